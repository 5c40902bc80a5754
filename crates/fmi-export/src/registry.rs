//! The instances this library created and has not freed: the one check that every entry
//! point makes of its instance pointer before it reads through it.
//!
//! A master can hand an entry point anything: NULL, a pointer to freed memory, another
//! FMU's instance (from another library, or from this library but of another model or
//! standard), or junk. Only a pointer this library returned from an instantiation, not
//! freed since, and of the entry point's model and standard, is read; everything else is
//! refused without touching the memory it points to.
//!
//! Each live instance has an [`Entry`]: its address, the type it was created as
//! ([`TypeId`] of `Instance<S, M>`) and its [`Guard`]. The entries sit in a fixed table of
//! [`SLOTS`] atomic pointers, each instance in the slot its address hashes to, so the
//! check of every call (a master calling `Get*`/`Set*`/`DoStep` on the same few
//! instances) is one atomic load and two compares: no lock, no thread-local. An instance
//! whose slot another holds goes to an overflow map under the registry's lock, and moves
//! into the slot when its holder is freed; a look-up that misses its slot takes the lock
//! only while the map holds any. Registering and freeing take the lock.
//! `cargo bench -p inchworm-fmu-models --bench instance_check` measures the look-up.
//!
//! An entry is never freed (a few dozen bytes per instance ever made), and a freed
//! instance's guard stays taken for good: a thread that loaded the entry just before the
//! free finds it busy and touches nothing.

use std::any::TypeId;
use std::collections::BTreeMap;
use std::ptr;
use std::sync::atomic::{AtomicBool, AtomicPtr, AtomicU32, AtomicUsize, Ordering};
use std::sync::{Mutex, MutexGuard, Once};

/// What the calls into one instance share across threads, allocated beside the instance
/// (not in it: a running call holds the instance exclusively, and another thread's call
/// must not touch that memory): whether a call runs, and how many calls were refused
/// because one did.
#[derive(Debug, Default)]
pub struct Guard {
    busy: AtomicBool,
    refused: AtomicU32,
}

impl Guard {
    /// Takes the instance for one call, or counts a refusal if another call has it.
    #[inline]
    pub fn enter(&self) -> bool {
        let free = self.busy.compare_exchange(false, true, Ordering::Acquire, Ordering::Relaxed);
        if free.is_err() {
            self.refused.fetch_add(1, Ordering::Relaxed);
        }
        free.is_ok()
    }

    /// Hands the instance back.
    #[inline]
    pub fn leave(&self) {
        self.busy.store(false, Ordering::Release);
    }

    /// The calls refused since the last time this was asked. Asked at the end of every
    /// call, which almost always finds none: a load then, not a locked swap. A refusal
    /// counted after the load is taken by the next call's ask, as one counted after the
    /// swap would be.
    #[inline]
    pub fn take_refused(&self) -> u32 {
        match self.refused.load(Ordering::Relaxed) {
            0 => 0,
            _ => self.refused.swap(0, Ordering::Relaxed),
        }
    }
}

/// One live instance: immutable once published but for its guard's atomics.
struct Entry {
    addr: usize,
    ty: TypeId,
    guard: Guard,
}

/// How many slots the table has: far more than a process has instances of one library,
/// so that two live instances rarely hash to one slot (32 KiB of pointers).
pub const SLOTS: usize = 1 << SLOT_BITS;
const SLOT_BITS: u32 = 12;

/// The live instances that hold their slot; written only under [`WRITE`]'s lock.
static TABLE: [AtomicPtr<Entry>; SLOTS] = [const { AtomicPtr::new(ptr::null_mut()) }; SLOTS];

/// The registry's lock, and what it holds besides the table.
struct Registry {
    /// Live instances whose slot another holds, by (slot, address): the first of a slot is
    /// the one that moves in when the slot's holder is freed.
    overflow: BTreeMap<(usize, usize), &'static Entry>,
    /// Live instances, in the table and in `overflow`.
    live: usize,
}

static WRITE: Mutex<Registry> = Mutex::new(Registry { overflow: BTreeMap::new(), live: 0 });

