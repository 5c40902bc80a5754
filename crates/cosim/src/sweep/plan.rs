//! The sweep plan: which parameter values each run gets, as data (`run,sample,<name>,…`).
//!
//! A grid (`NAME=a:b:n`, or `NAME=v1;v2;…`) and Monte Carlo draws (`NAME=normal(m,s)`,
//! `uniform(a,b)`, `lognormal(mu,sigma)`) combine as grid point × sample: every grid point
//! gets the same `N` draws (common random numbers), so a difference between grid points is
//! not sampling noise. Runs are numbered grid point major: `run = g · N + s`, and `sample`
//! is `s`, the seed index.
//!
//! # Reproducible on every machine
//!
//! The draws come from one splitmix64 stream seeded with `--seed`, in order: sample 0's
//! values in the order of the `--sample` flags, then sample 1's, … A uniform is the top 53
//! bits of one output; a normal is Box–Muller's cosine branch on two outputs (the sine
//! branch is not used, so every normal costs exactly two outputs); a lognormal is
//! `exp(mu + sigma z)` of such a normal (`mu`, `sigma` of the logarithm, as numpy has it).
//! The logarithm, cosine and exponential are computed here ([`ln`], [`cos_2pi`], [`exp`])
//! from `+ − × ÷` and `sqrt` only, which IEEE 754 rounds correctly on every machine, so
//! the same seed gives the same bits everywhere, whatever the platform's libm.

use std::fmt::Write as _;

use crate::Error;

/// splitmix64 (Steele, Lea and Flood 2014; Vigna's reference code).
#[derive(Clone, Debug)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    pub fn new(seed: u64) -> SplitMix64 {
        SplitMix64 { state: seed }
    }

    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform on [0, 1): the top 53 bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform on (0, 1): the top 53 bits, offset by half a step (never 0, never 1).
    fn open01(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) * (1.0 / (1u64 << 53) as f64)
    }

    /// Standard normal: Box–Muller, `sqrt(-2 ln u1) cos(2π u2)`.
    pub fn normal(&mut self) -> f64 {
        let u1 = self.open01();
        let u2 = self.open01();
        (-2.0 * ln(u1)).sqrt() * cos_2pi(u2)
    }
}

/// ln 2 split as fdlibm has it: the high part ends in 21 zero bits, so `k · LN2_HI` is exact for every `k` here.
const LN2_HI: f64 = 0.693_147_180_369_123_8;
const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;

/// Natural logarithm of a finite `x > 0` (NaN otherwise), within a few ulp (the tests hold it to 4 of libm): `x = m 2^e` with
/// `m` in [√½, √2), `ln m = 2 atanh((m − 1)/(m + 1))` by its series.
pub fn ln(x: f64) -> f64 {
    if !(x > 0.0 && x.is_finite()) {
        return f64::NAN;
    }
    let (mut m, mut e) = (x, 0i32);
    if m < f64::MIN_POSITIVE {
        m *= (1u64 << 54) as f64;
        e -= 54;
    }
    let bits = m.to_bits();
    e += ((bits >> 52) & 0x7ff) as i32 - 1023;
    m = f64::from_bits((bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000);
    if m > std::f64::consts::SQRT_2 {
        m *= 0.5;
        e += 1;
    }
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    // 2 (s + s³/3 + s⁵/5 + …); |s| ≤ 0.172, so s²⁴ < 1e-18 ends it.
    let mut term = s;
    let mut sum = 0.0;
    let mut k = 1.0;
    while k < 26.0 {
        sum += term / k;
        term *= s2;
        k += 2.0;
    }
    let e = f64::from(e);
    e * LN2_HI + (2.0 * sum + e * LN2_LO)
}

/// `cos(2π u)` for `u` in [0, 1], within a few ulp (the tests hold it to 4 of libm): reduced to a quarter turn exactly (a
/// multiple of ¼ subtracted from `u` is exact), then the Taylor series of cos or sin on
/// |θ| ≤ π/4.
pub fn cos_2pi(u: f64) -> f64 {
    let q = (u * 4.0 + 0.5).floor();
    let w = u - q * 0.25;
    let theta = w * (2.0 * std::f64::consts::PI);
    let t2 = theta * theta;
    let (mut c, mut s) = (0.0, 0.0);
    let (mut tc, mut ts) = (1.0, theta);
    let mut n = 0.0;
    while n < 22.0 {
        c += tc;
        s += ts;
        tc *= -t2 / ((n + 1.0) * (n + 2.0));
        ts *= -t2 / ((n + 2.0) * (n + 3.0));
        n += 2.0;
    }
    match (q as i64).rem_euclid(4) {
        0 => c,
        1 => -s,
        2 => -c,
        _ => s,
    }
}

/// `e^x`, within a few ulp (the tests hold it to 4 of libm): `x = k ln 2 + r`, |r| ≤ ln 2 / 2, the Taylor series of `e^r`,
/// times `2^k` built from its bits (exact). Overflows to ∞ above 709.7, 0 below −745.
pub fn exp(x: f64) -> f64 {
    if x.is_nan() {
        return x;
    }
    if x > 709.78 {
        return f64::INFINITY;
    }
    if x < -745.2 {
        return 0.0;
    }
    let k = (x / std::f64::consts::LN_2 + 0.5).floor();
    let r = (x - k * LN2_HI) - k * LN2_LO;
    let (mut sum, mut term, mut n) = (1.0, 1.0, 1.0);
    while n < 24.0 {
        term *= r / n;
        sum += term;
        n += 1.0;
    }
    let k = k as i64;
    // 2^k in two factors so that neither leaves the normal range.
    let half = k / 2;
    let pow2 = |j: i64| f64::from_bits(((j + 1023) as u64) << 52);
    sum * pow2(half) * pow2(k - half)
}

/// How a swept parameter gets its values.
#[derive(Clone, Debug, PartialEq)]
pub enum Axis {
    /// Grid points, in order.
    Grid(Vec<f64>),
    Normal {
        mean: f64,
        sd: f64,
    },
    Uniform {
        lo: f64,
        hi: f64,
    },
    LogNormal {
        mu: f64,
        sigma: f64,
    },
}

/// One swept parameter: `component.variable` and its axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    pub name: String,
    pub axis: Axis,
}

