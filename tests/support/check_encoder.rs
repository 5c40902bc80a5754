//! The encoder input of the check trace (`tests/data/plant-check-trace-fia20-passive.csv`),
//! for the tests that drive a controller alone on it.

/// The encoder the controller reads at instant k = 0 ..= `samples`: the plant's after step
/// k - 1 (0 at k = 0).
pub fn encoder(samples: usize) -> Vec<i32> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/plant-check-trace-fia20-passive.csv"
    );
    let text = std::fs::read_to_string(path).unwrap();
    let after: Vec<i32> =
        text.lines().skip(1).map(|l| l.split(',').nth(4).unwrap().parse().unwrap()).collect();
    assert_eq!(after.len(), samples);
    std::iter::once(0).chain(after).collect()
}
