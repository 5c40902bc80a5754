//! What the property tests of the parsers and decoders share: how many cases each runs,
//! with which seed, and the mutations of a valid input they are fed (docs/testing.md,
//! *Property tests*).
//!
//! Every property runs [`CASES`] cases (`INCHWORM_PROPERTY_CASES` to change) from a fixed
//! seed, so a CI run is the same run every time; `INCHWORM_PROPERTY_SEED=random` draws a
//! fresh one and prints it, a number replays it. A failure is kept as a named regression
//! test beside its property (proptest's seed files are off: a seed replays only under
//! the same strategy, a named input under any).

use std::cell::Cell;

use proptest::collection::vec;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestRunner};

/// The cases of every property, the floor.
pub const CASES: u32 = 10_000;

/// The seed of a CI run.
const SEED: u64 = 0x14c8_0a3d;

/// The seed and cases of this run, from the environment or the defaults.
fn settings() -> (u64, u32) {
    let seed = match std::env::var("INCHWORM_PROPERTY_SEED").as_deref() {
        Err(_) => SEED,
        Ok("random") => std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(SEED, |d| d.as_nanos() as u64 ^ u64::from(std::process::id())),
        Ok(n) => n.parse().expect("INCHWORM_PROPERTY_SEED: unset, `random` or a number"),
    };
    let cases = std::env::var("INCHWORM_PROPERTY_CASES")
        .map_or(CASES, |n| n.parse().expect("INCHWORM_PROPERTY_CASES: a number"));
    (seed, cases)
}

/// Runs `property` on the values of `strategy`, and panics with proptest's smallest
/// failing input if one fails. Prints how many cases ran (`cargo test -- --nocapture`
/// shows it) and checks that all of them did: a strategy that rejects its values would
/// otherwise pass on fewer.
pub fn check<S: Strategy>(
    name: &str,
    strategy: S,
    property: impl Fn(S::Value) -> Result<(), TestCaseError>,
) where
    S::Value: std::fmt::Debug,
{
    let (seed, cases) = settings();
    let config = Config {
        cases,
        rng_seed: RngSeed::Fixed(seed),
        failure_persistence: None,
        ..Config::default()
    };
    let ran = Cell::new(0u32);
    let mut runner = TestRunner::new(config);
    let outcome = runner.run(&strategy, |v| {
        ran.set(ran.get() + 1);
        property(v)
    });
    if let Err(e) = outcome {
        panic!("property {name} (INCHWORM_PROPERTY_SEED={seed}): {e}");
    }
    assert!(ran.get() >= cases, "property {name}: {} of {cases} cases ran", ran.get());
    eprintln!("property {name}: {cases} cases passed (seed {seed})");
}

/// One edit of a byte string, at a position taken modulo its length.
#[derive(Clone, Debug)]
pub enum Edit {
    /// Flips bit `bit` of the byte at `at`.
    Flip { at: usize, bit: u8 },
    /// Sets the byte at `at`.
    Set { at: usize, byte: u8 },
    /// Cuts the input at `at`.
    Truncate { at: usize },
    /// Inserts `bytes` at `at`.
    Insert { at: usize, bytes: Vec<u8> },
    /// Removes `len` bytes from `at`.
    Remove { at: usize, len: usize },
    /// Repeats the `len` bytes from `at` right after them.
    Duplicate { at: usize, len: usize },
}

/// Text a parser of numbers, XML or CSV finds hard: what a hostile or broken file holds.
const TOKENS: &[&str] = &[
    "NaN",
    "nan",
    "inf",
    "-inf",
    "1e308",
    "1e309",
    "-0",
    "0x10",
    "4294967296",
    "-2147483649",
    "99999999999999999999",
    "1e-400",
    "\"",
    "'",
    "<",
    ">",
    "&",
    "&amp;",
    "&#0;",
    "&#x110000;",
    "<![CDATA[",
    "]]>",
    "<!--",
    "-->",
    "<!DOCTYPE x [<!ENTITY e \"ee\">]>",
    "&e;",
    "=",
    ",",
    ";",
    "\n",
    "\r\n",
    "\t",
    " ",
    "\u{0}",
    "\u{feff}",
    "é",
    "\u{fffd}",
    "</",
    "/>",
    "?>",
    "true",
    "false",
    "1.5",
    "",
];

fn edit() -> impl Strategy<Value = Edit> {
    let at = any::<usize>();
    prop_oneof![
        (at, 0u8..8).prop_map(|(at, bit)| Edit::Flip { at, bit }),
        (at, any::<u8>()).prop_map(|(at, byte)| Edit::Set { at, byte }),
        at.prop_map(|at| Edit::Truncate { at }),
        (at, vec(any::<u8>(), 1..8)).prop_map(|(at, bytes)| Edit::Insert { at, bytes }),
        (at, proptest::sample::select(TOKENS))
            .prop_map(|(at, t)| Edit::Insert { at, bytes: t.as_bytes().to_vec() }),
        (at, 1usize..64).prop_map(|(at, len)| Edit::Remove { at, len }),
        (at, 1usize..64).prop_map(|(at, len)| Edit::Duplicate { at, len }),
    ]
}

/// One to four edits.
pub fn edits() -> impl Strategy<Value = Vec<Edit>> {
    vec(edit(), 1..5)
}

/// `base` with `edits` applied in order.
pub fn apply(base: &[u8], edits: &[Edit]) -> Vec<u8> {
    let mut v = base.to_vec();
    for e in edits {
        let n = v.len();
        let pos = |at: usize| if n == 0 { 0 } else { at % n };
        match e {
            Edit::Flip { at, bit } if n > 0 => v[pos(*at)] ^= 1 << bit,
            Edit::Set { at, byte } if n > 0 => v[pos(*at)] = *byte,
            Edit::Truncate { at } => v.truncate(at % (n + 1)),
            Edit::Insert { at, bytes } => {
                let i = at % (n + 1);
                v.splice(i..i, bytes.iter().copied());
            }
            Edit::Remove { at, len } if n > 0 => {
                let i = pos(*at);
                v.drain(i..(i + len).min(n));
            }
            Edit::Duplicate { at, len } if n > 0 => {
                let i = pos(*at);
                let piece = v[i..(i + len).min(n)].to_vec();
                let end = i + piece.len();
                v.splice(end..end, piece);
            }
            _ => {}
        }
    }
    v
}

/// `base` (text) with `edits` applied, as text: invalid UTF-8 becomes U+FFFD, as a reader
/// of text files would see it.
pub fn apply_text(base: &str, edits: &[Edit]) -> String {
    String::from_utf8_lossy(&apply(base.as_bytes(), edits)).into_owned()
}

/// Which of `bases` and how to edit it.
pub fn mutations(bases: usize) -> impl Strategy<Value = (usize, Vec<Edit>)> {
    (0..bases, edits())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edits_apply_at_positions_modulo_the_length() {
        let b = b"abcdef";
        assert_eq!(apply(b, &[Edit::Flip { at: 6, bit: 0 }]), b"`bcdef");
        assert_eq!(apply(b, &[Edit::Truncate { at: 9 }]), b"ab");
        assert_eq!(apply(b, &[Edit::Insert { at: 6, bytes: b"X".to_vec() }]), b"abcdefX");
        assert_eq!(apply(b, &[Edit::Remove { at: 4, len: 10 }]), b"abcd");
        assert_eq!(apply(b, &[Edit::Duplicate { at: 1, len: 2 }]), b"abcbcdef");
        assert_eq!(apply(b"", &[Edit::Set { at: 3, byte: 0 }]), b"");
    }
}