fn number(text: &str, what: &str) -> Result<f64, Error> {
    let v: f64 = text
        .trim()
        .parse()
        .map_err(|_| Error::Config(format!("{what}: `{text}` is not a number")))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Error::Config(format!("{what}: `{text}` is not finite")))
    }
}

/// `--grid NAME=a:b:n` (n points from a to b, ends included) or `NAME=v1;v2;…`.
pub fn parse_grid(text: &str) -> Result<Sweep, Error> {
    let what = format!("--grid {text}");
    let (name, spec) =
        text.split_once('=').ok_or(Error::Config(format!("{what}: expected NAME=a:b:n")))?;
    let parts: Vec<&str> = spec.split(':').collect();
    let values = if parts.len() == 3 {
        let (a, b) = (number(parts[0], &what)?, number(parts[1], &what)?);
        let n: usize = parts[2].trim().parse().ok().filter(|&n| n >= 1).ok_or(Error::Config(
            format!("{what}: the point count `{}` is not a whole number ≥ 1", parts[2]),
        ))?;
        if n == 1 {
            vec![a]
        } else {
            (0..n)
                .map(|i| if i == n - 1 { b } else { a + (b - a) * i as f64 / (n - 1) as f64 })
                .collect()
        }
    } else if parts.len() == 1 {
        spec.split(';').map(|v| number(v, &what)).collect::<Result<_, _>>()?
    } else {
        return Err(Error::Config(format!("{what}: expected NAME=a:b:n or NAME=v1;v2;…")));
    };
    Ok(Sweep { name: name.trim().to_string(), axis: Axis::Grid(values) })
}

/// `--sample NAME=normal(mean,sd)`, `uniform(lo,hi)` or `lognormal(mu,sigma)`.
pub fn parse_sample(text: &str) -> Result<Sweep, Error> {
    let what = format!("--sample {text}");
    let (name, spec) = text
        .split_once('=')
        .ok_or(Error::Config(format!("{what}: expected NAME=normal(mean,sd)")))?;
    let spec = spec.trim();
    let (kind, args) = spec.strip_suffix(')').and_then(|s| s.split_once('(')).ok_or(
        Error::Config(format!("{what}: expected normal(m,s), uniform(a,b) or lognormal(mu,sigma)")),
    )?;
    let args: Vec<f64> = args.split(',').map(|a| number(a, &what)).collect::<Result<_, _>>()?;
    let [a, b] = args[..] else {
        return Err(Error::Config(format!("{what}: {kind} takes two numbers")));
    };
    let axis = match kind.trim() {
        "normal" if b >= 0.0 => Axis::Normal { mean: a, sd: b },
        "uniform" if a <= b => Axis::Uniform { lo: a, hi: b },
        "lognormal" if b >= 0.0 => Axis::LogNormal { mu: a, sigma: b },
        "normal" | "lognormal" => {
            return Err(Error::Config(format!("{what}: the spread must be ≥ 0")))
        }
        "uniform" => return Err(Error::Config(format!("{what}: uniform(a,b) needs a ≤ b"))),
        k => {
            return Err(Error::Config(format!(
                "{what}: unknown distribution `{k}` (normal, uniform, lognormal)"
            )))
        }
    };
    Ok(Sweep { name: name.trim().to_string(), axis })
}

