//! The plant's time grid: durations in ticks of 2⁻⁴⁰ s, and the dyadic levels of the
//! propagator tables (level `l` advances `2^l` ticks). Shared by the exponentials (`expm`)
//! and the piecewise linear system built on them (`linear`).

/// Seconds per tick: 2⁻⁴⁰ s (0.91 ps), fine enough for any event tolerance asked for.
pub const TICK: f64 = 1.0 / (1u64 << 40) as f64;

/// A step of `h` seconds in whole ticks and the sub-tick rest (s).
pub(crate) fn ticks_of(h: f64) -> (u64, f64) {
    let exact = h / TICK;
    (exact.floor() as u64, (exact - exact.floor()) * TICK)
}

/// Table levels: level `l` propagates `2^l` ticks; the top level is 2⁻⁹ s = 1.95 ms.
pub const LEVELS: usize = 32;
