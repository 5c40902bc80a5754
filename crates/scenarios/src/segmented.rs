//! The segmented mirrors' seeded draws (docs/segmented.md): every segment's initial
//! co-phasing error and every actuator's plant. `fmu-build segmented` binds them into its
//! SSP files, and `inchworm-phasing`'s examples run the same mirror in plain Rust, so both
//! start from the same bits.

use inchworm_cosim::sweep::plan::{self, SplitMix64};
use inchworm_plant::PlantParams;

/// The co-phasing errors (docs/segmented.md §5): piston uniform within ±[`PISTON_ERROR`],
/// tip and tilt each within ±[`ANGLE_ERROR`].
pub const PISTON_ERROR: f64 = 10e-6;
pub const ANGLE_ERROR: f64 = 5e-6;

/// The errors' splitmix64 stream is seeded with `seed ^ ERROR_STREAM`, apart from the
/// actuators' draws, so that neither depends on the other's count.
pub const ERROR_STREAM: u64 = 1 << 63;

/// `n` segments' initial errors (piston m, tip rad, tilt rad) from `seed`, segment by
/// segment: a mirror's first segments draw the same whatever its ring count.
pub fn errors(seed: u64, n: usize) -> Vec<[f64; 3]> {
    let mut rng = SplitMix64::new(seed ^ ERROR_STREAM);
    let mut within = |half: f64| half * (2.0 * rng.uniform() - 1.0);
    (0..n).map(|_| [within(PISTON_ERROR), within(ANGLE_ERROR), within(ANGLE_ERROR)]).collect()
}

/// One actuator's draw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Draw {
    /// Brake disturbance force in DRIVE (N).
    pub f_d0: f64,
    /// Electromechanical transformer ratio (N/V): the scale factor's spread.
    pub t_em: f64,
    /// Environment stiffness on the runner (N/m).
    pub k_e: f64,
}

/// The spreads, seeded (docs/segmented.md §2). The paper's two devices (docs/model.md
/// §2.8) bound the first; the others are design decisions, the paper publishing none:
/// * `F_d0` uniform between fia6's 105 N and fia20's 175 N: brake disturbances of about
///   3 µm to 5 µm, the range the paper reports for its two devices;
/// * `T_em` normal about fia20's 8.8 N/V, standard deviation [`T_EM_SIGMA`] (5 %), cut at
///   [`T_EM_CUT`] σ (redrawn beyond): a production lot of the 20 µm device, whose scale
///   factor (µm a full step) follows `T_em` and the controller's estimator tracks;
/// * `k_e` log-uniform over a factor 2 each side of fia20's 2·10^4 N/m (10^4 to
///   4·10^4 N/m): the stiffness of what the runner pushes against, mount to mount.
///
/// The draws take splitmix64 with the sweep plan's own logarithm, cosine and exponential
/// (`inchworm_cosim::sweep::plan`), so a seed gives the same bits on every machine.
pub const F_D0_RANGE: (f64, f64) = (105.0, 175.0);
pub const T_EM_SIGMA: f64 = 0.05;
pub const T_EM_CUT: f64 = 3.0;
pub const K_E_RANGE: (f64, f64) = (1.0e4, 4.0e4);

/// `n` actuators' draws from `seed`, actuator by actuator (segment 0's a, b, c, then
/// segment 1's, …): a mirror's first segments are the same whatever its ring count.
pub fn draws(seed: u64, n: usize) -> Vec<Draw> {
    let nominal = PlantParams::fia20();
    let mut rng = SplitMix64::new(seed);
    let k_e_decades = plan::ln(K_E_RANGE.1 / K_E_RANGE.0);
    (0..n)
        .map(|_| {
            let f_d0 = F_D0_RANGE.0 + (F_D0_RANGE.1 - F_D0_RANGE.0) * rng.uniform();
            let t_em = loop {
                let z = rng.normal();
                if z.abs() <= T_EM_CUT {
                    break nominal.t_em * (1.0 + T_EM_SIGMA * z);
                }
            };
            let k_e = K_E_RANGE.0 * plan::exp(k_e_decades * rng.uniform());
            Draw { f_d0, t_em, k_e }
        })
        .collect()
}

impl Draw {
    /// fia20 with this draw's brake disturbance, transducer ratio and environment stiffness.
    pub fn plant(&self) -> PlantParams {
        PlantParams { f_d0: self.f_d0, t_em: self.t_em, k_e: self.k_e, ..PlantParams::fia20() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_are_seeded_within_their_ranges_and_spread() {
        let d = draws(7, 3000);
        assert_eq!(d, draws(7, 3000));
        assert_ne!(d[0], draws(8, 1)[0]);
        // A mirror's first actuators are the same whatever its size.
        assert_eq!(&d[..21], &draws(7, 21)[..]);
        let nominal = PlantParams::fia20().t_em;
        let mean = |f: &dyn Fn(&Draw) -> f64| d.iter().map(f).sum::<f64>() / d.len() as f64;
        for x in &d {
            assert!((F_D0_RANGE.0..=F_D0_RANGE.1).contains(&x.f_d0));
            assert!((x.t_em / nominal - 1.0).abs() <= T_EM_CUT * T_EM_SIGMA + 1e-12);
            assert!((K_E_RANGE.0..=K_E_RANGE.1).contains(&x.k_e));
        }
        // Uniform mean 140 N (sd of the mean 0.37 N), normal mean 8.8 (sd of the mean
        // 0.008), log-uniform geometric mean 2e4 (log sd of the mean 0.007).
        assert!((mean(&|x| x.f_d0) - 140.0).abs() < 2.0);
        assert!((mean(&|x| x.t_em) - nominal).abs() < 0.04);
        let sd = (mean(&|x| (x.t_em - nominal).powi(2))).sqrt() / nominal;
        assert!((sd - T_EM_SIGMA).abs() < 0.004, "{sd}");
        assert!((mean(&|x| x.k_e.ln()) - 2.0e4_f64.ln()).abs() < 0.03);
    }
}