/// How many instances `overflow` holds, read without the lock: a look-up that misses its
/// slot takes the lock only when this is not 0. Stored (Release) after every change of
/// the table that goes with a change of `overflow`.
static OVERFLOWED: AtomicUsize = AtomicUsize::new(0);

/// The slot of the instance at `addr`: Fibonacci hashing of the address, whose low bits
/// (the allocation's alignment) are the same for every instance.
#[inline(always)]
fn slot(addr: usize) -> usize {
    ((addr as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> (64 - SLOT_BITS)) as usize
}

fn write() -> MutexGuard<'static, Registry> {
    // The registry is consistent after every operation on it, so a panic elsewhere while
    // the lock was held (there is none in this module) leaves nothing half done.
    WRITE.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// The entry in slot `i` if it is the instance at `addr` of type `ty`.
#[inline(always)]
fn in_slot(i: usize, addr: usize, ty: TypeId) -> Option<&'static Entry> {
    // Acquire: the entry's fields, written before it was published (Release), are seen.
    let entry = TABLE[i].load(Ordering::Acquire);
    // SAFETY: a non-null slot holds a leaked entry, never freed.
    let entry = unsafe { entry.as_ref() }?;
    (entry.addr == addr && entry.ty == ty).then_some(entry)
}

/// Records `ptr` as a live instance of `T`; called once, right after it is allocated.
pub(crate) fn register<T: 'static>(ptr: *mut T) {
    static PINNED: Once = Once::new();
    PINNED.call_once(pin_library);
    let addr = ptr as usize;
    let entry: &'static Entry =
        Box::leak(Box::new(Entry { addr, ty: TypeId::of::<T>(), guard: Guard::default() }));
    let mut registry = write();
    let i = slot(addr);
    match TABLE[i].load(Ordering::Relaxed).is_null() {
        // Release: a thread that loads the entry sees its fields.
        true => TABLE[i].store(entry as *const Entry as *mut Entry, Ordering::Release),
        false => {
            registry.overflow.insert((i, addr), entry);
            OVERFLOWED.store(registry.overflow.len(), Ordering::Release);
        }
    }
    registry.live += 1;
}

/// Keeps this library loaded until the process ends, once it has made an instance. The
/// registry lives in the library's memory: a master that unloads the library while its
/// instances live and loads it again (Ecos does, between components of one FMU) would
/// otherwise find a new, empty registry that refuses every instance it made before. If the
/// system refuses, the library stays as unloadable as it was.
fn pin_library() {
    // An address inside this library.
    let here = pin_library as fn() as *const std::ffi::c_void;
    #[cfg(unix)]
    // SAFETY: `info` is written by dladdr; the name it gives is that of a loaded object,
    // which dlopen with RTLD_NOLOAD only finds again (and marks never to unload).
    unsafe {
        let mut info: libc::Dl_info = std::mem::zeroed();
        if libc::dladdr(here, &mut info) != 0 && !info.dli_fname.is_null() {
            let flags = libc::RTLD_NOW | libc::RTLD_NOLOAD | libc::RTLD_NODELETE;
            libc::dlopen(info.dli_fname, flags);
        }
    }
    #[cfg(windows)]
    {
        const PIN: u32 = 0x1;
        const FROM_ADDRESS: u32 = 0x4;
        extern "system" {
            fn GetModuleHandleExW(
                flags: u32,
                name: *const u16,
                module: *mut *mut std::ffi::c_void,
            ) -> i32;
        }
        let mut module = std::ptr::null_mut();
        // SAFETY: with FROM_ADDRESS, `name` is an address inside the module to pin.
        unsafe { GetModuleHandleExW(PIN | FROM_ADDRESS, here as *const u16, &mut module) };
    }
    #[cfg(not(any(unix, windows)))]
    let _ = here;
}

/// Whether `ptr` is a live instance of `T` created by this library. Reads nothing
/// through `ptr`.
#[inline]
pub fn is_live<T: 'static>(ptr: *const T) -> bool {
    guard_of(ptr).is_some()
}

