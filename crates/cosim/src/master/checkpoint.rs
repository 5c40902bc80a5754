//! A [`Checkpoint`] of a running [`Simulation`]: taken, restored and released.

use super::{Checkpoint, Simulation};
use crate::Error;

impl Checkpoint {
    /// The communication step the checkpoint was taken at (its time is `step · h`).
    pub fn step(&self) -> u64 {
        self.k
    }
}

impl Simulation {
    /// Saves the current communication point. An FMU that cannot save its state (it does
    /// not declare `canGetAndSetFMUstate`) fails the call with its component's name, and
    /// the states already taken from the others are freed. A component whose clocks the
    /// master ticks (event mode, Scheduled Execution) is refused: its FMU state does not
    /// hold the mode of its interface's state machine the master's schedule relies on.
    pub fn checkpoint(&mut self) -> Result<Checkpoint, Error> {
        if let Some(c) = self.components.iter().find(|c| c.fmu.clocked()) {
            return Err(Error::Config(format!(
                "component {}: runs its clocks with event mode or in Scheduled Execution: a checkpoint of it is not taken",
                c.name
            )));
        }
        let mut states = Vec::with_capacity(self.components.len());
        for i in 0..self.components.len() {
            match self.components[i].fmu.get_state() {
                Ok(s) => states.push(s),
                Err(source) => {
                    for (c, s) in self.components.iter_mut().zip(states) {
                        // Freeing is best effort here: the error that matters is the one
                        // that stopped the checkpoint.
                        let _ = c.fmu.free_state(s);
                    }
                    let component = self.components[i].name.clone();
                    return Err(Error::Component { component, source });
                }
            }
        }
        let carries = self.components.iter().map(|c| c.fmu.carry()).collect();
        Ok(Checkpoint { states, carries, k: self.k, latest: self.latest.clone() })
    }

    /// Back to `checkpoint`, which this simulation took: every component restores its
    /// state (a checkpoint of another simulation is refused by the first component, whose
    /// FMU did not hand out that state), then the master's step counter and last outputs.
    pub fn restore(&mut self, checkpoint: &Checkpoint) -> Result<(), Error> {
        if checkpoint.states.len() != self.components.len() {
            return Err(Error::Config(format!(
                "the checkpoint holds {} component states, this simulation has {} components",
                checkpoint.states.len(),
                self.components.len()
            )));
        }
        // The restored FMUs hold the inputs of the checkpoint, not those set since.
        self.destination_batches.forget();
        for ((c, s), carry) in
            self.components.iter_mut().zip(&checkpoint.states).zip(&checkpoint.carries)
        {
            c.fmu
                .set_state(s)
                .map_err(|source| Error::Component { component: c.name.clone(), source })?;
            c.fmu.set_carry(carry);
        }
        self.k = checkpoint.k;
        self.latest.clone_from(&checkpoint.latest);
        self.rows_read = false;
        Ok(())
    }

    /// Frees the FMU states of `checkpoint`.
    pub fn release(&mut self, checkpoint: Checkpoint) -> Result<(), Error> {
        if checkpoint.states.len() != self.components.len() {
            return Err(Error::Config("the checkpoint was not taken from this simulation".into()));
        }
        for (c, s) in self.components.iter_mut().zip(checkpoint.states) {
            c.fmu
                .free_state(s)
                .map_err(|source| Error::Component { component: c.name.clone(), source })?;
        }
        Ok(())
    }
}
