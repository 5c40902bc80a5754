//! The table's exponentials `e^{A 2^l tick}`, `l = 0 … LEVELS − 1`, with the bits of
//! nalgebra's `exp` of each level's matrix, at a fraction of 32 separate calls' cost.
//!
//! nalgebra's `exp` is Higham's scaling and squaring (Higham 2005, "The scaling and
//! squaring method for the matrix exponential revisited", Algorithm 2.3, as scipy's `expm`):
//! from the one-norms of `A⁴, A⁶, A⁸, A¹⁰` and a rounding-error estimate (`ell`) it picks a
//! Padé approximant of degree 3, 5, 7, 9, or of degree 13 of `A / 2^s` squared `s` times.
//! Every level here takes the same decision on the same numbers and makes the same
//! floating-point operations in the same order, with two savings that change no bit:
//!
//! * **Powers by scaling.** `A_l = A_0 · 2^l` exactly (a product by a power of two rounds
//!   as its factor does), and so are the products that make its powers, `A_l^k = A_0^k ·
//!   2^{kl}`, as long as no product of two entries underflows below the normal range or
//!   overflows: [`Powers::new`] checks that and otherwise declines, and every level then
//!   comes from its own `exp`. The powers are formed once, not once per level.
//! * **Levels by squaring.** Of two consecutive levels that both take degree 13, with
//!   `s_{l+1} = s_l + 1`, the Padé approximant is made of the same scaled matrix
//!   (`A_l / 2^{s_l}` is `A_{l+1} / 2^{s_{l+1}}` exactly), so level `l + 1` is level `l`
//!   squared once more: the very product its own `exp` would end with.
//!
//! A matrix [`Powers::new`] declines has every level from nalgebra's `exp`. Debug builds
//! compare every level with it.

use nalgebra::{Const, DimMin, SMatrix, SVector};

use crate::linear::{LEVELS, TICK};

/// `e^{a 2^l tick}` for every level, each with the bits of `exp(a * (TICK * 2^l))`.
pub(crate) fn dyadic<const D: usize>(a: &SMatrix<f64, D, D>) -> [SMatrix<f64, D, D>; LEVELS]
where
    Const<D>: DimMin<Const<D>, Output = Const<D>>,
{
    let level = |l: usize| a * (TICK * (1u64 << l) as f64);
    let Some(powers) = Powers::new(a) else {
        return std::array::from_fn(|l| level(l).exp());
    };
    let mut phi = [SMatrix::<f64, D, D>::zeros(); LEVELS];
    let mut previous = None;
    for l in 0..LEVELS {
        let scaled = powers.at(l);
        let choice = scaled.choice();
        phi[l] = match (previous, choice) {
            (Some(Choice::Pade13 { s: before }), Choice::Pade13 { s }) if s == before + 1 => {
                phi[l - 1] * phi[l - 1]
            }
            _ => scaled.exp(choice),
        };
        debug_assert!(
            same_bits(&phi[l], &level(l).exp()),
            "level {l}: the shared exponential differs from nalgebra's"
        );
        previous = Some(choice);
    }
    phi
}

/// Whether two matrices hold the same bits (NaN, −0 and all).
pub(crate) fn same_bits<const D: usize>(a: &SMatrix<f64, D, D>, b: &SMatrix<f64, D, D>) -> bool {
    a.iter().zip(b.iter()).all(|(x, y)| x.to_bits() == y.to_bits())
}

/// The approximant `exp` picks for a matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Choice {
    Pade3,
    Pade5,
    Pade7,
    Pade9,
    /// Degree 13 of `A / 2^s`, squared `s` times.
    Pade13 {
        s: u64,
    },
}

/// The powers of `A_0 = a · tick` that `exp` forms (`A², A⁴ = A²·A², A⁶ = A⁴·A²,
/// A⁸ = A⁶·A², A¹⁰ = A⁶·A⁴`), valid for every level by scaling.
struct Powers<const D: usize> {
    a: SMatrix<f64, D, D>,
    /// `[A², A⁴, A⁶, A⁸, A¹⁰]` of level 0.
    even: [SMatrix<f64, D, D>; 5],
}

/// Entries at least this large (or zero) at level 0, and at most [`HUGE`] at the top level,
/// make every product of two of them a normal number at every level: `2^-500`.
const TINY: f64 = f64::from_bits((1023 - 500) << 52);
/// See [`TINY`]: `2^400`.
const HUGE: f64 = f64::from_bits((1023 + 400) << 52);

impl<const D: usize> Powers<D> {
    /// The powers of level 0, or `None` if some level's products could leave the normal
    /// range (then scaling would not give that level's bits).
    fn new(a: &SMatrix<f64, D, D>) -> Option<Self> {
        let a0 = a * TICK;
        let a2 = a0 * a0;
        let a4 = a2 * a2;
        let a6 = a4 * a2;
        let a8 = a6 * a2;
        let a10 = a6 * a4;
        // The factors of every product: A_l, A_l², A_l⁴, A_l⁶ at every level.
        let top = (1u64 << (LEVELS - 1)) as f64;
        let normal = [(&a0, 1), (&a2, 2), (&a4, 4), (&a6, 6)].into_iter().all(|(m, k)| {
            m.iter().all(|&x| {
                let x = x.abs();
                x == 0.0 || (x >= TINY && x * top.powi(k) <= HUGE)
            })
        });
        let finite =
            [&a8, &a10].into_iter().all(|m| m.iter().all(|x| (x * top.powi(10)).is_finite()));
        (normal && finite).then_some(Powers { a: *a, even: [a2, a4, a6, a8, a10] })
    }

