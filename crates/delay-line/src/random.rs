//! Seeded Gaussian deviates for the disturbances and the sensor noise: the plant's
//! splitmix64 stream (`inchworm_plant::noise`), so every run replays from its seed.

/// A stream of standard normal deviates from `seed`.
#[derive(Clone, Debug)]
pub struct Gaussian {
    state: u64,
}

impl Gaussian {
    pub fn new(seed: u64) -> Gaussian {
        Gaussian { state: seed }
    }

    /// The next deviate.
    pub fn sample(&mut self) -> f64 {
        inchworm_plant::noise::gaussian(&mut self.state)
    }

    pub(crate) fn save_state(&self, w: &mut inchworm_state_bytes::Writer) {
        w.u64(self.state);
    }

    pub(crate) fn load_state(
        &mut self,
        r: &mut inchworm_state_bytes::Reader,
    ) -> Result<(), String> {
        self.state = r.u64()?;
        Ok(())
    }
}
