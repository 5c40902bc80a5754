//! Property tests of the serialized FMU state (crates/properties: 10 000 cases each, a
//! fixed seed), through the FMI 2.0 entry points of the plant as a master calls them.
//! The bases are states of the plant after a few seeded gait periods of DAC inputs.
//!
//! * Any edit of a state (bytes cut, flipped, repeated, inserted) is refused: the CRC-32
//!   frame catches it, and the instance is left as it was.
//! * Edits behind a recomputed CRC (what a hostile file does) reach the checks behind it:
//!   refused with fmi2Error and a logged reason, or restored into an instance that steps
//!   on with a defined status and finite outputs. Never a panic, never fmi2Fatal.

use inchworm_fmi_export::testing::Harness;
use inchworm_fmu_models::PlantFmu;
use inchworm_properties::{apply, check, edits, Edit};
use proptest::prelude::*;

const DAC: [u32; 3] = [1, 2, 3];
const OUTPUTS: [u32; 6] = [11, 12, 13, 14, 15, 10];
const H: f64 = 0.002;
const OK: i32 = 0;
const ERROR: i32 = 3;

/// A state after `steps` steps of a gait-like DAC sequence, and its time.
fn base(steps: u32) -> (Vec<u8>, f64) {
    let p = Harness::<PlantFmu>::init("base");
    p.take_logged();
    // A gait: a brake PZT at 0 V holds, at 10 V releases; one brake holds at all times.
    let volts = [
        [0.0, 10.0, 0.0],
        [0.0, 10.0, 7.5],
        [0.0, 0.0, 7.5],
        [10.0, 0.0, 7.5],
        [10.0, 0.0, 0.0],
        [0.0, 0.0, 0.0],
    ];
    for k in 0..steps {
        let phase = (k / 10) as usize % volts.len();
        for (vr, v) in DAC.iter().zip(volts[phase]) {
            assert_eq!(p.set_real(*vr, v), OK);
        }
        // A slip (both brakes open a moment) is a warning: a state the properties want too.
        assert!(p.step(f64::from(k) * H, H) <= 1, "{:?}", p.logged());
    }
    (p.serialize(), f64::from(steps) * H)
}

fn bases() -> Vec<(Vec<u8>, f64)> {
    [0, 7, 40, 133].into_iter().map(base).collect()
}

/// The frame's CRC-32 recomputed over the edited bytes.
fn reseal(v: &mut [u8]) {
    if v.len() >= 4 {
        let n = v.len() - 4;
        let crc = crc32(&v[..n]);
        v[n..].copy_from_slice(&crc.to_le_bytes());
    }
}

/// CRC-32 (IEEE), as the state frame uses it.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = (crc >> 1) ^ (0xEDB8_8320 & (crc & 1).wrapping_neg());
        }
    }
    !crc
}

fn outputs(p: &Harness<PlantFmu>) -> Vec<f64> {
    OUTPUTS[..5].iter().map(|&vr| p.real(vr).1).collect()
}

#[test]
fn any_edit_of_a_state_is_refused_and_changes_nothing() {
    let bases = bases();
    let target = Harness::<PlantFmu>::init("target");
    let before = outputs(&target);
    check("FMU state: edits", (0..bases.len(), edits()), |(i, e): (usize, Vec<Edit>)| {
        let edited = apply(&bases[i].0, &e);
        if edited == bases[i].0 {
            return Ok(());
        }
        prop_assert_eq!(target.deserialize(&edited), ERROR);
        let why = target.take_logged();
        prop_assert!(why.iter().any(|l| l.contains("fmi2DeSerializeFMUstate")), "{:?}", why);
        prop_assert_eq!(outputs(&target), before.clone());
        Ok(())
    });
}

#[test]
fn edits_behind_a_valid_crc_are_refused_or_step_on() {
    let bases = bases();
    let edited = (0..bases.len(), edits(), 0u8..2);
    let restored = std::cell::Cell::new(0u32);
    check("FMU state: edits behind a valid CRC", edited, |(i, e, dac)| {
        let (blob, t) = &bases[i];
        let mut bytes = apply(blob, &e);
        reseal(&mut bytes);
        let p = Harness::<PlantFmu>::init("restored");
        match p.deserialize(&bytes) {
            OK => {
                restored.set(restored.get() + 1);
                for vr in DAC {
                    prop_assert_eq!(p.set_real(vr, 10.0 * f64::from(dac)), OK);
                }
                let status = p.step(*t, H);
                prop_assert!(status == OK || status == 1 || status == ERROR, "status {}", status);
                if status != ERROR {
                    for v in outputs(&p) {
                        prop_assert!(v.is_finite(), "a restored state stepped to {}", v);
                    }
                }
            }
            ERROR => {
                let why = p.take_logged();
                prop_assert!(why.iter().any(|l| l.contains("fmi2")), "no reason logged: {:?}", why);
            }
            s => prop_assert!(false, "fmi2DeSerializeFMUstate returned {}", s),
        }
        Ok(())
    });
    // Both ways were taken: some edits (a value of a state's float) restore and step on.
    eprintln!("FMU state: {} of the edited states behind a valid CRC restored", restored.get());
    assert!(restored.get() > 100, "{} restored", restored.get());
}
