//! FMU states of an [`Instance`]: saved, restored, freed, serialized and read back. A state
//! keeps the communication grid of its time beside the FMU's own state, so that the time
//! after a restore is the state's; the instance holds every state it gave out and frees
//! those left when it is dropped.

use crate::backend::RawState;
use crate::{FmuError, Instance};

/// A saved FMU state, held by the [`Instance`] it was taken from and addressed by this
/// handle. The FMU's memory is freed by [`Instance::free_state`] or, at the latest, when
/// the instance is dropped (before it is freed), so a state never outlives its instance; a
/// handle used with another instance, or after it was freed, is refused.
#[derive(Debug, PartialEq, Eq, Hash)]
pub struct FmuState {
    owner: u64,
    id: u64,
}

/// What a state holds besides the FMU's own: the communication grid at the time it was
/// taken, so that the time after a restore is the time of the state.
#[derive(Clone, Copy)]
pub(crate) struct Saved {
    pub(crate) raw: RawState,
    start_time: f64,
    steps_done: u64,
    step_size: f64,
}

/// The first bytes of a serialized state, then version 1's grid: start time, steps done,
/// step size (little-endian), then the FMU's own bytes.
const STATE_MAGIC: &[u8; 8] = b"IWSTATE1";
const STATE_HEADER: usize = 8 + 3 * 8;

impl Instance {
    /// `fmi2GetFMUstate` / `fmi3GetFMUState`: saves the FMU's state and the communication
    /// time. Fails with [`FmuError::Unsupported`] unless the FMU declares
    /// `canGetAndSetFMUstate` (FMI 2.0) / `canGetAndSetFMUState` (FMI 3.0).
    pub fn get_state(&mut self) -> Result<FmuState, FmuError> {
        let raw = self.backend.states().get(&mut self.cx)?;
        Ok(self.hold(raw))
    }

    /// `fmi2SetFMUstate` / `fmi3SetFMUState`: back to `state`, time included.
    pub fn set_state(&mut self, state: &FmuState) -> Result<(), FmuError> {
        let saved = self.saved(state, self.backend.states().names().set)?;
        self.backend.states().set(&mut self.cx, saved.raw)?;
        self.cx.start_time = saved.start_time;
        self.cx.steps_done = saved.steps_done;
        self.cx.step_size = saved.step_size;
        Ok(())
    }

    /// `fmi2FreeFMUstate` / `fmi3FreeFMUState`. Dropping the instance frees the states
    /// still held.
    pub fn free_state(&mut self, state: FmuState) -> Result<(), FmuError> {
        let saved = self.saved(&state, self.backend.states().names().free)?;
        self.states.remove(&state.id);
        self.backend.states().free(&mut self.cx, saved.raw)
    }

    /// `fmi2SerializeFMUstate` / `fmi3SerializeFMUState` (with the size call first): the
    /// state as bytes, to be read back by [`Instance::deserialize_state`] of an instance of
    /// the same FMU. The bytes are a short header (the communication grid) and the FMU's
    /// own serialization.
    pub fn serialize_state(&mut self, state: &FmuState) -> Result<Vec<u8>, FmuError> {
        let saved = self.saved(state, self.backend.states().names().serialize)?;
        let fmu = self.backend.states().serialize(&mut self.cx, saved.raw)?;
        let mut out = Vec::with_capacity(STATE_HEADER + fmu.len());
        out.extend_from_slice(STATE_MAGIC);
        out.extend_from_slice(&saved.start_time.to_le_bytes());
        out.extend_from_slice(&saved.steps_done.to_le_bytes());
        out.extend_from_slice(&saved.step_size.to_le_bytes());
        out.extend_from_slice(&fmu);
        Ok(out)
    }

    /// `fmi2DeSerializeFMUstate` / `fmi3DeserializeFMUState`: a new state from bytes of
    /// [`Instance::serialize_state`]; [`Instance::set_state`] restores it.
    pub fn deserialize_state(&mut self, bytes: &[u8]) -> Result<FmuState, FmuError> {
        let f = self.backend.states().names().deserialize;
        self.cx.alive(f)?;
        let header = bytes.get(..STATE_HEADER).filter(|h| h.starts_with(STATE_MAGIC));
        let Some(header) = header else {
            return Err(self.cx.invalid(
                f,
                format!(
                    "{} bytes that are not a state serialized by this importer (no {} header)",
                    bytes.len(),
                    String::from_utf8_lossy(STATE_MAGIC)
                ),
            ));
        };
        let word = |i: usize| {
            let mut w = [0u8; 8];
            w.copy_from_slice(&header[8 + 8 * i..16 + 8 * i]);
            w
        };
        let (start_time, steps_done, step_size) =
            (f64::from_le_bytes(word(0)), u64::from_le_bytes(word(1)), f64::from_le_bytes(word(2)));
        if !(start_time.is_finite() && step_size.is_finite() && step_size >= 0.0) {
            return Err(self.cx.invalid(f, "the serialized communication grid is damaged"));
        }
        let raw = self.backend.states().deserialize(&mut self.cx, &bytes[STATE_HEADER..])?;
        let state = self.hold(raw);
        if let Some(s) = self.states.get_mut(&state.id) {
            (s.start_time, s.steps_done, s.step_size) = (start_time, steps_done, step_size);
        }
        Ok(state)
    }

    /// How many saved states this instance holds.
    pub fn states_held(&self) -> usize {
        self.states.len()
    }

    fn hold(&mut self, raw: RawState) -> FmuState {
        let id = self.next_state;
        self.next_state += 1;
        let (start_time, steps_done, step_size) =
            (self.cx.start_time, self.cx.steps_done, self.cx.step_size);
        self.states.insert(id, Saved { raw, start_time, steps_done, step_size });
        FmuState { owner: self.owner, id }
    }

    fn saved(&self, state: &FmuState, function: &'static str) -> Result<Saved, FmuError> {
        self.cx.alive(function)?;
        match self.states.get(&state.id) {
            Some(s) if state.owner == self.owner => Ok(*s),
            _ => Err(self
                .cx
                .invalid(function, "the state was not taken from this instance, or was freed")),
        }
    }
}