/// The guard of `ptr` if it is a live instance of `T` created by this library. Reads
/// nothing through `ptr`.
#[inline]
pub fn guard_of<T: 'static>(ptr: *const T) -> Option<&'static Guard> {
    let (addr, ty) = (ptr as usize, TypeId::of::<T>());
    match in_slot(slot(addr), addr, ty) {
        Some(entry) => Some(&entry.guard),
        None => missed(addr, ty),
    }
}

/// [`guard_of`] for a pointer its slot does not hold: an instance in the overflow map, or
/// one that is not live (NULL, freed, foreign, of another type).
#[cold]
#[inline(never)]
fn missed(addr: usize, ty: TypeId) -> Option<&'static Guard> {
    let i = slot(addr);
    // Acquire, then the slot again: an instance that moved from the map into its slot
    // (which the count's store follows) is found there.
    let overflowed = OVERFLOWED.load(Ordering::Acquire);
    if let Some(entry) = in_slot(i, addr, ty) {
        return Some(&entry.guard);
    }
    if overflowed == 0 {
        return None;
    }
    let registry = write();
    // Under the lock the table and the map are as the last change left them together.
    let entry = in_slot(i, addr, ty)
        .or_else(|| registry.overflow.get(&(i, addr)).copied().filter(|e| e.ty == ty))?;
    Some(&entry.guard)
}

/// Removes `ptr` if it is a live instance of `T` and no call runs on it, and says whether
/// it was removed: only then may the caller free it. A second free of the same pointer
/// finds nothing; a free while another thread's call runs is refused (and counted as that
/// call's refusal). The guard stays taken for good: a thread that found the instance live
/// just before the free finds it busy and touches nothing.
pub(crate) fn unregister<T: 'static>(ptr: *const T) -> bool {
    let (addr, ty) = (ptr as usize, TypeId::of::<T>());
    let i = slot(addr);
    let mut registry = write();
    if let Some(entry) = in_slot(i, addr, ty) {
        if !entry.guard.enter() {
            return false;
        }
        // The first instance waiting for this slot moves in, else the slot is cleared;
        // Release: a thread that loads the slot after this sees the instance gone.
        let next = registry.overflow.range((i, 0)..=(i, usize::MAX)).next().map(|(k, e)| (*k, *e));
        match next {
            Some((key, next)) => {
                TABLE[i].store(next as *const Entry as *mut Entry, Ordering::Release);
                registry.overflow.remove(&key);
                OVERFLOWED.store(registry.overflow.len(), Ordering::Release);
            }
            None => TABLE[i].store(ptr::null_mut(), Ordering::Release),
        }
    } else {
        let Some(entry) = registry.overflow.get(&(i, addr)).filter(|e| e.ty == ty) else {
            return false;
        };
        if !entry.guard.enter() {
            return false;
        }
        registry.overflow.remove(&(i, addr));
        OVERFLOWED.store(registry.overflow.len(), Ordering::Release);
    }
    registry.live -= 1;
    true
}

/// How many instances of this library are live (for tests of leaks and double frees).
pub fn live_count() -> usize {
    write().live
}

#[cfg(test)]
mod tests {
    use super::*;

