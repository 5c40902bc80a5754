//! The driver board's fixed facts, which the plant, the controller, the FMUs' variable
//! tables and the HIL bridge all need: one place for each (docs/model.md §2.1, §2.6).

/// The DACs' full scale (V): a code of [`DAC_MAX_CODE`] is this many volts, and the plant
/// holds its DAC inputs within `0..=DAC_FULL_SCALE`.
pub const DAC_FULL_SCALE: f64 = 10.0;

/// The DACs' largest code: 16-bit converters.
pub const DAC_MAX_CODE: u16 = u16::MAX;

/// The encoder's resolution (m per count): the 1.2 nm of the flight device, the default
/// of both the plant's and the controller's `q_enc`.
pub const ENCODER_RESOLUTION: f64 = 1.2e-9;

/// `x` rounded to the nearest whole number, half away from zero: the rule of the DACs'
/// quantizer and the encoder's count (docs/model.md §2.6), `f64::round`'s bits for every
/// input. Without SSE4.1 `f64::round` is a call into the C library; this is a few
/// instructions inline, on the path of every step of the plant and the controller.
#[inline]
pub fn round_half_away(x: f64) -> f64 {
    // Below 2⁵² in magnitude a double may have a fraction; from there on it is whole (and
    // NaN and the infinities are their own rounding).
    const WHOLE: f64 = 4_503_599_627_370_496.0;
    if x.is_nan() || x.abs() >= WHOLE {
        return x;
    }
    // Truncation through i64 is exact here, and so is the fraction `x - t`: it keeps
    // the low bits of `x`'s significand.
    let t = x as i64 as f64;
    let fraction = x - t;
    let r = if fraction >= 0.5 {
        t + 1.0
    } else if fraction <= -0.5 {
        t - 1.0
    } else {
        t
    };
    // A zero takes `x`'s sign, as `round(-0.3)` is `-0.0`.
    r.copysign(x)
}

#[cfg(test)]
mod tests {
    use super::round_half_away;

    #[test]
    fn round_half_away_is_f64_round_bit_for_bit() {
        let specials = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            2.5,
            -2.5,
            0.49999999999999994,
            -0.49999999999999994,
            4_503_599_627_370_495.5,
            -4_503_599_627_370_495.5,
            4_503_599_627_370_496.0,
            9_007_199_254_740_993.0,
            f64::MAX,
            f64::MIN_POSITIVE,
            5e-324,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        let mut rng = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            rng
        };
        let random = (0..200_000).map(|k| match k % 4 {
            // Any bit pattern: every binade, both signs, NaNs.
            0 => f64::from_bits(next()),
            // Halves and their neighbours, where the rule matters.
            1 => {
                let half = (next() % 200_000) as f64 / 2.0 - 50_000.0;
                let ulps = (next() % 5) as i64 - 2;
                f64::from_bits((half.to_bits() as i64 + ulps) as u64)
            }
            // The DAC's and the encoder's ranges.
            2 => (next() >> 11) as f64 / (1u64 << 53) as f64 * 70_000.0 - 1_000.0,
            _ => ((next() >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 2e8,
        });
        for x in specials.into_iter().chain(random) {
            let (got, want) = (round_half_away(x), x.round());
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "round_half_away({x:e}) = {got:e}, f64::round gives {want:e}"
            );
        }
    }
}
