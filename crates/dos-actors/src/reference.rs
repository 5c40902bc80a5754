//! [`ReferenceSource`]: the reference trajectory (`ReferenceFmu`: a table of points, the
//! Fig. 5 step or the staircase) as a source actor's client, sampled every `period`:
//! sample `k` is the reference at `k × period`, `samples` of them, then the source ends
//! (and with it the model's run).

use inchworm_fmu_models::ReferenceFmu;
use interface::{Data, TryUpdate, TryWrite};

use crate::inchworm::write;
use crate::table::Driven;
use crate::uid::{FmiName, Reference};
use crate::Error;

pub struct ReferenceSource<const ID: u8> {
    reference: Driven<ReferenceFmu>,
    period: f64,
    samples: u64,
    /// Samples written so far.
    k: u64,
    started: bool,
}

impl<const ID: u8> ReferenceSource<ID> {
    pub fn new(name: &str, period: f64, samples: u64) -> Result<Self, Error> {
        let reference = Driven::new(name);
        if !(period.is_finite() && period > 0.0) {
            let message = format!("the period {period} s must be finite and > 0");
            return Err(Error::Usage { client: name.to_owned(), message });
        }
        Ok(ReferenceSource { reference, period, samples, k: 0, started: false })
    }

    /// Sets a parameter (`profile`, `n_points`, `times[i]`, `positions[i]`, `ramp_time`) by
    /// its name in the reference FMU's table.
    pub fn parameter(mut self, name: &str, value: f64) -> Result<Self, Error> {
        if self.started {
            let message = format!("parameter `{name}` after the first sample");
            return Err(Error::Usage { client: self.reference.client().to_owned(), message });
        }
        self.reference.set(name, value)?;
        Ok(self)
    }
}

impl<const ID: u8> TryUpdate for ReferenceSource<ID> {
    type Error = Error;
    /// The first update leaves initialization (sample 0 is the value at 0); every later
    /// one steps a period.
    fn try_update(&mut self) -> Result<&mut Self, Error> {
        if !self.started {
            self.reference.exit_initialization(0.0)?;
            self.started = true;
        } else {
            let t = (self.k - 1) as f64 * self.period;
            self.reference.step(t, self.period)?;
        }
        self.k += 1;
        Ok(self)
    }
}

impl<const ID: u8> TryWrite<Reference<ID>> for ReferenceSource<ID> {
    type Error = Error;
    fn try_write(&mut self) -> Result<Option<Data<Reference<ID>>>, Error> {
        if self.k > self.samples {
            return Ok(None);
        }
        write::<Reference<ID>>(self.reference.get(Reference::<ID>::NAME))
    }
}