    struct A(#[allow(dead_code)] u64);
    struct B(#[allow(dead_code)] u64);

    #[test]
    fn only_a_registered_pointer_of_its_own_type_is_live_until_freed() {
        let a = Box::into_raw(Box::new(A(1)));
        let b = Box::into_raw(Box::new(B(2)));
        assert!(!is_live(a), "not registered yet");
        register(a);
        register(b);
        assert!(is_live(a) && is_live(a), "found, and found again");
        assert!(!is_live(a as *const B), "the same address as another type");
        assert!(is_live(b));
        assert!(!unregister(a as *const B), "not freed as another type");
        assert!(is_live(a));
        assert!(unregister(a));
        assert!(!is_live(a), "freed");
        assert!(!unregister(a), "a second free finds nothing");
        assert!(unregister(b));
        // SAFETY: both came from Box::into_raw and are freed once.
        unsafe {
            drop(Box::from_raw(a));
            drop(Box::from_raw(b));
        }
    }

    #[test]
    fn a_free_on_one_thread_is_seen_by_another() {
        let a = Box::into_raw(Box::new(A(3)));
        register(a);
        let addr = a as usize;
        assert!(std::thread::spawn(move || is_live(addr as *const A)).join().unwrap());
        assert!(is_live(a));
        let other = std::thread::spawn(move || {
            assert!(is_live(addr as *const A));
            unregister(addr as *const A)
        });
        assert!(other.join().unwrap());
        assert!(!is_live(a), "freed on the other thread, so not live here");
        // SAFETY: from Box::into_raw, freed once.
        unsafe { drop(Box::from_raw(a)) };
    }

    /// The instances of this test only, so that no other test's can take their slots or
    /// addresses while it runs.
    struct Many(#[allow(dead_code)] u64);

    /// More instances than slots: every one is live, through its slot or the overflow
    /// map, each of its own type only; a freed one is not, whichever slot or map held it,
    /// and the others stay live as overflowed ones move into the freed slots.
    #[test]
    fn more_instances_than_slots_are_all_found_until_freed() {
        let n = SLOTS + SLOTS / 2;
        // Kept allocated until the end, so no address is reused while the test looks.
        let all: Vec<*mut Many> = (0..n as u64).map(|k| Box::into_raw(Box::new(Many(k)))).collect();
        all.iter().for_each(|&p| register(p));
        assert!(OVERFLOWED.load(Ordering::Relaxed) >= n - SLOTS, "the map holds the rest");
        assert!(all.iter().all(|&p| is_live(p)));
        assert!(all.iter().all(|&p| !is_live(p as *const A)), "of another type");
        let (freed, kept) = all.split_at(n / 2);
        assert!(freed.iter().all(|&p| unregister(p)));
        assert!(freed.iter().all(|&p| !is_live(p)), "freed");
        assert!(freed.iter().all(|&p| !unregister(p)), "a second free finds nothing");
        assert!(kept.iter().all(|&p| is_live(p)), "moved into freed slots or still waiting");
        assert!(kept.iter().all(|&p| unregister(p)));
        assert!(all.iter().all(|&p| !is_live(p)));
        for p in all {
            // SAFETY: from Box::into_raw, freed once.
            unsafe { drop(Box::from_raw(p)) };
        }
    }

    /// An instance moving from the overflow map into its slot, as its holder is freed on
    /// another thread, is found by every look-up of a thread that checks it meanwhile.
    #[test]
    fn an_instance_moving_into_its_slot_is_never_missed() {
        struct Moving(#[allow(dead_code)] u64);
        let ty = TypeId::of::<Moving>();
        let mut moved = 0;
        while moved < 20 {
            // Two instances that hash to one slot (some 80 allocations find a pair).
            let mut boxes: Vec<*mut Moving> = Vec::new();
            let (holder, waiting) = loop {
                let p = Box::into_raw(Box::new(Moving(moved)));
                match boxes.iter().find(|&&q| slot(q as usize) == slot(p as usize)) {
                    Some(&q) => break (q, p),
                    None => boxes.push(p),
                }
            };
            boxes.push(waiting);
            register(holder);
            register(waiting);
            // Another test's instance may hold the slot: then try again.
            let (h, w) = (holder as usize, waiting as usize);
            if in_slot(slot(h), h, ty).is_some() && in_slot(slot(w), w, ty).is_none() {
                let looking =
                    std::thread::spawn(move || (0..20_000).all(|_| is_live(w as *const Moving)));
                assert!(unregister(holder));
                assert!(looking.join().unwrap(), "found throughout");
                // Moved in, unless another test's instance waited for the slot before it.
                moved += u64::from(in_slot(slot(w), w, ty).is_some());
            } else {
                assert!(unregister(holder));
            }
            assert!(is_live(waiting) && !is_live(holder));
            assert!(unregister(waiting));
            for p in boxes {
                // SAFETY: from Box::into_raw, freed once.
                unsafe { drop(Box::from_raw(p)) };
            }
        }
    }
}
