//! The plant's next event with its inputs held, for a Model Exchange master to stop at
//! (docs/model.md §5.1, docs/model-exchange.md).
//!
//! Between events the plant with its DAC volts held is the exact solver's propagation:
//! from the physical state after an event update, [`EventProbe::next_event`] runs a copy
//! of the plant through `Plant::step` and reads where its event loop located the first
//! event (`StepReport::first_event`). The FMU announces that time as its next time event,
//! so a master stops there and the update applies the event, however long its integrator's
//! steps are: the indicators of node 3's ring (`ξ` against a slip onset, `ξ̇` at a slip's
//! end) can cross and return inside one step of an integrator that steps with the slow
//! motion, and its root finding, which sees only the ends of its steps, misses them.

use crate::params::N_PLAYS;
use crate::{Dac, Mode, Plant};

/// How far ahead one prediction looks (s): node 3's ring, whose crossings an integrator can
/// skip, decays by e⁻¹ in 9 ms (ζ 0.8 % at 2.2 kHz in DRIVE) and is gone after this;
/// later events (a brake channel's slow crossing, FREE's runner) are smooth, the
/// indicators' to find. Nothing found is kept for this long too: a master's updates
/// before then that change nothing predict nothing anew.
pub const HORIZON: f64 = 0.1;

/// The steps the probe takes (s): the event loop runs on to the end of the step that
/// located the first event, so a shorter step wastes less after it; the length repeats,
/// so the solver's plans for it are built once.
const CHUNK: f64 = 2.5e-4;

/// What an event changes: the mode and the brakes, the sliding set and, while elements
/// slide, their direction (their memories follow `ξ` then, and are not compared).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Discrete {
    mode: Mode,
    brakes: (bool, bool),
    sliding: u8,
    direction: i8,
}

impl Discrete {
    fn of(p: &Plant) -> Discrete {
        let (s, h) = (&p.state, &p.state.hysteresis);
        Discrete {
            mode: s.mode,
            brakes: (s.earth_closed, s.nonearth_closed),
            sliding: h.sliding,
            direction: if h.sliding != 0 { h.direction } else { 0 },
        }
    }
}

/// What a prediction started from besides the continuous state: the discrete state, the
/// elements' memories and the held volts (bits).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Origin {
    discrete: Discrete,
    memory: [u64; N_PLAYS],
    dac: [u64; 3],
}

impl Origin {
    fn of(p: &Plant, dac: Dac) -> Origin {
        Origin {
            discrete: Discrete::of(p),
            memory: p.state.hysteresis.memory.map(f64::to_bits),
            dac: [dac.earth, dac.nonearth, dac.extension].map(f64::to_bits),
        }
    }
}

/// A plant of the same parameters whose propagators the predictions reuse, and the last
/// time event announced with what it was predicted from.
#[derive(Clone, Debug)]
pub struct EventProbe {
    plant: Plant,
    /// What the last prediction started from, the time it found (or the end of its
    /// horizon) and whether it found an event.
    announced: Option<(Origin, f64, bool)>,
}

impl EventProbe {
    /// A probe for plants of `plant`'s parameters (its caches come along).
    pub fn new(plant: &Plant) -> EventProbe {
        EventProbe { plant: plant.clone(), announced: None }
    }

    /// The time of the first event the exact solver locates after `from`'s time with `dac`
    /// held, if one lies within [`HORIZON`]. `None` too if the propagation leaves the
    /// finite numbers (`Plant::step` refuses it).
    pub fn next_event(&mut self, from: &Plant, dac: Dac) -> Option<f64> {
        let p = &mut self.plant;
        p.state = from.state.clone();
        let chunks = (HORIZON / CHUNK).round() as usize;
        for _ in 0..chunks {
            let before = Discrete::of(p);
            let report = p.step(dac, CHUNK).ok()?;
            if let Some(t) = report.first_event {
                return Some(t);
            }
            // A change that no located event reports happened where the step began (its
            // first hysteresis update): by the step's end it has happened.
            if Discrete::of(p) != before {
                return Some(p.state.time);
            }
        }
        None
    }

