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
}
