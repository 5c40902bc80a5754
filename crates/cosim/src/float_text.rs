//! The text of an `f64` as `format!("{x}")` writes it, at a fraction of `core::fmt`'s cost.
//!
//! `{}` writes the shortest decimal digits that read back as the same `f64` (of those, the
//! nearest to the value), in positional notation: `0.0000001`, not `1e-7`; `1`, not `1.0`;
//! `-0` for negative zero. [`zmij`] finds the same shortest, nearest digits (Schubfach),
//! several times faster than `core::fmt`'s Grisu with its Dragon fallback, and writes them
//! in its own notation (`1e-7`, `1.0`); [`push`] keeps that text where it is positional
//! and otherwise lays its digits and decimal exponent out as `{}` does.
//!
//! The two differ where two shortest candidates are equally near: `core::fmt` takes the
//! larger, zmij the even one (2⁻²⁵ is `0.000000029802322387695313` to `{}`, `…312` to
//! zmij). Such a tie needs a value whose exact decimal expansion has at most 18
//! significant digits (a shortest text has at most 17, the tie one more), so those values
//! ([`may_tie`]) take `core::fmt`'s text, as do NaN and the infinities; whole numbers below
//! 2⁵³ are written as integers. The tests compare the result with `{}` on millions of
//! values, subnormals, powers of two and ten and their neighbours among them, byte for
//! byte.

use std::io::Write;

/// Appends `x` to `out` as `format!("{x}")` would.
pub fn push(out: &mut Vec<u8>, x: f64) {
    // Whole numbers (±0 included; NaN and the infinities fail the range test). Below 2⁵³
    // the conversion to `i64` and back is exact, so it gives `x` back just when `x` is
    // whole.
    if x.abs() < TWO_POW_53 && (x as i64) as f64 == x {
        if x == 0.0 && x.is_sign_negative() {
            out.extend_from_slice(b"-0");
        } else {
            push_integer(out, x as i64);
        }
        return;
    }
    if !x.is_finite() || may_tie(x) {
        write!(out, "{x}").expect("a Vec takes any bytes");
        return;
    }
    let mut buffer = zmij::Buffer::new();
    let text = buffer.format_finite(x).as_bytes();
    // zmij writes `[-]d.ddd` (positional, as `{}` writes a number that is not whole) or
    // `[-]d[.ddd]e±x`, with `0.d…` below 1 in either.
    // The exponent, if any, is the text's last five bytes at most (`e-324`).
    let tail = text.len().saturating_sub(5);
    let Some(at) = text[tail..].iter().rposition(|&b| b == b'e').map(|at| tail + at) else {
        out.extend_from_slice(text);
        return;
    };
    let (sign, mantissa) = match text[..at].split_first() {
        Some((b'-', rest)) => (&text[..1], rest),
        _ => (&text[..0], &text[..at]),
    };
    let (lead, mut fraction) = mantissa.split_at(1);
    fraction = fraction.get(1..).unwrap_or_default();
    while let [rest @ .., b'0'] = fraction {
        fraction = rest;
    }
    // The value is 0.d₁d₂…dₙ × 10^`e`, d₁ the lead digit.
    let e = exponent_of(&text[at + 1..]) + 1;
    let n = 1 + fraction.len() as i32;
    out.extend_from_slice(sign);
    if e <= 0 {
        out.extend_from_slice(b"0.");
        out.resize(out.len() + e.unsigned_abs() as usize, b'0');
        out.extend_from_slice(lead);
        out.extend_from_slice(fraction);
    } else if e < n {
        let (whole, rest) = fraction.split_at(e as usize - 1);
        out.extend_from_slice(lead);
        out.extend_from_slice(whole);
        out.push(b'.');
        out.extend_from_slice(rest);
    } else {
        out.extend_from_slice(lead);
        out.extend_from_slice(fraction);
        out.resize(out.len() + (e - n) as usize, b'0');
    }
}