    /// Level `l`'s matrix and powers.
    fn at(&self, l: usize) -> Scaled<D> {
        let a = self.a * (TICK * (1u64 << l) as f64);
        let two_l = (1u64 << l) as f64;
        let scale = |m: &SMatrix<f64, D, D>, k: i32| m * two_l.powi(k);
        let [a2, a4, a6, a8, a10] = &self.even;
        Scaled {
            a,
            a2: scale(a2, 2),
            a4: scale(a4, 4),
            a6: scale(a6, 6),
            a8: scale(a8, 8),
            a10: scale(a10, 10),
        }
    }
}

/// One level's matrix and its powers.
struct Scaled<const D: usize> {
    a: SMatrix<f64, D, D>,
    a2: SMatrix<f64, D, D>,
    a4: SMatrix<f64, D, D>,
    a6: SMatrix<f64, D, D>,
    a8: SMatrix<f64, D, D>,
    a10: SMatrix<f64, D, D>,
}

impl<const D: usize> Scaled<D>
where
    Const<D>: DimMin<Const<D>, Output = Const<D>>,
{
    /// The approximant `exp` takes, decided on the same numbers in the same order.
    fn choice(&self) -> Choice {
        let d4 = self.a4.one_norm().powf(0.25);
        let d6 = self.a6.one_norm().powf(1.0 / 6.0);
        let d8 = || self.a8.one_norm().powf(1.0 / 8.0);
        let d10 = || self.a10.one_norm().powf(1.0 / 10.0);
        let eta_1 = d4.max(d6);
        if eta_1 < 1.495_585_217_958_292e-2 && ell(&self.a, 3) == 0 {
            return Choice::Pade3;
        }
        if eta_1 < 2.539_398_330_063_23e-1 && ell(&self.a, 5) == 0 {
            return Choice::Pade5;
        }
        let eta_3 = d6.max(d8());
        if eta_3 < 9.504_178_996_162_932e-1 && ell(&self.a, 7) == 0 {
            return Choice::Pade7;
        }
        if eta_3 < 2.097_847_961_257_068e0 && ell(&self.a, 9) == 0 {
            return Choice::Pade9;
        }
        let eta_5 = eta_3.min(d8().max(d10()));
        let mut s = if eta_5 == 0.0 {
            0
        } else {
            let l2 = (eta_5 / 4.25).log2().ceil();
            if l2 < 0.0 {
                0
            } else {
                l2 as u64
            }
        };
        s += ell(&(self.a * 2.0_f64.powf(-(s as f64))), 13);
        Choice::Pade13 { s }
    }

    /// The exponential by the approximant chosen.
    fn exp(&self, choice: Choice) -> SMatrix<f64, D, D> {
        let id = SMatrix::<f64, D, D>::identity();
        let (a, a2, a4, a6, a8) = (&self.a, &self.a2, &self.a4, &self.a6, &self.a8);
        let (u, v) = match choice {
            Choice::Pade3 => {
                let b = [120.0, 60.0, 12.0, 1.0];
                (a * (a2 * b[3] + id * b[1]), a2 * b[2] + id * b[0])
            }
            Choice::Pade5 => {
                let b = [30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0];
                (a * (a4 * b[5] + a2 * b[3] + id * b[1]), a4 * b[4] + a2 * b[2] + id * b[0])
            }
            Choice::Pade7 => {
                let b = [
                    17_297_280.0,
                    8_648_640.0,
                    1_995_840.0,
                    277_200.0,
                    25_200.0,
                    1_512.0,
                    56.0,
                    1.0,
                ];
                (
                    a * (a6 * b[7] + a4 * b[5] + a2 * b[3] + id * b[1]),
                    a6 * b[6] + a4 * b[4] + a2 * b[2] + id * b[0],
                )
            }
            Choice::Pade9 => {
                let b = [
                    17_643_225_600.0,
                    8_821_612_800.0,
                    2_075_673_600.0,
                    302_702_400.0,
                    30_270_240.0,
                    2_162_160.0,
                    110_880.0,
                    3_960.0,
                    90.0,
                    1.0,
                ];
                (
                    a * (a8 * b[9] + a6 * b[7] + a4 * b[5] + a2 * b[3] + id * b[1]),
                    a8 * b[8] + a6 * b[6] + a4 * b[4] + a2 * b[2] + id * b[0],
                )
            }
            Choice::Pade13 { s } => self.pade13(s),
        };
        let mut x = solve(u, v);
        if let Choice::Pade13 { s } = choice {
            for _ in 0..s {
                x = x * x;
            }
        }
        x
    }

    /// Degree 13 of `A / 2^s`, its powers scaled as `exp` scales them.
    fn pade13(&self, s: u64) -> (SMatrix<f64, D, D>, SMatrix<f64, D, D>) {
        let b = [
            64_764_752_532_480_000.0,
            32_382_376_266_240_000.0,
            7_771_770_303_897_600.0,
            1_187_353_796_428_800.0,
            129_060_195_264_000.0,
            10_559_470_521_600.0,
            670_442_572_800.0,
            33_522_128_640.0,
            1_323_241_920.0,
            40_840_800.0,
            960_960.0,
            16_380.0,
            182.0,
            1.0,
        ];
        let s = s as f64;
        let id = SMatrix::<f64, D, D>::identity();
        let mb = self.a * 2.0_f64.powf(-s);
        let mb2 = self.a2 * 2.0_f64.powf(-2.0 * s);
        let mb4 = self.a4 * 2.0_f64.powf(-4.0 * s);
        let mb6 = self.a6 * 2.0_f64.powf(-6.0 * s);
        let u2 = mb6 * (mb6 * b[13] + mb4 * b[11] + mb2 * b[9]);
        let u = mb * (u2 + mb6 * b[7] + mb4 * b[5] + mb2 * b[3] + id * b[1]);
        let v2 = mb6 * (mb6 * b[12] + mb4 * b[10] + mb2 * b[8]);
        let v = v2 + mb6 * b[6] + mb4 * b[4] + mb2 * b[2] + id * b[0];
        (u, v)
    }
}

