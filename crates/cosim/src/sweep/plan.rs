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

use std::collections::HashSet;
use std::fmt::Write as _;
use std::io::BufRead;

use crate::Error;

/// The most runs a plan may have: a sweep keeps every run's outcome, and a plan from
/// outside (or a slip of the finger: `--samples 1e12`) would otherwise allocate until the
/// process aborts. A million runs is days of simulation; split larger studies.
pub const MAX_RUNS: usize = 1_000_000;

/// The most swept parameters (columns) a plan may have.
pub const MAX_PARAMETERS: usize = 256;

/// The most values (runs × parameters) a plan may hold: 16 Mi values, 128 MiB.
pub const MAX_VALUES: usize = 1 << 24;

/// The longest plan line read, bytes: far above [`MAX_PARAMETERS`] values of 25 characters.
const MAX_LINE_BYTES: usize = 64 << 10;

/// The longest parameter name, characters.
const MAX_NAME_CHARS: usize = 256;

/// Refuses a parameter name that a plan could not carry as a CSV column and read back as
/// the same name, or that would reach a terminal or a file header as control characters.
pub fn check_name(name: &str, what: &str) -> Result<(), Error> {
    let shown = crate::archive::cut(&name.escape_debug().to_string(), 80);
    if name.is_empty() {
        return Err(Error::Config(format!("{what}: the parameter name is empty")));
    }
    if name.chars().count() > MAX_NAME_CHARS {
        return Err(Error::Config(format!(
            "{what}: the parameter name `{shown}` is longer than {MAX_NAME_CHARS} characters"
        )));
    }
    if let Some(c) = name.chars().find(|c| c.is_control() || matches!(c, ',' | '"')) {
        return Err(Error::Config(format!(
            "{what}: the parameter name `{shown}` holds {}: refused (it names a CSV column)",
            match c {
                ',' => "a comma".to_string(),
                '"' => "a quote".to_string(),
                c => format!("the control character U+{:04X}", c as u32),
            }
        )));
    }
    if name != name.trim() {
        return Err(Error::Config(format!(
            "{what}: the parameter name `{shown}` starts or ends with white space"
        )));
    }
    if matches!(name, "run" | "sample") {
        return Err(Error::Config(format!(
            "{what}: `{name}` names a plan column of its own, not a parameter"
        )));
    }
    Ok(())
}

/// `runs × parameters` within [`MAX_RUNS`] and [`MAX_VALUES`], or the arithmetic that is not.
fn check_size(runs: Option<usize>, shown: &str, parameters: usize) -> Result<usize, Error> {
    let runs = runs.ok_or_else(|| {
        Error::Config(format!(
            "{shown} runs overflows a {}-bit count: more than the {MAX_RUNS} a sweep may have",
            usize::BITS
        ))
    })?;
    if runs > MAX_RUNS {
        return Err(Error::Config(format!(
            "{shown} = {runs} runs: more than the {MAX_RUNS} a sweep may have"
        )));
    }
    match runs.checked_mul(parameters) {
        Some(v) if v <= MAX_VALUES => Ok(runs),
        _ => Err(Error::Config(format!(
            "{runs} runs × {parameters} parameters: more than the {MAX_VALUES} values a plan may hold"
        ))),
    }
}

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
        .map_err(|_| Error::Config(format!("{what}: `{}` is not a number", text.escape_debug())))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Error::Config(format!("{what}: `{}` is not finite", text.escape_debug())))
    }
}

