//! Where a run's wall time goes: loading and initialising its system (unpacking the
//! archives, loading the libraries, instantiating, initialisation mode), then its loop
//! (the steps and the rows), kept apart so that a run's real-time factor is its loop's.

use std::path::Path;
use std::time::Instant;

use super::{Options, System};
use crate::trace::Trace;
use crate::Error;

/// Wall seconds of one run or several, and the seconds they simulated.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Timing {
    /// Loading and initialising the systems.
    pub load_s: f64,
    /// The loops: every step and row, from t = 0 to the stop time.
    pub loop_s: f64,
    /// Simulated seconds.
    pub simulated_s: f64,
}

impl Timing {
    /// Simulated seconds per wall second of the loop.
    pub fn speed(&self) -> f64 {
        self.simulated_s / self.loop_s
    }

    /// Both runs' times and simulated seconds together.
    pub fn and(self, other: Timing) -> Timing {
        Timing {
            load_s: self.load_s + other.load_s,
            loop_s: self.loop_s + other.loop_s,
            simulated_s: self.simulated_s + other.simulated_s,
        }
    }
}

/// `20 s simulated: load 0.031 s, loop 0.040 s (500x real time)`: the factor is the
/// loop's, with two decimals below 10 (a Model Exchange run can be slower than real time,
/// and "0x" would hide by how much).
impl std::fmt::Display for Timing {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        let speed = self.speed();
        let digits = if speed < 10.0 { 2 } else { 0 };
        write!(
            f,
            "{} s simulated: load {:.3} s, loop {:.3} s ({speed:.digits$}x real time)",
            self.simulated_s, self.load_s, self.loop_s
        )
    }
}

/// [`super::run`], with where its wall time went.
pub fn run_timed(
    path: &Path,
    opts: &Options,
    progress: impl FnMut(f64),
) -> Result<(Trace, Timing), Error> {
    let start = Instant::now();
    let sim = System::load(path)?.initialise(opts)?;
    let load_s = start.elapsed().as_secs_f64();
    let simulated_s = sim.n_steps() as f64 * sim.h;
    let mut trace = Trace::new(sim.record_names().to_vec());
    let start = Instant::now();
    sim.run_into(
        |t, row| {
            trace.push(t, row.to_vec());
            Ok::<(), Error>(())
        },
        progress,
    )?;
    let loop_s = start.elapsed().as_secs_f64();
    Ok((trace, Timing { load_s, loop_s, simulated_s }))
}

#[cfg(test)]
mod tests {
    use super::Timing;

    #[test]
    fn the_timing_line_gives_load_loop_and_the_loops_factor() {
        let t = Timing { load_s: 0.0314, loop_s: 0.04, simulated_s: 20.0 };
        assert_eq!(t.to_string(), "20 s simulated: load 0.031 s, loop 0.040 s (500x real time)");
        // Below 10x, two decimals: a slow Model Exchange run is not shown as 0x.
        let slow = Timing { load_s: 0.5, loop_s: 8.0, simulated_s: 2.0 };
        assert_eq!(slow.to_string(), "2 s simulated: load 0.500 s, loop 8.000 s (0.25x real time)");
        let both = t.and(slow);
        assert_eq!(both, Timing { load_s: 0.5314, loop_s: 8.04, simulated_s: 22.0 });
        assert_eq!(
            both.to_string(),
            "22 s simulated: load 0.531 s, loop 8.040 s (2.74x real time)"
        );
    }
}
