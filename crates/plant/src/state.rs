//! The plant's dynamic state as bytes, for FMU state save/restore and serialisation.

use crate::solver::Armed;
use crate::{Mode, Plant, N_PLAYS};

impl Plant {
    pub fn save_state(&self, out: &mut Vec<u8>) {
        let mut w = inchworm_state_bytes::Writer(out);
        w.f64(self.time);
        for v in self.z.iter().chain(self.earth.iter()).chain(self.nonearth.iter()) {
            w.f64(*v);
        }
        w.u8(u8::from(self.earth_closed));
        w.u8(u8::from(self.nonearth_closed));
        w.u8(self.mode as u8);
        for m in self.hysteresis.memory {
            w.f64(m);
        }
        w.u8(self.hysteresis.sliding);
        w.u8(self.hysteresis.direction as u8);
        w.f64(self.drive_offset);
        w.u64(u64::from(self.slip_events));
        w.u64(self.encoder_counts as u64);
        w.u64(self.rng);
    }

    /// Restores a state written by `save_state`; on error the plant is unchanged.
    pub fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let mut r = inchworm_state_bytes::Reader::new(bytes, "plant state");
        let mut next = self.clone();
        next.time = r.f64()?;
        for v in next.z.iter_mut().chain(next.earth.iter_mut()).chain(next.nonearth.iter_mut()) {
            *v = r.f64()?;
        }
        next.earth_closed = r.bool()?;
        next.nonearth_closed = r.bool()?;
        next.mode = match r.u8()? {
            1 => Mode::Hold,
            2 => Mode::Locked,
            3 => Mode::Drive,
            4 => Mode::Free,
            m => return Err(format!("plant state: invalid mode {m}")),
        };
        for m in next.hysteresis.memory.iter_mut() {
            *m = r.f64()?;
        }
        next.hysteresis.sliding = r.u8()?;
        next.hysteresis.direction = r.u8()? as i8;
        next.drive_offset = r.f64()?;
        next.slip_events =
            u32::try_from(r.u64()?).map_err(|_| "plant state: slip count out of range")?;
        next.encoder_counts = r.u64()? as i64;
        next.rng = r.u64()?;
        r.finish()?;
        next.armed = Armed::of(&next.hysteresis);
        if next.hysteresis.sliding >= 1 << N_PLAYS || !(-1..=1).contains(&next.hysteresis.direction)
        {
            return Err("plant state: invalid hysteresis flags".into());
        }
        if Mode::from_brakes(next.earth_closed, next.nonearth_closed) != next.mode {
            return Err("plant state: mode disagrees with the brakes".into());
        }
        if !next.z.iter().all(|v| v.is_finite()) || !next.time.is_finite() {
            return Err("plant state: non-finite value".into());
        }
        *self = next;
        Ok(())
    }
}