/// `--grid NAME=a:b:n` (n points from a to b, ends included) or `NAME=v1;v2;…`.
pub fn parse_grid(text: &str) -> Result<Sweep, Error> {
    let what = format!("--grid {}", text.escape_debug());
    let (name, spec) =
        text.split_once('=').ok_or(Error::Config(format!("{what}: expected NAME=a:b:n")))?;
    let parts: Vec<&str> = spec.split(':').collect();
    let values = if parts.len() == 3 {
        let (a, b) = (number(parts[0], &what)?, number(parts[1], &what)?);
        let n: usize = parts[2].trim().parse().ok().filter(|&n| n >= 1).ok_or(Error::Config(
            format!("{what}: the point count `{}` is not a whole number ≥ 1", parts[2]),
        ))?;
        check_size(Some(n), &format!("{what}: {n} points"), 1)?;
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
    check_name(name.trim(), &what)?;
    Ok(Sweep { name: name.trim().to_string(), axis: Axis::Grid(values) })
}

/// `--sample NAME=normal(mean,sd)`, `uniform(lo,hi)` or `lognormal(mu,sigma)`.
pub fn parse_sample(text: &str) -> Result<Sweep, Error> {
    let what = format!("--sample {}", text.escape_debug());
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
    check_name(name.trim(), &what)?;
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
        if names.len() > MAX_PARAMETERS {
            return Err(Error::Config(format!(
                "{} swept parameters: more than the {MAX_PARAMETERS} a plan may have",
                names.len()
            )));
        }
        // Checked before anything is allocated: the product of the axes and the samples
        // may pass any cap, or wrap around to a small number (even 0) unchecked.
        let mut factors: Vec<String> = grids.iter().map(|(_, v)| v.len().to_string()).collect();
        if !sampled.is_empty() {
            factors.push(format!("{n_samples} samples"));
        }
        let runs = grids
            .iter()
            .map(|(_, v)| v.len())
            .chain([n_samples])
            .try_fold(1usize, |acc, n| acc.checked_mul(n));
        let shown = if factors.len() > 1 { factors.join(" × ") } else { factors.join("") };
        check_size(runs, &shown, names.len())?;
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
        // No overflow: the product with the samples was checked above.
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
        Plan::read(text.as_bytes(), None)
    }

    /// Reads a plan line by line from `from`, keeping every row, or with `only` just the
    /// rows whose run index it lists (in the order listed): the memory is that of the rows
    /// kept, not of the file. Refused: a header that is not `run,sample,<parameter>,…`, a
    /// parameter twice or a name [`check_name`] refuses, a line longer than 64 KiB, a
    /// field that is not a finite number, more rows than [`MAX_RUNS`], and a run index
    /// twice (every index when all rows are kept; those in `only` otherwise), or one in
    /// `only` that the plan lacks.
    pub fn read(mut from: impl BufRead, only: Option<&[usize]>) -> Result<Plan, Error> {
        let mut buf = Vec::new();
        let mut number = 0usize;
        let mut next_line = |buf: &mut Vec<u8>| -> Result<Option<usize>, Error> {
            loop {
                buf.clear();
                let mut line = std::io::Read::take(&mut from, MAX_LINE_BYTES as u64 + 1);
                let n =
                    line.read_until(b'\n', buf).map_err(|e| Error::Config(format!("plan: {e}")))?;
                if n == 0 {
                    return Ok(None);
                }
                number += 1;
                if buf.len() > MAX_LINE_BYTES && buf.last() != Some(&b'\n') {
                    return Err(Error::Config(format!(
                        "plan line {number}: longer than {MAX_LINE_BYTES} bytes"
                    )));
                }
                if !buf.iter().all(u8::is_ascii_whitespace) {
                    return Ok(Some(number));
                }
            }
        };
        let text = |buf: &[u8], i: usize| -> Result<String, Error> {
            std::str::from_utf8(buf)
                .map(|l| l.trim_end_matches(['\n', '\r']).to_string())
                .map_err(|_| Error::Config(format!("plan line {i}: not UTF-8 text")))
        };
        let i = next_line(&mut buf)?.ok_or(Error::Config("the plan is empty".into()))?;
        let header = text(&buf, i)?;
        let header = header.strip_prefix('\u{feff}').unwrap_or(&header);
        let cols: Vec<&str> = header.split(',').map(str::trim).collect();
        if cols.len() < 2 || cols[0] != "run" || cols[1] != "sample" {
            return Err(Error::Config(format!(
                "plan header must be `run,sample,<parameter>,…`, got `{}`",
                crate::archive::cut(&header.escape_debug().to_string(), 200)
            )));
        }
        let mut names: Vec<String> = Vec::new();
        for c in &cols[2..] {
            check_name(c, "plan header")?;
            if names.iter().any(|n| n == c) {
                return Err(Error::Config(format!(
                    "plan header: the parameter `{c}` is a column twice"
                )));
            }
            names.push(c.to_string());
        }
        if names.len() > MAX_PARAMETERS {
            return Err(Error::Config(format!(
                "plan header: {} parameters, more than the {MAX_PARAMETERS} a plan may have",
                names.len()
            )));
        }
        let mut seen: HashSet<usize> = HashSet::new();
        let mut kept: Vec<Option<Row>> = vec![None; only.map_or(0, <[usize]>::len)];
        let mut rows = Vec::new();
        let mut count = 0usize;
        while let Some(i) = next_line(&mut buf)? {
            let l = text(&buf, i)?;
            let bad = || {
                format!(
                    "plan line {i}: `{}`",
                    crate::archive::cut(&l.escape_debug().to_string(), 200)
                )
            };
            count += 1;
            check_size(Some(count), &format!("plan line {i}: {count} rows"), names.len())?;
            let f: Vec<&str> = l.split(',').map(str::trim).collect();
            if f.len() != cols.len() {
                return Err(Error::Config(format!("{}: expected {} fields", bad(), cols.len())));
            }
            let run: usize = f[0].parse().map_err(|_| Error::Config(bad()))?;
            let sample = f[1].parse().map_err(|_| Error::Config(bad()))?;
            let wanted: Vec<usize> = match only {
                None => vec![],
                Some(ks) => {
                    ks.iter().enumerate().filter(|(_, k)| **k == run).map(|(j, _)| j).collect()
                }
            };
            let keep = only.is_none() || !wanted.is_empty();
            let twice = if only.is_none() {
                !seen.insert(run)
            } else {
                wanted.iter().any(|&j| kept[j].is_some())
            };
            if twice {
                return Err(Error::Config(format!(
                    "plan line {i}: the run index {run} is given twice"
                )));
            }
            let values = f[2..]
                .iter()
                .map(|v| v.parse::<f64>().ok().filter(|x| x.is_finite()))
                .collect::<Option<Vec<f64>>>()
                .ok_or_else(|| Error::Config(format!("{}: not all finite numbers", bad())))?;
            if !keep {
                continue;
            }
            let row = Row { run, sample, values };
            match only {
                None => rows.push(row),
                Some(_) => wanted.iter().for_each(|&j| kept[j] = Some(row.clone())),
            }
        }
        if let Some(ks) = only {
            rows = kept
                .into_iter()
                .zip(ks)
                .map(|(r, k)| r.ok_or_else(|| Error::Config(format!("no row with run index {k}"))))
                .collect::<Result<_, _>>()?;
        }
        Ok(Plan { names, rows })
    }
}