/// The runs of a sweep: one row of parameter values per run.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// The swept parameters, grid axes first, then the sampled ones (flag order).
    pub names: Vec<String>,
    pub rows: Vec<Row>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub run: usize,
    /// The Monte Carlo sample index (the seed index): which draw of the stream.
    pub sample: usize,
    pub values: Vec<f64>,
}

impl Plan {
    /// The grid (cartesian product, first axis outermost) times `samples` draws of the
    /// sampled axes from `seed`; no sampled axis: one run per grid point.
    pub fn build(sweeps: &[Sweep], samples: usize, seed: u64) -> Result<Plan, Error> {
        let mut names: Vec<String> = Vec::new();
        for s in sweeps {
            if names.contains(&s.name) {
                return Err(Error::Config(format!("`{}` is swept twice", s.name)));
            }
            names.push(s.name.clone());
        }
        let grids: Vec<(&str, &Vec<f64>)> = sweeps
            .iter()
            .filter_map(
                |s| if let Axis::Grid(v) = &s.axis { Some((s.name.as_str(), v)) } else { None },
            )
            .collect();
        let sampled: Vec<&Sweep> =
            sweeps.iter().filter(|s| !matches!(s.axis, Axis::Grid(_))).collect();
        let n_samples = if sampled.is_empty() { 1 } else { samples };
        if n_samples == 0 {
            return Err(Error::Config("--samples must be at least 1".into()));
        }
        // The draws first, in stream order.
        let mut rng = SplitMix64::new(seed);
        let draws: Vec<Vec<f64>> = (0..n_samples)
            .map(|_| {
                sampled
                    .iter()
                    .map(|s| match s.axis {
                        Axis::Normal { mean, sd } => mean + sd * rng.normal(),
                        Axis::Uniform { lo, hi } => lo + (hi - lo) * rng.uniform(),
                        Axis::LogNormal { mu, sigma } => exp(mu + sigma * rng.normal()),
                        Axis::Grid(_) => f64::NAN,
                    })
                    .collect()
            })
            .collect();
        let n_grid: usize = grids.iter().map(|(_, v)| v.len()).product();
        let mut rows = Vec::with_capacity(n_grid * n_samples);
        for g in 0..n_grid {
            // Mixed radix, last axis fastest.
            let mut rest = g;
            let mut point = vec![0.0; grids.len()];
            for (j, (_, v)) in grids.iter().enumerate().rev() {
                point[j] = v[rest % v.len()];
                rest /= v.len();
            }
            for (s, draw) in draws.iter().enumerate() {
                let mut values = Vec::with_capacity(names.len());
                let (mut gi, mut si) = (0, 0);
                for sw in sweeps {
                    if matches!(sw.axis, Axis::Grid(_)) {
                        values.push(point[gi]);
                        gi += 1;
                    } else {
                        values.push(draw[si]);
                        si += 1;
                    }
                }
                rows.push(Row { run: rows.len(), sample: s, values });
            }
        }
        Ok(Plan { names, rows })
    }

    /// CSV `run,sample,<name>,…`, each value in the shortest text that reads back as the
    /// same `f64`.
    pub fn to_csv(&self) -> String {
        let mut s = format!("run,sample,{}\n", self.names.join(","));
        for r in &self.rows {
            let _ = write!(s, "{},{}", r.run, r.sample);
            for v in &r.values {
                let _ = write!(s, ",{v}");
            }
            s.push('\n');
        }
        s
    }

    /// Reads [`Plan::to_csv`]'s format (any engine may write it).
    pub fn parse(text: &str) -> Result<Plan, Error> {
        let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
        let (_, header) = lines.next().ok_or(Error::Config("the plan is empty".into()))?;
        let cols: Vec<&str> = header.split(',').map(str::trim).collect();
        if cols.len() < 2 || cols[0] != "run" || cols[1] != "sample" {
            return Err(Error::Config(format!(
                "plan header must be `run,sample,<parameter>,…`, got `{header}`"
            )));
        }
        let names: Vec<String> = cols[2..].iter().map(|c| c.to_string()).collect();
        let mut rows = Vec::new();
        for (i, l) in lines {
            let f: Vec<&str> = l.split(',').map(str::trim).collect();
            let bad = || Error::Config(format!("plan line {}: `{l}`", i + 1));
            if f.len() != cols.len() {
                return Err(Error::Config(format!("{}: expected {} fields", bad(), cols.len())));
            }
            let run = f[0].parse().map_err(|_| bad())?;
            let sample = f[1].parse().map_err(|_| bad())?;
            let values = f[2..]
                .iter()
                .map(|v| v.parse::<f64>().ok().filter(|x| x.is_finite()))
                .collect::<Option<Vec<f64>>>()
                .ok_or_else(|| Error::Config(format!("{}: not all finite numbers", bad())))?;
            rows.push(Row { run, sample, values });
        }
        Ok(Plan { names, rows })
    }
}
