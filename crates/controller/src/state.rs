//! The controller's dynamic state as bytes (FMI get/set state, serialized FMU state):
//! the layout, its version and the checks that refuse a state from another
//! configuration.

use crate::analog::Analog;
use crate::compensator::Loop;
use crate::gait::Direction;
use crate::waveform::Plan;
use crate::{Controller, StepKind};

/// Layout version of [`Controller::save_state`]; raise it whenever the layout changes.
pub const STATE_VERSION: u8 = 1;

impl Controller {
    /// Appends the complete dynamic state (not the parameters), little-endian, headed by
    /// [`STATE_VERSION`] and the samples per step it was taken with.
    pub fn save_state(&self, out: &mut Vec<u8>) {
        let mut w = inchworm_state_bytes::Writer(out);
        w.u8(STATE_VERSION);
        w.u64(self.timing.samples as u64);
        for v in self.estimator.x.iter().chain(self.estimator.p.iter()) {
            w.f64(*v);
        }
        self.feedback.save(&mut w);
        w.u64(self.sample as u64);
        match self.current {
            StepKind::Idle => {
                w.u8(0);
                w.f64(0.0);
            }
            StepKind::Gait { direction, amplitude } => {
                w.u8(if direction == Direction::Forward { 1 } else { 2 });
                w.f64(amplitude);
            }
        }
        w.u8(u8::from(self.first));
        for v in self.enc.iter().chain(self.ext.iter()) {
            w.f64(*v);
        }
        w.u64(u64::from(self.full_steps_left));
        w.u8(if self.move_direction == Direction::Forward { 1 } else { 2 });
        match self.fraction_left {
            None => w.u8(0),
            Some(f) => {
                w.u8(1);
                w.f64(f);
            }
        }
        match self.plan {
            None => w.u8(0),
            Some(p) => {
                w.u8(1);
                w.f64(p.step_forward.unwrap_or(f64::NAN));
                w.f64(p.step_backward.unwrap_or(f64::NAN));
                w.u64(u64::from(p.n_steps));
                w.u8(p.direction as u8);
                w.f64(p.fraction);
                w.u8(u8::from(p.no_root));
            }
        }
        w.u64(self.iterations);
        // Only with the option on, so the default layout is unchanged.
        if self.params.analog {
            self.analog.save(&mut w);
        }
        if let Some(m) = &self.bdmap {
            m.save(&mut w);
        }
    }

    /// Restores what `save_state` wrote, for a controller with the same parameters; on
    /// error the controller is unchanged.
    pub fn load_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let mut r = inchworm_state_bytes::Reader::new(bytes, "controller state");
        let version = r.u8()?;
        if version != STATE_VERSION {
            return Err(format!("controller state has version {version}, this controller reads version {STATE_VERSION}"));
        }
        let samples = r.u64()?;
        if samples != self.timing.samples as u64 {
            return Err(format!("controller state was taken with samples_per_step = {samples}, this controller has {}", self.timing.samples));
        }
        let mut next = self.clone();
        for v in next.estimator.x.iter_mut() {
            *v = r.f64()?;
        }
        for v in next.estimator.p.iter_mut() {
            *v = r.f64()?;
        }
        next.feedback = Loop::load(&mut r)?;
        next.sample = r.u64()? as usize;
        let kind = r.u8()?;
        let amplitude = r.f64()?;
        next.current = match kind {
            0 => StepKind::Idle,
            1 => StepKind::Gait { direction: Direction::Forward, amplitude },
            2 => StepKind::Gait { direction: Direction::Backward, amplitude },
            k => return Err(format!("controller state: invalid step kind {k}")),
        };
        next.first = r.bool()?;
        for v in next.enc.iter_mut().chain(next.ext.iter_mut()) {
            *v = r.f64()?;
        }
        next.full_steps_left =
            u32::try_from(r.u64()?).map_err(|_| "controller state: step count out of range")?;
        next.move_direction = match r.u8()? {
            1 => Direction::Forward,
            2 => Direction::Backward,
            d => return Err(format!("controller state: invalid move direction {d}")),
        };
        next.fraction_left = if r.bool()? { Some(r.f64()?) } else { None };
        next.plan = if r.bool()? {
            let opt = |v: f64| (!v.is_nan()).then_some(v);
            Some(Plan {
                step_forward: opt(r.f64()?),
                step_backward: opt(r.f64()?),
                n_steps: u32::try_from(r.u64()?)
                    .map_err(|_| "controller state: n_steps out of range")?,
                direction: r.u8()? as i8,
                fraction: r.f64()?,
                no_root: r.bool()?,
            })
        } else {
            None
        };
        next.iterations = r.u64()?;
        if self.params.analog {
            next.analog = Analog::load(&mut r)?;
        }
        if let Some(m) = &mut next.bdmap {
            m.load(&mut r)?;
        }
        r.finish()?;
        if !(1..=self.timing.samples).contains(&next.sample) {
            return Err(format!("controller state: sample {} outside the step", next.sample));
        }
        *self = next;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use crate::{Controller, Params};

    #[test]
    fn disturbance_map_state_round_trips() {
        let p = Params { disturbance_map: true, use_disturbance_map: true, ..Params::default() };
        let mut c = Controller::new(p.clone()).unwrap();
        for k in 0..1000 {
            c.tick(k / 10, 30e-6);
        }
        let mut bytes = Vec::new();
        c.save_state(&mut bytes);
        let mut d = Controller::new(p).unwrap();
        d.load_state(&bytes).unwrap();
        assert_eq!(c.disturbance_map(), d.disturbance_map());
        for k in 1000..1500 {
            assert_eq!(c.tick(k / 10, 30e-6), d.tick(k / 10, 30e-6), "tick {k}");
        }
    }

    #[test]
    fn analog_state_is_saved_only_with_the_option_on() {
        let mut off = Vec::new();
        Controller::new(Params::default()).unwrap().save_state(&mut off);
        let mut c = Controller::new(Params { analog: true, ..Params::default() }).unwrap();
        // Into analog hold: the first iteration is within range of the reference.
        for _ in 0..20 {
            c.tick(0, 1e-6);
        }
        assert!(c.analog().active());
        let mut on = Vec::new();
        c.save_state(&mut on);
        assert!(on.len() > off.len());
        let mut d = Controller::new(Params { analog: true, ..Params::default() }).unwrap();
        d.load_state(&on).unwrap();
        for k in 0..200 {
            assert_eq!(c.tick(k, 1e-6), d.tick(k, 1e-6), "tick {k}");
        }
    }
}
