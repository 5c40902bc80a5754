//! The 16-bit DACs over 0..10 V: the controller's quantizer and its inverse, shared with
//! whoever turns codes back into volts so the plant sees the same bits either way.

/// Full scale of the 16-bit DACs (V).
pub use inchworm_board::{DAC_FULL_SCALE, DAC_MAX_CODE};

pub(crate) fn quantize(v: f64) -> (f64, u16) {
    let code = inchworm_board::round_half_away(v / DAC_FULL_SCALE * f64::from(DAC_MAX_CODE))
        .clamp(0.0, f64::from(DAC_MAX_CODE)) as u16;
    (volts_of_code(code), code)
}

/// The volts a DAC code stands for: the inverse of the controller's quantizer, and the
/// very value it holds as its quantized output. Whoever turns codes back into volts (a
/// board, a co-simulation) calls this, so the plant sees the same bits either way.
pub fn volts_of_code(code: u16) -> f64 {
    f64::from(code) * DAC_FULL_SCALE / f64::from(DAC_MAX_CODE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dac_quantization_is_16_bit_over_10_v() {
        assert_eq!(quantize(0.0), (0.0, 0));
        assert_eq!(quantize(10.0), (10.0, 65535));
        assert_eq!(quantize(12.0).1, 65535, "clamped to full scale");
        let (v, c) = quantize(3.0);
        assert_eq!(c, 19661, "3 V = 0.3 × 65535 = 19660.5, rounded half away from zero");
        assert_eq!(v, 19661.0 * 10.0 / 65535.0);
    }

    #[test]
    fn volts_of_code_inverts_the_quantizer_bit_for_bit() {
        for code in 0..=DAC_MAX_CODE {
            let v = volts_of_code(code);
            // The quantizer's own volts for that code, and the formula boards used before.
            assert_eq!(quantize(v), (v, code), "code {code}");
            assert_eq!(v.to_bits(), (f64::from(code) * 10.0 / 65535.0).to_bits(), "code {code}");
        }
        assert_eq!((volts_of_code(0), volts_of_code(DAC_MAX_CODE)), (0.0, DAC_FULL_SCALE));
    }
}
