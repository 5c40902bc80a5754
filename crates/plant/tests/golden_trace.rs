//! Bit-exact guard of the plant solver: a long, varied DAC sequence (the SPEC 2.9 gaits,
//! long constant holds as in closed-loop regulation, random volts and odd step sizes),
//! every step's outputs, report and complete saved state hashed into one number.
//!
//! The golden value was computed with the solver before the quiet-step scan skip was
//! added (the scan of every event functional at every scan point), so it guards that
//! optimisations of the solver change no bit of its results. A deliberate change of the
//! numerics must update it, and say so.

use inchworm_plant::{Dac, Plant, PlantParams, ScanStats, StepReport};

const GOLDEN: u64 = 0x9eb1_26f1_792a_9307;

/// FNV-1a over 64-bit words.
struct Hash(u64);

impl Hash {
    fn word(&mut self, w: u64) {
        for b in w.to_le_bytes() {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01B3);
        }
    }
}

fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut x = *state;
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

fn uniform(state: &mut u64) -> f64 {
    (splitmix(state) >> 11) as f64 / (1u64 << 53) as f64
}

fn gait() -> Vec<Dac> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/reference/plant-check-trace-fia20.csv"
    );
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("reading {path}: {e}"));
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            Dac { earth: f[1], nonearth: f[2], extension: f[3] }
        })
        .collect()
}

/// The input sequence: (DAC, step size) pairs, 100+ s of simulated time.
pub fn sequence() -> Vec<(Dac, f64)> {
    const H: f64 = 0.002;
    let gait = gait();
    let mut seq = Vec::new();
    let mut rng = 0x5EED_2026_u64;
    for round in 0..12 {
        // The five gaits, then a long hold of their last volts (a parked controller).
        seq.extend(gait.iter().map(|d| (*d, H)));
        let last = *gait.last().unwrap();
        seq.extend(std::iter::repeat((last, H)).take(1500));
        // Closed-loop-like regulation: a few small moves of the extension, each held.
        for j in 0..4 {
            let ext = 2.0 + 6.0 * uniform(&mut rng);
            let d = Dac { extension: ext, ..last };
            seq.extend(std::iter::repeat((d, H)).take(300 + 100 * j));
        }
        // Each mode held: LOCKED, DRIVE, FREE, HOLD.
        for (e, n) in [(0.0, 10.0), (10.0, 10.0), (10.0, 0.0), (0.0, 0.0)] {
            let d = Dac { earth: e, nonearth: n, extension: 10.0 * uniform(&mut rng) };
            seq.extend(std::iter::repeat((d, H)).take(250));
        }
        // Random volts, some near the thresholds, and odd step sizes.
        for _ in 0..200 {
            let mut v = || {
                let u = uniform(&mut rng);
                if u < 0.3 {
                    10.0 * uniform(&mut rng)
                } else if u < 0.5 {
                    5.0 + 0.01 * (uniform(&mut rng) - 0.5)
                } else if u < 0.75 {
                    0.0
                } else {
                    10.0
                }
            };
            let d = Dac { earth: v(), nonearth: v(), extension: v() };
            let h = match round % 4 {
                0 => H,
                1 => [0.001, 0.0005, 0.0037, 0.002][(splitmix(&mut rng) % 4) as usize],
                2 => 0.0001 + 0.004 * uniform(&mut rng),
                _ => H,
            };
            let repeat = 1 + (splitmix(&mut rng) % 20) as usize;
            seq.extend(std::iter::repeat((d, h)).take(repeat));
        }
    }
    seq
}

/// What one run of the sequence gave.
pub struct Trace {
    hash: u64,
    time: f64,
    steps: usize,
    stats: ScanStats,
}

/// Runs the sequence and hashes every step's outputs, report and saved state; with
/// `scan_always`, on the solver's reference path (every scan point looked at).
pub fn trace_hash(params: PlantParams, scan_always: bool) -> Trace {
    let mut plant = Plant::new(params).unwrap();
    plant.set_scan_always(scan_always);
    let mut h = Hash(0xCBF2_9CE4_8422_2325);
    let mut state = Vec::new();
    let seq = sequence();
    for (d, dt) in &seq {
        let r: StepReport = plant.step(*d, *dt);
        let o = plant.outputs();
        h.word(o.encoder_counts as u64);
        for v in [
            o.encoder_position,
            o.runner_position,
            o.extension,
            o.voltage_earth,
            o.voltage_nonearth,
            o.voltage_extension,
        ] {
            h.word(v.to_bits());
        }
        h.word(o.mode as u64);
        h.word(u64::from(o.earth_closed) | u64::from(o.nonearth_closed) << 1);
        h.word(u64::from(o.slip_events));
        h.word(u64::from(r.brake_events));
        h.word(u64::from(r.slips));
        h.word(r.first_brake_event.map_or(u64::MAX, f64::to_bits));
        h.word(u64::from(r.event_budget_exhausted));
        for m in plant.play_memories() {
            h.word(m.to_bits());
        }
        state.clear();
        plant.save_state(&mut state);
        for b in &state {
            h.word(u64::from(*b));
        }
    }
    Trace { hash: h.0, time: plant.time(), steps: seq.len(), stats: plant.scan_stats() }
}

/// Both paths, the quiet-step bound and the full scan, give the golden hash.
fn check(name: &str, params: PlantParams, golden: u64) {
    for scan_always in [false, true] {
        let t = trace_hash(params.clone(), scan_always);
        eprintln!(
            "{name}, scan_always {scan_always}: {} steps, {:.3} s simulated, long scans run {} / skipped {}, hash {:#018x}",
            t.steps, t.time, t.stats.scanned, t.stats.skipped, t.hash
        );
        assert!(t.time >= 100.0, "the sequence covers {} s", t.time);
        assert_eq!(
            t.hash, golden,
            "{name}, scan_always {scan_always}: the solver's results changed (hash {:#018x})",
            t.hash
        );
        if scan_always {
            assert_eq!(t.stats, ScanStats::default(), "the reference path never skips");
        } else {
            assert!(t.stats.skipped > 0, "the bound never proved a scan clear");
        }
    }
}

#[test]
fn golden_trace_is_bit_identical() {
    check("fia20", PlantParams::fia20(), GOLDEN);
}

const GOLDEN_FIA6_TIGHT: u64 = 0x41b4_dff6_7e8b_940d;

#[test]
fn golden_trace_fia6_tight_tolerance_is_bit_identical() {
    // Another device and a 100x tighter tolerance: a 4x finer scan of 512 points per piece.
    check(
        "fia6, rel_tol 1e-11",
        PlantParams { rel_tol: 1e-11, ..PlantParams::fia6() },
        GOLDEN_FIA6_TIGHT,
    );
}
