use super::*;
use crate::linear::{chain_matrix, system_matrix};
use crate::numerics::configs::every_configuration;
use crate::{Mode, PlantParams};

/// Every level against nalgebra's own `exp` of that level's matrix, bit for bit, and
/// every share of level 0 (`ℓ`, the powers' one-norms) against the level's own; whether
/// the shared path (powers by scaling) took the matrix.
fn check<const D: usize>(a: &SMatrix<f64, D, D>, what: &str) -> bool
where
    Const<D>: DimMin<Const<D>, Output = Const<D>>,
{
    let mut phi = [SMatrix::<f64, D, D>::zeros(); LEVELS];
    dyadic(a, &mut phi);
    for (l, p) in phi.iter().enumerate() {
        let own = level_matrix(a, l).exp();
        assert!(same_bits(p, &own), "{what}, level {l}: differs from nalgebra's exp");
    }
    let Some(powers) = Powers::new(a) else {
        return false;
    };
    for l in 0..LEVELS {
        let two_l = (1u64 << l) as f64;
        for (k, p) in [(1, 4), (2, 6), (3, 8), (4, 10)] {
            let own = (powers.even[k] * two_l.powi(p)).one_norm();
            let scaled = powers.norms[k - 1] * two_l.powi(p);
            assert_eq!(scaled.to_bits(), own.to_bits(), "{what}, level {l}: ‖A^{p}‖₁");
        }
        let a_l = level_matrix(a, l);
        for m in [3, 5, 7, 9] {
            let shared = powers.abs.ell(l as i32, m);
            assert!(shared.is_none_or(|v| v == ell(&a_l, m)), "{what}, level {l}: ℓ(A, {m})");
        }
        // Degree 13's `ℓ` at the halvings around the level's own.
        let s_l = match powers.choice(l) {
            Choice::Pade13 { s } => s as i32,
            _ => 0,
        };
        for s in (s_l - 3).max(0)..=s_l + 1 {
            let shared = powers.abs.ell(l as i32 - s, 13);
            let own = ell(&(a_l * 2.0_f64.powf(-f64::from(s))), 13);
            assert!(shared.is_none_or(|v| v == own), "{what}, level {l}: ℓ(A / 2^{s}, 13)");
        }
    }
    true
}

/// The approximants the levels of `a` take.
fn choices<const D: usize>(a: &SMatrix<f64, D, D>) -> Vec<Choice>
where
    Const<D>: DimMin<Const<D>, Output = Const<D>>,
{
    let p = Powers::new(a).expect("a matrix in range");
    (0..LEVELS).map(|l| p.choice(l)).collect()
}

/// Whether every `ℓ` the levels of `a` ask for comes from level 0's iterates.
fn ell_shared_everywhere<const D: usize>(a: &SMatrix<f64, D, D>) -> bool
where
    Const<D>: DimMin<Const<D>, Output = Const<D>>,
{
    let p = Powers::new(a).expect("a matrix in range");
    (0..LEVELS).all(|l| {
        let s = match p.choice(l) {
            Choice::Pade13 { s } => s as i32,
            _ => 0,
        };
        [3, 5, 7, 9].iter().all(|&m| p.abs.ell(l as i32, m).is_some())
            && (0..=s).all(|s| p.abs.ell(l as i32 - s, 13).is_some())
    })
}

fn parameter_sets() -> Vec<(&'static str, PlantParams)> {
    let f = PlantParams::fia20();
    vec![
        ("fia20", f.clone()),
        ("fia6", PlantParams::fia6()),
        ("stiff stack", PlantParams { k_p: 3.0e8, c_p: 1.5, ..f.clone() }),
        ("soft flexure", PlantParams { k_f: 5.0e5, m_r: 1.5, ..f.clone() }),
        ("fast analog chain", PlantParams { f_bessel: 3000.0, f_amp: 4750.0, ..f.clone() }),
    ]
}

#[test]
fn every_configuration_of_the_plant_has_nalgebras_bits() {
    for (name, p) in parameter_sets() {
        assert!(check(&chain_matrix(&p), &format!("{name}, analog chain")));
        for (mode, sliding, a) in every_configuration(&p) {
            let what = format!("{name}, {mode:?}, sliding {sliding:#07b}");
            assert!(check(&a, &what), "{what}: the shared path declined");
            assert!(ell_shared_everywhere(&a), "{what}: some ℓ took the level's own iterates");
        }
    }
}

#[test]
fn the_top_levels_of_the_plant_are_squares_of_the_ones_below() {
    let p = PlantParams::fia20();
    let c = choices(&system_matrix(&p, Mode::Hold, p.play_weight.iter().sum()));
    // Low levels take the low degrees, the top ones degree 13 with one more halving
    // each: those are the levels made by one squaring.
    assert_eq!(c[0], Choice::Pade3);
    let shared = c.windows(2).filter(|w| {
        matches!((w[0], w[1]), (Choice::Pade13 { s: a }, Choice::Pade13 { s: b }) if b == a + 1)
    });
    assert!(shared.count() >= 5, "{c:?}");
}

/// Matrices of every norm from 1e-12 to 1e6 at level 0: every approximant, every `s`.
#[test]
fn random_matrices_of_every_norm_have_nalgebras_bits() {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut uniform = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let mut seen = std::collections::BTreeSet::new();
    for k in 0..60 {
        let scale = 10f64.powf(-12.0 + 18.0 * k as f64 / 59.0) / TICK;
        let a = SMatrix::<f64, 6, 6>::from_fn(|_, _| uniform() * scale);
        assert!(check(&a, &format!("random matrix {k}")));
        for c in choices(&a) {
            seen.insert(format!("{c:?}").split_whitespace().next().unwrap_or("").to_owned());
        }
    }
    for degree in ["Pade3", "Pade5", "Pade7", "Pade9", "Pade13"] {
        assert!(seen.contains(degree), "no level took {degree}: {seen:?}");
    }
}

/// A matrix whose products would underflow at level 0 is declined and gets nalgebra's
/// `exp` level by level.
#[test]
fn a_matrix_out_of_range_takes_nalgebras_exp_level_by_level() {
    let mut a = SMatrix::<f64, 4, 4>::from_fn(|i, j| (i as f64 - j as f64) * 1e3);
    a[(0, 3)] = 1e-250;
    assert!(!check(&a, "a tiny entry"));
    a[(0, 3)] = 1e250;
    assert!(!check(&a, "a huge entry"));
}

/// Where the iterates of `ℓ` would leave the normal range at some scale, the shared `ℓ`
/// declines and the level's own iterates decide; inside it, both agree.
#[test]
fn ell_declines_outside_the_normal_range() {
    let p = PlantParams::fia20();
    let a = system_matrix(&p, Mode::Hold, p.play_weight.iter().sum());
    let powers = Powers::new(&a).expect("a matrix in range");
    let a0 = a * TICK;
    let (mut declined, mut shared) = (0, 0);
    for e in (-1100..=1100).step_by(50) {
        let scaled = a0.map(|x| scale(x, e));
        for m in [3, 5, 13] {
            let own = ell(&scaled, m as u32);
            match powers.abs.ell(e as i32, m as u32) {
                None => declined += 1,
                Some(v) => {
                    assert_eq!(v, own, "ℓ(A_0 2^{e}, {m})");
                    shared += 1;
                }
            }
            assert_eq!(powers.ell(e as i32, m as u32, || scaled), own);
        }
    }
    assert!(declined > 0 && shared > 0, "{declined} declined, {shared} shared");
}
