//! FMI 3.0 clocks in the master: the scheduler of the components run with event mode
//! (`--interface NAME=cs-events`) or in Scheduled Execution (`--interface NAME=se`).
//!
//! Each such component's input clocks are time-based and periodic (`constant`, `fixed` or
//! `tunable`); after initialization the master asks the FMU their interval
//! (`fmi3GetIntervalDecimal`) and shift (`fmi3GetShiftDecimal`) and ticks clock `c` at
//! `t0 + shift + n · interval`, n counted (never summed). The ticks, not the
//! communication step, decide when a clocked component runs:
//!
//! * **Within a step** `(t, t + h)`, a component with event mode is stepped to the tick
//!   (`fmi3DoStep` ends there with `eventHandlingNeeded`), enters event mode, takes its
//!   clocked inputs (the values of the communication point `t`, as a plain Co-Simulation
//!   step holds them), has its clocks due set active (`fmi3SetClock`), updates
//!   (`fmi3UpdateDiscreteStates`, until it needs no further pass), has its output clocks
//!   read, and steps on; a Scheduled Execution component takes its clocked inputs and has
//!   the partitions due activated (`fmi3ActivateModelPartition`).
//! * **At a communication point** `t + h` that is a tick (within the master's 1e-9
//!   relative rounding), every component is stepped to it first and its outputs read; then
//!   the clocked components' events run, in the order of their clocks' priorities (0
//!   first), then of the components in the SSP: each takes its clocked inputs from the
//!   outputs just read (and the system inputs at `t + h`), so an event sees the outputs of
//!   the events before it, and its outputs are read at once. The row at `t + h` is sampled
//!   after them. With Gauss–Seidel coupling the events of a component run in its turn,
//!   right after its step.
//! * **At the start time** the events of the ticks there run at the start of the first
//!   step, after its inputs are set: the row at the start time holds the outputs after
//!   initialization, as for every other component.
//!
//! So a tick shared with a communication point writes what a plain Co-Simulation step
//! ending there writes, and latches the inputs the next plain step would be given: with
//! Jacobi coupling the clocked runs repeat the plain Co-Simulation run bit for bit.
//! `clockUpdate` (an output clock ticked during an activation) is serviced by reading the
//! component's output clocks (`fmi3GetClock`), which also resets them; event mode reads
//! them in every event. Clocked inputs (a variable whose `clocks` names an input clock) are
//! set only at their component's ticks; its other inputs at every step.

use super::clocked::{Clocked, InputClock};
use super::component::{Component, Fmu};
use super::Simulation;
use crate::fmu::CsFmu;
use crate::model_exchange::MAX_EVENT_ITERATIONS;
use crate::Error;

/// The clocked inputs of the clocked components, set at their ticks only.
pub(super) struct TickInputs {
    pub destinations: Vec<(super::Port, super::Feed)>,
    pub batches: super::batches::Batches,
    pub values: Vec<f64>,
}

/// Whether component input `port` is set at its component's ticks: a clocked input of a
/// component whose clocks the master ticks.
pub(super) fn at_ticks(components: &[Component], port: &super::Port) -> bool {
    let fmu = &components[port.component].fmu;
    fmu.clocked()
        && fmu.description().variables.iter().any(|v| v.vr == port.vr && !v.clocks.is_empty())
}

/// One event of a clocked component at `tick`: what is due there.
struct Due {
    component: usize,
    clocks: Vec<InputClock>,
}

impl Simulation {
    /// Reads every clocked component's clock schedule (after initialization), and refuses
    /// a run whose ticks it could not count or run.
    pub(super) fn schedule_clocks(&mut self, start: f64) -> Result<(), Error> {
        let (h, stop) = (self.h, start + self.n_steps as f64 * self.h);
        for c in self.components.iter_mut() {
            let name = c.name.clone();
            let scheduled = match &mut c.fmu {
                Fmu::Events(e) => e.schedule(start).and_then(|()| e.check_run(h, stop)),
                Fmu::Se(s) => s.schedule(start).and_then(|()| s.check_run(h, stop)),
                _ => Ok(()),
            };
            scheduled.map_err(|e| e.context(format!("component {name}")))?;
        }
        Ok(())
    }