/// Appends the decimal digits of `i`, a `-` first if it is negative, as `{}` writes an
/// `i64`.
fn push_integer(out: &mut Vec<u8>, i: i64) {
    let mut digits = [0u8; 20];
    let mut at = digits.len();
    let mut n = i.unsigned_abs();
    loop {
        at -= 1;
        digits[at] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    if i < 0 {
        out.push(b'-');
    }
    out.extend_from_slice(&digits[at..]);
}

/// 2⁵³: every whole `f64` below it is an `i64` with the same `{}` text.
const TWO_POW_53: f64 = 9_007_199_254_740_992.0;

/// Whether the exact decimal expansion of the finite, non-zero `x` may have 18 significant
/// digits or fewer (`false` means it has more). With `x = m·2^e`, `m` odd: for `e < 0` the
/// expansion's digits are those of `m·5^-e`, which ends in 5, so it has more than 18 when
/// `m·5^-e ≥ 10^18`; for `e ≥ 0`, `x` is a whole number, which has more than 18 when it is
/// at least 10^18 and `m` has no factor 5 (then `x` no factor 10).
fn may_tie(x: f64) -> bool {
    let bits = x.to_bits();
    let biased = ((bits >> 52) & 0x7ff) as i32;
    let fraction = bits & ((1 << 52) - 1);
    let (m, e) = if biased == 0 { (fraction, -1074) } else { (fraction | 1 << 52, biased - 1075) };
    let zeros = m.trailing_zeros();
    let (m, e) = (m >> zeros, e + zeros as i32);
    if e >= 0 {
        x.abs() < 1e18 || m % 5 == 0
    } else {
        // 5^28 > 10^18 already.
        let k = e.unsigned_abs() as usize;
        k < POW5.len() && u128::from(m) * u128::from(POW5[k]) < 1_000_000_000_000_000_000
    }
}

/// 5^k for k = 0 … 27 (5^27 < 2^63).
const POW5: [u64; 28] = {
    let mut t = [1u64; 28];
    let mut k = 1;
    while k < t.len() {
        t[k] = t[k - 1] * 5;
        k += 1;
    }
    t
};

/// The exponent after zmij's `e`: an optional sign, then decimal digits.
fn exponent_of(text: &[u8]) -> i32 {
    let (sign, digits) = match text.split_first() {
        Some((b'-', rest)) => (-1, rest),
        Some((b'+', rest)) => (1, rest),
        _ => (1, text),
    };
    sign * digits.iter().fold(0i32, |acc, &d| acc * 10 + i32::from(d - b'0'))
}

#[cfg(test)]
mod tests {
    use super::push;

    fn check(x: f64) {
        let mut fast = Vec::new();
        push(&mut fast, x);
        assert_eq!(fast, format!("{x}").as_bytes(), "bits {:#018x}", x.to_bits());
    }

    fn neighbours(x: f64) {
        for y in [x, x.next_up(), x.next_down(), -x, (-x).next_up(), (-x).next_down()] {
            check(y);
        }
    }

    #[test]
    fn special_values_are_core_fmt_text() {
        for x in [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.1,
            0.2,
            0.3,
            1e-7,
            -1e-7,
            3e-9,
            1.5,
            0.002,
            1e300,
            1e16,
            1e15,
            1e17,
            1e21,
            1e22,
            1e23,
            9007199254740992.0,
            9007199254740993.0,
            123456789012345680.0,
            f64::MAX,
            f64::MIN,
            f64::MIN_POSITIVE,
            f64::EPSILON,
            f64::from_bits(1),
            f64::from_bits(0x000f_ffff_ffff_ffff),
            5e-324,
            2.2250738585072014e-308,
            2f64.powi(-25),
            -1149636667324797.2,
            1.5e300,
            5e20,
            1e18 + 128.0,
            f64::NAN,
            -f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ] {
            check(x);
        }
    }

    #[test]
    fn powers_of_two_and_ten_and_their_neighbours_are_core_fmt_text() {
        for e in -1074..=1023 {
            neighbours(2f64.powi(e));
        }
        for e in -323..=308 {
            neighbours(format!("1e{e}").parse().unwrap());
            neighbours(format!("5e{e}").parse().unwrap());
            neighbours(format!("9.999999999999999e{e}").parse().unwrap());
        }
        for k in 0..100_000 {
            check(f64::from(k));
            check(f64::from(k) * 0.001);
            check(f64::from(k) * 0.002);
        }
    }

    #[test]
    fn whole_numbers_are_core_fmt_text() {
        // Every digit count of both signs up to 2⁵³, where the integer path ends.
        let mut x = 1.0f64;
        while x < 1e16 {
            neighbours(x);
            neighbours(x - 1.0);
            neighbours(x * 7.0 + 3.0);
            x *= 10.0;
        }
        for x in [9007199254740991.0, 9007199254740992.0, -9007199254740991.0, 4503599627370495.5] {
            neighbours(x);
        }
        let mut s = 0x6a09_e667_f3bc_c909u64;
        for _ in 0..200_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let whole = (s >> 11) as i64 >> (s % 53);
            check(whole as f64);
        }
    }

    #[test]
    fn random_bit_patterns_are_core_fmt_text() {
        // Every binade alike, subnormals and both signs included.
        let mut s = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..2_000_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            check(f64::from_bits(s));
        }
    }

    #[test]
    fn random_values_of_a_closed_loop_are_core_fmt_text() {
        // Values spread as a trace's are: a few binades around 1 µm … 10 V, and sums of
        // them, which carry long shortest texts.
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..1_000_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let m = (s >> 11) as f64 / (1u64 << 53) as f64;
            let e = (s % 40) as i32 - 30;
            check(m * 10f64.powi(e));
            check(m + f64::from((s % 997) as u32) * 0.002);
        }
    }
}