    /// The time event to announce after an update of `from` with `dac` held: its next
    /// event, if one lies within [`HORIZON`].
    ///
    /// An update that changed neither the discrete state nor the volts since the last
    /// prediction, before its time, keeps it: the master has been integrating the same
    /// trajectory since (a master that updates at every communication point pays for a
    /// prediction only after an event or a change of the volts).
    ///
    /// The time is at least the solver's event resolution (`rel_tol` seconds) after
    /// `from`'s: the exact solver locates events no finer, and a master's integrator can't
    /// stop a few rounding units ahead (where a master's root lies just before the event
    /// and its state has not crossed yet).
    pub fn next_time_event(&mut self, from: &Plant, dac: Dac) -> Option<f64> {
        let now = from.state.time;
        let origin = Origin::of(from, dac);
        let (at, found) = match self.announced {
            Some((o, at, found)) if o == origin && now < at => (at, found),
            _ => {
                let next = self.next_event(from, dac);
                let (at, found) = (next.unwrap_or(now + HORIZON), next.is_some());
                self.announced = Some((origin, at, found));
                (at, found)
            }
        };
        found.then_some(at.max(now + from.params.rel_tol))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::PlantParams;

    /// The events of a forward stroke from rest, one after the other: each predicted time
    /// is where the solver changes the discrete state (unchanged 10 ns before it, changed
    /// 10 ns after), and the brake switches are the solver's own located times.
    #[test]
    fn each_predicted_event_is_where_the_solver_changes_the_discrete_state() {
        let mut plant = Plant::new(PlantParams::fia20()).unwrap();
        let mut probe = EventProbe::new(&plant);
        // At rest the volts hold nothing up: no event within the horizon.
        assert_eq!(probe.next_event(&plant, Dac::default()), None);
        // Both brakes switch (HOLD to DRIVE: the channels are alike, the two crossings
        // within 10 ns), the stack extends: its elements slip one after the other and
        // stick where node 3's ring turns `ξ`.
        let dac = Dac { earth: 10.0, nonearth: 10.0, extension: 6.0 };
        let (mut brakes, mut slips) = (0, 0);
        for _ in 0..12 {
            let now = plant.state.time;
            let Some(t) = probe.next_event(&plant, dac) else { break };
            assert!(t > now && t <= now + HORIZON, "{t} after {now}");
            let before = Discrete::of(&plant);
            let mut early = plant.clone();
            if t - now > 1e-8 {
                early.step(dac, t - now - 1e-8).unwrap();
                assert_eq!(Discrete::of(&early), before, "at {t}");
            }
            let report = plant.step(dac, t - now + 1e-8).unwrap();
            let after = Discrete::of(&plant);
            assert_ne!(after, before, "at {t}");
            if after.brakes != before.brakes {
                brakes += u32::from(after.brakes.0 != before.brakes.0)
                    + u32::from(after.brakes.1 != before.brakes.1);
                let located = report.first_brake_event.unwrap();
                assert!((located - t).abs() < 2e-9, "brake at {located}, predicted {t}");
            } else {
                slips += 1;
            }
        }
        assert_eq!(brakes, 2);
        assert!(slips >= 2, "{slips}");
    }

    /// An update that changed nothing keeps the announced time; new volts, or an event,
    /// predict anew.
    #[test]
    fn an_unchanged_update_keeps_the_announced_time() {
        let mut plant = Plant::new(PlantParams::fia20()).unwrap();
        let mut probe = EventProbe::new(&plant);
        let dac = Dac { earth: 10.0, nonearth: 10.0, extension: 6.0 };
        let first = probe.next_time_event(&plant, dac).unwrap();
        assert_eq!(Some(first), probe.next_event(&plant, dac));
        // Half-way there nothing has changed: the announced time stands.
        plant.step(dac, first / 2.0).unwrap();
        assert_eq!(probe.next_time_event(&plant, dac).map(f64::to_bits), Some(first.to_bits()));
        // Other volts: predicted anew, from here.
        let other = Dac { extension: 0.0, ..dac };
        let again = probe.next_time_event(&plant, other);
        assert_eq!(again, probe.next_event(&plant, other));
        // Past the event: the next one.
        plant.step(dac, first - plant.state.time + 1e-8).unwrap();
        let next = probe.next_time_event(&plant, dac).unwrap();
        assert!(next > first + 1e-8, "{next} after {first}");
        // At rest nothing happens within the horizon: no time event.
        let rest = Plant::new(PlantParams::fia20()).unwrap();
        assert_eq!(probe.next_time_event(&rest, Dac::default()), None);
    }
}