/// `(V − U)⁻¹ (U + V)` by LU, as `exp` solves it. The LU of a Padé denominator `q(A)` is
/// regular for the norms each degree is chosen for.
fn solve<const D: usize>(u: SMatrix<f64, D, D>, v: SMatrix<f64, D, D>) -> SMatrix<f64, D, D>
where
    Const<D>: DimMin<Const<D>, Output = Const<D>>,
{
    let p = u + v;
    let q = v - u;
    q.lu().solve(&p).unwrap_or_else(|| SMatrix::from_element(f64::NAN))
}

/// `n!` for the small `n` of [`ell`].
const fn factorial(n: u32) -> u128 {
    let mut f = 1u128;
    let mut k = 2;
    while k <= n {
        f *= k as u128;
        k += 1;
    }
    f
}

/// Higham's `ℓ(A, m)`: how many more halvings the rounding of the degree-`m` approximant
/// asks for, from the one-norm of `|A|^{2m+1}` (by `2m + 1` products with a vector).
fn ell<const D: usize>(a: &SMatrix<f64, D, D>, m: u32) -> u64 {
    let a_abs = a.map(|x| x.abs());
    let t = a_abs.transpose();
    let mut v = SVector::<f64, D>::repeat(1.0);
    for _ in 0..2 * m + 1 {
        v = t * v;
    }
    let a_abs_onenorm = v.max();
    if a_abs_onenorm == 0.0 {
        return 0;
    }
    let m_factorial = factorial(m);
    let choose_2m_m = factorial(2 * m) / (m_factorial * m_factorial);
    let abs_c_recip = choose_2m_m * factorial(2 * m + 1);
    let alpha = a_abs_onenorm / a.one_norm();
    let alpha = alpha / abs_c_recip as f64;
    let u = 2_f64.powf(-53.0);
    let value = ((alpha / u).log2() / (2.0 * m as f64)).ceil();
    if value > 0.0 {
        value as u64
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linear::{chain_matrix, system_matrix};
    use crate::{Mode, PlantParams, N_PLAYS};

    /// Every level against nalgebra's own `exp` of that level's matrix, bit for bit; and
    /// whether the shared path (powers by scaling) took the matrix.
    fn check<const D: usize>(a: &SMatrix<f64, D, D>, what: &str) -> bool
    where
        Const<D>: DimMin<Const<D>, Output = Const<D>>,
    {
        let phi = dyadic(a);
        for (l, p) in phi.iter().enumerate() {
            let own = (a * (TICK * (1u64 << l) as f64)).exp();
            assert!(same_bits(p, &own), "{what}, level {l}: differs from nalgebra's exp");
        }
        Powers::new(a).is_some()
    }

    /// The approximants the levels of `a` take.
    fn choices<const D: usize>(a: &SMatrix<f64, D, D>) -> Vec<Choice>
    where
        Const<D>: DimMin<Const<D>, Output = Const<D>>,
    {
        let p = Powers::new(a).expect("a matrix in range");
        (0..LEVELS).map(|l| p.at(l).choice()).collect()
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
            for mode in [Mode::Hold, Mode::Locked, Mode::Drive, Mode::Free] {
                for sliding in 0..1u32 << N_PLAYS {
                    let w_s: f64 = (0..N_PLAYS)
                        .filter(|&i| sliding & (1 << i) == 0)
                        .map(|i| p.play_weight[i])
                        .sum();
                    let a = system_matrix(&p, mode, w_s);
                    let what = format!("{name}, {mode:?}, sliding {sliding:#07b}");
                    assert!(check(&a, &what), "{what}: the shared path declined");
                }
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
}
