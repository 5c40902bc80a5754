//! A seeded, portable random stream for the plant tests: the same inputs on every machine.

/// splitmix64: the next 64 random bits.
pub fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut x = *state;
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// Uniform in [0, 1).
pub fn uniform(state: &mut u64) -> f64 {
    (splitmix(state) >> 11) as f64 / (1u64 << 53) as f64
}

/// The DAC volts of the docs/model.md §2.9 check trace (the five gaits, 1 s at 2 ms).
#[allow(dead_code)] // not every test binary that shares this module uses it
pub fn check_gaits() -> Vec<inchworm_plant::Dac> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/plant-check-trace-fia20-passive.csv"
    );
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("reading {path}: {e}"));
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            inchworm_plant::Dac { earth: f[1], nonearth: f[2], extension: f[3] }
        })
        .collect()
}
