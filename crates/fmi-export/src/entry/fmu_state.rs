//! The FMU state (FMI 2.0 section 2.1.8, FMI 3.0 section 2.2.10): snapshots handed out
//! and taken back, and their serialized form.

use std::ffi::c_void;

use super::call::{slice, slice_mut, with_instance};
use crate::instance::*;
use crate::state::*;
use crate::{model_description, state_blob, Model};

impl<S: Standard, M: Model> Instance<S, M> {
    /// The snapshot behind `state` if this instance handed it out.
    unsafe fn own_snapshot<'a>(&self, state: *mut c_void) -> Option<&'a mut Snapshot<M>> {
        let p = state as *mut Snapshot<M>;
        self.snapshots.contains(&p).then(|| &mut *p)
    }

    /// Stores `snap` into `*slot`: in place if it already holds one of ours, else anew.
    unsafe fn store_snapshot(&mut self, slot: *mut *mut c_void, snap: Snapshot<M>) -> Status {
        if let Some(existing) = self.own_snapshot(*slot) {
            *existing = snap;
        } else {
            let p = Box::into_raw(Box::new(snap));
            self.snapshots.push(p);
            *slot = p as *mut c_void;
        }
        OK
    }

    fn not_ours(&self, func: &str) -> Status {
        let (p, s) = (S::PREFIX, S::FMU_STATE);
        self.refuse(
            func,
            format_args!("{s} was not created by {p}Get{s} of this instance (or was freed)"),
        )
    }
}

pub unsafe fn get_fmu_state<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    slot: *mut *mut c_void,
) -> Status {
    with_instance::<S, M>(c, func, STATE_CALLS, |inst| {
        if slot.is_null() {
            return inst.refuse(func, format_args!("{} is NULL", S::FMU_STATE));
        }
        if inst.state == State::Error && !S::GET_STATE_IN_ERROR {
            return inst.refuse(
                func,
                format_args!("an instance in Error state has no state worth saving"),
            );
        }
        let snap = inst.snapshot();
        inst.store_snapshot(slot, snap)
    })
}

pub unsafe fn set_fmu_state<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    state: *mut c_void,
) -> Status {
    with_instance::<S, M>(c, func, STATE_CALLS, |inst| match inst.own_snapshot(state) {
        Some(s) => {
            let s = s.clone();
            inst.restore(&s);
            OK
        }
        None => inst.not_ours(func),
    })
}

pub unsafe fn free_fmu_state<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    slot: *mut *mut c_void,
) -> Status {
    with_instance::<S, M>(c, func, STATE_CALLS, |inst| {
        if slot.is_null() || (*slot).is_null() {
            return OK;
        }
        let p = *slot as *mut Snapshot<M>;
        match inst.snapshots.iter().position(|&s| s == p) {
            Some(i) => {
                inst.snapshots.swap_remove(i);
                drop(Box::from_raw(p));
                *slot = std::ptr::null_mut();
                OK
            }
            None => inst.not_ours(func),
        }
    })
}

/// This build of `M` under standard `S`, as its states carry it.
fn build<S: Standard, M: Model>() -> state_blob::Build<'static> {
    state_blob::Build {
        major: S::MAJOR,
        model: M::info().model_identifier,
        guid: model_description::guid::<M>(),
    }
}

fn encode<S: Standard, M: Model>(s: &Snapshot<M>) -> Result<Vec<u8>, String> {
    let payload = state_blob::save_model(&s.model)?;
    let h = state_blob::Header {
        state: s.state,
        time: s.time,
        start_time: s.start_time,
        stop_time: s.stop_time,
    };
    Ok(state_blob::encode(&build::<S, M>(), &h, &payload))
}

/// Serializes the snapshot behind `state` and hands the bytes to `out`.
unsafe fn with_blob<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    state: *mut c_void,
    out: impl FnOnce(&Instance<S, M>, Vec<u8>) -> Status,
) -> Status {
    with_instance::<S, M>(c, func, STATE_CALLS, |inst| {
        let Some(s) = inst.own_snapshot(state) else { return inst.not_ours(func) };
        match encode::<S, M>(s) {
            Ok(blob) => out(inst, blob),
            Err(why) => inst.refuse(func, format_args!("{why}")),
        }
    })
}

pub unsafe fn serialized_size<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    state: *mut c_void,
    size: *mut usize,
) -> Status {
    with_blob::<S, M>(c, func, state, |inst, blob| {
        if size.is_null() {
            return inst.refuse(func, format_args!("size is NULL"));
        }
        *size = blob.len();
        OK
    })
}

pub unsafe fn serialize<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    state: *mut c_void,
    (bytes, size): (*mut u8, usize),
) -> Status {
    with_blob::<S, M>(c, func, state, |inst, blob| {
        let Some(out) = slice_mut(bytes, size) else {
            return inst.refuse(func, format_args!("serializedState is NULL"));
        };
        if out.len() < blob.len() {
            let (have, need) = (out.len(), blob.len());
            return inst.refuse(
                func,
                format_args!("buffer of {have} bytes is smaller than the state ({need} bytes)"),
            );
        }
        out[..blob.len()].copy_from_slice(&blob);
        OK
    })
}

pub unsafe fn deserialize<S: Standard, M: Model>(
    c: *mut c_void,
    func: &str,
    (bytes, size): (*const u8, usize),
    slot: *mut *mut c_void,
) -> Status {
    with_instance::<S, M>(c, func, STATE_CALLS, |inst| {
        let (Some(blob), false) = (slice(bytes, size), slot.is_null()) else {
            return inst.refuse(func, format_args!("serializedState or {} is NULL", S::FMU_STATE));
        };
        let (header, payload) =
            match state_blob::decode(blob).and_then(|(wrote, header, payload)| {
                build::<S, M>().check(&wrote).map(|()| (header, payload))
            }) {
                Ok(x) => x,
                Err(why) => return inst.refuse(func, format_args!("{why}")),
            };
        if header.state as u16 & S::STATES == 0 {
            let (s, v) = (header.state.name(), S::VERSION);
            return inst.refuse(
                func,
                format_args!("serialized state was saved in FMI 2.0 state {s}, which {v} has not"),
            );
        }
        if header.state as u16 & inst.interface.states() == 0 {
            let (s, i) = (S::state_name(header.state), inst.interface.name());
            return inst.refuse(
                func,
                format_args!("serialized state was saved in state {s}, which {i} has not"),
            );
        }
        let model = match state_blob::load_model::<M>(payload) {
            Ok(m) => m,
            Err(why) => return inst.refuse(func, format_args!("model state refused: {why}")),
        };
        let snap = Snapshot {
            model,
            state: header.state,
            time: header.time,
            start_time: header.start_time,
            stop_time: header.stop_time,
        };
        inst.store_snapshot(slot, snap)
    })
}