    /// Sets component `ci`'s clocked inputs from the latest outputs and the system inputs
    /// at `t`.
    fn feed_ticked(&mut self, ci: usize, t: f64) -> Result<(), Error> {
        for i in 0..self.ticked.destinations.len() {
            let (dst, feed) = self.ticked.destinations[i];
            if dst.component == ci {
                self.ticked.values[i] = self.input_value(dst, feed, t)?;
            }
        }
        self.ticked.batches.write(&mut self.components, &self.ticked.values, Some(ci))
    }

    /// One event of component `ci` at `t` with the input clocks `due` (none: an event the
    /// FMU asked for): its clocked inputs at `feed_time`, its clocks set or its partitions
    /// activated, its output clocks read, its outputs read into the latest values.
    fn clocked_event(
        &mut self,
        ci: usize,
        t: f64,
        due: &[InputClock],
        feed_time: f64,
    ) -> Result<(), Error> {
        if !due.is_empty() {
            self.feed_ticked(ci, feed_time)?;
        }
        match &mut self.components[ci].fmu {
            Fmu::Events(e) => {
                let vrs: Vec<u32> = due.iter().map(|c| c.vr).collect();
                if !vrs.is_empty() {
                    e.fmu.set_clocks(&vrs, &vec![true; vrs.len()])?;
                }
                update_until_settled(e, t)?;
                e.read_output_clocks()?;
                e.fmu.enter_step_mode()?;
            }
            Fmu::Se(s) => {
                for c in due {
                    let done = s.fmu.activate_model_partition(c.vr, t)?;
                    if done.clock_updates > 0 {
                        s.read_output_clocks()?;
                    }
                }
            }
            _ => {}
        }
        self.source_batches.read(&mut self.components, &mut self.latest, Some(ci))
    }

    /// The events at `t` of the clocked components (`only`, or all), in the order of
    /// their clocks' priorities, then of the components; `start`: the start time's
    /// events, where a component with event mode is in event mode already and leaves it.
    fn events_at(&mut self, only: Option<usize>, t: f64, start: bool) -> Result<(), Error> {
        let mut due: Vec<Due> = Vec::new();
        for (ci, c) in self.components.iter().enumerate() {
            if only.is_some_and(|o| o != ci) {
                continue;
            }
            let clocks = match &c.fmu {
                Fmu::Events(e) => e.due_at(t),
                Fmu::Se(s) => s.due_at(t),
                _ => continue,
            };
            // The start leaves event mode whether or not a clock ticks there.
            if !clocks.is_empty() || start && matches!(c.fmu, Fmu::Events(_)) {
                due.push(Due { component: ci, clocks });
            }
        }
        let rank = |d: &Due| d.clocks.iter().map(|c| c.priority).min().unwrap_or(u32::MAX);
        due.sort_by_key(|d| (rank(d), d.component));
        for d in due {
            if let (Fmu::Events(e), false) = (&mut self.components[d.component].fmu, start) {
                e.fmu.enter_event_mode()?;
            }
            let mut clocks = d.clocks;
            clocks.sort_by_key(|c| (c.priority, c.vr));
            self.clocked_event(d.component, t, &clocks, t).map_err(|e| {
                e.context(format!("component {}", self.components[d.component].name))
            })?;
        }
        Ok(())
    }

    /// The start time's events, at the start of the first step.
    pub(super) fn start_events(&mut self, only: Option<usize>) -> Result<(), Error> {
        self.events_at(only, self.time(), true)
    }

