//! The instances this library created and has not freed: the one check that every entry
//! point makes of its instance pointer before it reads through it.
//!
//! A master can hand an entry point anything: NULL, a pointer to freed memory, another
//! FMU's instance (from another library, or from this library but of another model or
//! standard), or junk. Only a pointer this library returned from an instantiation, not
//! freed since, and of the entry point's model and standard, is read; everything else is
//! refused without touching the memory it points to. The registry maps each live
//! instance's address to the type it was created as ([`TypeId`] of `Instance<S, M>`).
//!
//! The hot path (a master calling `Get*`/`Set*`/`DoStep` on the same few instances) does
//! not take the registry's lock: each thread keeps the last few instances it found live,
//! valid while no instance of this library has been freed since (an epoch counter that
//! every free advances). A hit costs a thread-local read and one atomic load;
//! `cargo bench -p inchworm-fmu-models --bench instance_check` measures both side by side.

use std::any::TypeId;
use std::cell::Cell;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard, Once};

/// Live instances: address → the type they were created as and the instance's [`Guard`].
static LIVE: Mutex<BTreeMap<usize, (TypeId, &'static Guard)>> = Mutex::new(BTreeMap::new());

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

/// Advanced by every free, after the instance left [`LIVE`]: a thread's cache of live
/// instances is good only for the epoch it was filled in.
static EPOCH: AtomicU64 = AtomicU64::new(0);

/// How many instances a thread remembers: a master's loop touches one instance of a model
/// per component, and a system rarely has more than a few components of one FMU.
const CACHED: usize = 4;

/// An instance found live: its address, type and guard.
type Cached = (usize, TypeId, &'static Guard);

/// A thread's cache of instances found live: valid while `epoch` is [`EPOCH`].
struct Recent {
    epoch: Cell<u64>,
    /// The last instances found live, newest first, with their guards.
    slots: [Cell<Option<Cached>>; CACHED],
}

thread_local! {
    static RECENT: Recent = const {
        Recent { epoch: Cell::new(u64::MAX), slots: [const { Cell::new(None) }; CACHED] }
    };
}

fn live() -> MutexGuard<'static, BTreeMap<usize, (TypeId, &'static Guard)>> {
    // The map is consistent after every operation on it, so a panic elsewhere while the
    // lock was held (there is none in this module) leaves nothing half done.
    LIVE.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Records `ptr` as a live instance of `T`; called once, right after it is allocated.
pub(crate) fn register<T: 'static>(ptr: *mut T) {
    static PINNED: Once = Once::new();
    PINNED.call_once(pin_library);
    let guard: &'static Guard = Box::leak(Box::default());
    live().insert(ptr as usize, (TypeId::of::<T>(), guard));
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
    let key = (ptr as usize, TypeId::of::<T>());
    // Acquire: a free that happened before this call (the only way a master can use a
    // pointer after freeing it) is seen, so a stale cache is not trusted.
    let epoch = EPOCH.load(Ordering::Acquire);
    RECENT.with(|recent| {
        let current = recent.epoch.get() == epoch;
        if current {
            let hit = recent.slots.iter().find_map(|s| s.get().filter(|e| (e.0, e.1) == key));
            if let Some(entry) = hit {
                return Some(entry.2);
            }
        }
        let guard = live().get(&key.0).filter(|e| e.0 == key.1).map(|e| e.1)?;
        if !current {
            recent.slots.iter().for_each(|s| s.set(None));
            recent.epoch.set(epoch);
        }
        // Newest first: the others move one slot down, the oldest drops out.
        let mut carry = Some((key.0, key.1, guard));
        for s in &recent.slots {
            carry = s.replace(carry);
        }
        Some(guard)
    })
}

/// Removes `ptr` if it is a live instance of `T` and no call runs on it, and says whether
/// it was removed: only then may the caller free it. A second free of the same pointer
/// finds nothing; a free while another thread's call runs is refused (and counted as that
/// call's refusal). The guard stays allocated, taken for good: a thread that found the
/// instance live just before the free finds it busy and touches nothing (a few bytes per
/// instance ever made).
pub(crate) fn unregister<T: 'static>(ptr: *const T) -> bool {
    let mut map = live();
    let Some(&(_, guard)) = map.get(&(ptr as usize)).filter(|e| e.0 == TypeId::of::<T>()) else {
        return false;
    };
    if !guard.enter() {
        return false;
    }
    map.remove(&(ptr as usize));
    // Release, with the lock still held: a thread that sees the new epoch also sees
    // the instance gone from the map.
    EPOCH.fetch_add(1, Ordering::Release);
    true
}

/// How many instances of this library are live (for tests of leaks and double frees).
pub fn live_count() -> usize {
    live().len()
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
        assert!(is_live(a) && is_live(a), "found, then found in the cache");
        assert!(!is_live(a as *const B), "the same address as another type");
        assert!(is_live(b));
        assert!(!unregister(a as *const B), "not freed as another type");
        assert!(is_live(a));
        assert!(unregister(a));
        assert!(!is_live(a), "the cache forgets it with the epoch");
        assert!(!unregister(a), "a second free finds nothing");
        assert!(unregister(b));
        // SAFETY: both came from Box::into_raw and are freed once.
        unsafe {
            drop(Box::from_raw(a));
            drop(Box::from_raw(b));
        }
    }

    #[test]
    fn a_free_on_one_thread_is_seen_by_another_s_cache() {
        let a = Box::into_raw(Box::new(A(3)));
        register(a);
        let addr = a as usize;
        assert!(std::thread::spawn(move || is_live(addr as *const A)).join().unwrap());
        assert!(is_live(a), "cached on this thread");
        let other = std::thread::spawn(move || {
            assert!(is_live(addr as *const A));
            unregister(addr as *const A)
        });
        assert!(other.join().unwrap());
        assert!(!is_live(a), "freed on the other thread, so not live here");
        // SAFETY: from Box::into_raw, freed once.
        unsafe { drop(Box::from_raw(a)) };
    }
}
