//! The plant's dynamic state as bytes, for FMU state save/restore and serialisation.

use crate::numerics::solver::Armed;
use crate::{Mode, Plant, N_PLAYS};

impl Plant {
    pub fn save_state(&self, out: &mut Vec<u8>) {
        let mut w = inchworm_state_bytes::Writer(out);
        w.f64(self.state.time);
        for v in
            self.state.z.iter().chain(self.state.earth.iter()).chain(self.state.nonearth.iter())
        {
            w.f64(*v);
        }
        w.u8(u8::from(self.state.earth_closed));
        w.u8(u8::from(self.state.nonearth_closed));
        w.u8(self.state.mode as u8);
        for m in self.state.hysteresis.memory {
            w.f64(m);
        }
        w.u8(self.state.hysteresis.sliding);
        w.u8(self.state.hysteresis.direction as u8);
        w.f64(self.state.drive_offset);
        w.u64(u64::from(self.state.slip_events));
        w.u64(self.state.encoder_counts as u64);
        w.u64(self.state.rng);
    }

    /// Restores a state written by `save_state`; on error the plant is unchanged.
    pub fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let mut r = inchworm_state_bytes::Reader::new(bytes, "plant state");
        let mut next = self.clone();
        next.state.time = r.f64()?;
        for v in next
            .state
            .z
            .iter_mut()
            .chain(next.state.earth.iter_mut())
            .chain(next.state.nonearth.iter_mut())
        {
            *v = r.f64()?;
        }
        next.state.earth_closed = r.bool()?;
        next.state.nonearth_closed = r.bool()?;
        next.state.mode = match r.u8()? {
            1 => Mode::Hold,
            2 => Mode::Locked,
            3 => Mode::Drive,
            4 => Mode::Free,
            m => return Err(format!("plant state: invalid mode {m}")),
        };
        for m in next.state.hysteresis.memory.iter_mut() {
            *m = r.f64()?;
        }
        next.state.hysteresis.sliding = r.u8()?;
        next.state.hysteresis.direction = r.u8()? as i8;
        next.state.drive_offset = r.f64()?;
        next.state.slip_events =
            u32::try_from(r.u64()?).map_err(|_| "plant state: slip count out of range")?;
        next.state.encoder_counts = r.u64()? as i64;
        next.state.rng = r.u64()?;
        r.finish()?;
        next.state.armed = Armed::of(&next.state.hysteresis);
        if next.state.hysteresis.sliding >= 1 << N_PLAYS
            || !(-1..=1).contains(&next.state.hysteresis.direction)
        {
            return Err("plant state: invalid hysteresis flags".into());
        }
        if Mode::from_brakes(next.state.earth_closed, next.state.nonearth_closed) != next.state.mode
        {
            return Err("plant state: mode disagrees with the brakes".into());
        }
        if !next.state.z.iter().all(|v| v.is_finite()) || !next.state.time.is_finite() {
            return Err("plant state: non-finite value".into());
        }
        *self = next;
        Ok(())
    }
}