    /// The events at the communication point `end`, after the step to it.
    pub(super) fn end_events(&mut self, only: Option<usize>, end: f64) -> Result<(), Error> {
        self.events_at(only, end, false)
    }

    /// Steps clocked component `ci` from the communication point `t` to `end`, running
    /// the events of its ticks inside the step (those at `end` are [`Self::end_events`]').
    pub(super) fn advance_clocked(&mut self, ci: usize, t: f64, end: f64) -> Result<(), Error> {
        let name = self.components[ci].name.clone();
        let here = |e: Error| e.context(format!("component {name}"));
        let ticks = match &self.components[ci].fmu {
            Fmu::Events(e) => e.ticks_within(t, end),
            Fmu::Se(s) => s.ticks_within(t, end),
            _ => return Err(here(Error::Config("not a clocked component".into()))),
        }
        .map_err(here)?;
        for tick in ticks {
            // A step may hold up to a million ticks: the run's stop flag is honoured
            // between two of them, as between two steps.
            if let Some(flag) = &self.stop {
                flag.check()?;
            }
            let due = match &mut self.components[ci].fmu {
                Fmu::Events(e) => {
                    let ended = e.fmu.do_step_to(tick).map_err(|e| here(e.into()))?;
                    check_step_end(ended.terminate, tick).map_err(here)?;
                    e.fmu.enter_event_mode().map_err(|e| here(e.into()))?;
                    e.due_at(tick)
                }
                Fmu::Se(s) => s.due_at(tick),
                _ => Vec::new(),
            };
            let mut due = due;
            due.sort_by_key(|c| (c.priority, c.vr));
            // Within the step the inputs are those of the communication point t.
            self.clocked_event(ci, tick, &due, t).map_err(here)?;
        }
        if let Fmu::Events(e) = &mut self.components[ci].fmu {
            let ended = e.fmu.do_step_to(end).map_err(|e| here(e.into()))?;
            check_step_end(ended.terminate, end).map_err(here)?;
            // An event the FMU asks for at a point no clock ticks: handled at once, as
            // the ticks' events are (those at `end` follow the step).
            if ended.event_handling_needed && e.due_at(end).is_empty() {
                e.fmu.enter_event_mode().map_err(|e| here(e.into()))?;
                self.clocked_event(ci, end, &[], end).map_err(here)?;
            }
        }
        Ok(())
    }

    /// The ticks of every component's output clocks seen so far, by component name (the
    /// clocked components only).
    pub fn output_clock_ticks(&self) -> Vec<(String, u64)> {
        self.components
            .iter()
            .filter_map(|c| match &c.fmu {
                Fmu::Events(e) => Some((c.name.clone(), e.output_ticks)),
                Fmu::Se(s) => Some((c.name.clone(), s.output_ticks)),
                _ => None,
            })
            .collect()
    }
}

/// `fmi3UpdateDiscreteStates` until the FMU needs no further pass (at most
/// [`MAX_EVENT_ITERATIONS`]).
fn update_until_settled(e: &mut Clocked<CsFmu>, t: f64) -> Result<(), Error> {
    for _ in 0..MAX_EVENT_ITERATIONS {
        let u = e.fmu.update_discrete_states()?;
        if u.terminate {
            return Err(Error::Config(format!(
                "at t = {t} s the FMU asked to terminate the simulation (terminateSimulation)"
            )));
        }
        if !u.needs_update {
            return Ok(());
        }
    }
    Err(Error::Config(format!(
        "at t = {t} s the event iteration did not converge: fmi3UpdateDiscreteStates still asked for another pass after {MAX_EVENT_ITERATIONS}"
    )))
}

/// A step that ended asking to terminate is an error naming the time.
fn check_step_end(terminate: bool, t: f64) -> Result<(), Error> {
    match terminate {
        true => Err(Error::Config(format!(
            "the step to t = {t} s ended with terminateSimulation: the FMU asked to stop"
        ))),
        false => Ok(()),
    }
}
