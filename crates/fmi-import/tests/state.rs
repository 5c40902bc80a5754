//! FMU state through the importer, for the FMI 2.0 and the FMI 3.0 plant alike: save,
//! step on, restore, step again bit for bit; serialize and deserialize likewise; and the
//! refusals (a corrupt blob, a foreign or freed handle), each naming the real call.

mod common;

use common::dist;
use inchworm_fmi_import::{CsFmu, FmuError, VarType};
use inchworm_fmu_models::PlantFmu;

const H: f64 = 0.002;

fn started(name: &str) -> CsFmu {
    let mut f = CsFmu::load(&dist(name), "plant", false).unwrap();
    f.enter_initialization(None, 0.0, None).unwrap();
    f.exit_initialization().unwrap();
    f
}

/// `n` steps of the gait from step `k0`; the outputs of each step, as bits.
fn gait(f: &mut CsFmu, k0: usize, n: usize) -> Vec<(i32, bool, u64, u64)> {
    let dac = f.vrs_of(&PlantFmu::DAC_INPUTS.map(|v| v.name()), VarType::Real).unwrap();
    let enc = f.var_of(PlantFmu::ENCODER_COUNTS.name(), VarType::Integer).unwrap().vr;
    let closed = f.var_of(PlantFmu::EARTH_CLOSED.name(), VarType::Boolean).unwrap().vr;
    let x = f.var_of(PlantFmu::RUNNER_POSITION.name(), VarType::Real).unwrap().vr;
    (k0..k0 + n)
        .map(|k| {
            let v = [[0.0, 10.0, 0.0], [10.0, 10.0, 0.0], [10.0, 10.0, 10.0], [0.0, 0.0, 10.0]]
                [(k / 15) % 4];
            f.set_real(&dac, &v).unwrap();
            f.do_step(H).unwrap();
            let (mut c, mut b, mut p) = ([0], [false], [0.0]);
            f.get_integer(&[enc], &mut c).unwrap();
            f.get_boolean(&[closed], &mut b).unwrap();
            f.get_real(&[x], &mut p).unwrap();
            (c[0], b[0], p[0].to_bits(), f.time().to_bits())
        })
        .collect()
}

fn save_and_restore(name: &str) {
    let mut f = started(name);
    gait(&mut f, 0, 100);
    let state = f.get_state().unwrap();
    let first = gait(&mut f, 100, 120);
    assert_ne!(first[0].2, first[119].2, "{name}: the runner moved");
    f.set_state(&state).unwrap();
    assert_eq!(f.time(), 100.0 * H, "{name}: the time is the state's");
    assert_eq!(gait(&mut f, 100, 120), first, "{name}: restored, the run repeats bit for bit");

    // Serialized and read back, into this instance and into a fresh one.
    let bytes = f.serialize_state(&state).unwrap();
    f.free_state(state).unwrap();
    assert_eq!(f.states_held(), 0);
    let back = f.deserialize_state(&bytes).unwrap();
    f.set_state(&back).unwrap();
    assert_eq!(gait(&mut f, 100, 120), first, "{name}: deserialized, bit for bit");
    let mut g = started(name);
    let there = g.deserialize_state(&bytes).unwrap();
    g.set_state(&there).unwrap();
    assert_eq!(g.time(), 100.0 * H);
    assert_eq!(gait(&mut g, 100, 120), first, "{name}: in another instance, bit for bit");

    // A handle of another instance, and a freed one, are refused.
    let e = f.set_state(&there).unwrap_err().to_string();
    assert!(e.contains("the state was not taken from this instance, or was freed"), "{e}");
    f.free_state(back).unwrap();
    // States still held are freed with their instance (g holds `there`).
    drop(g);
}

#[test]
fn fmi2_state_saves_restores_and_serializes() {
    save_and_restore("InchwormPlant.fmu");
}

#[test]
fn fmi3_state_saves_restores_and_serializes() {
    save_and_restore("fmi3/InchwormPlant.fmu");
}

fn corrupt_blob(name: &str, call: &str) {
    let mut f = started(name);
    gait(&mut f, 0, 10);
    let state = f.get_state().unwrap();
    let bytes = f.serialize_state(&state).unwrap();
    // The FMU's own part damaged: the FMU refuses it.
    let mut bad = bytes.clone();
    let n = bad.len();
    bad.truncate(n - n / 3);
    match f.deserialize_state(&bad) {
        Err(FmuError::Call { function, .. }) => assert_eq!(function, call),
        other => panic!("{name}: {other:?}"),
    }
    // Not a blob of this importer at all.
    let e = f.deserialize_state(b"garbage").unwrap_err();
    assert!(matches!(e, FmuError::InvalidArgument { function, .. } if function == call), "{e}");
    assert!(e.to_string().contains("not a state serialized by this importer"), "{e}");
    // The instance is still fine.
    f.set_state(&state).unwrap();
    gait(&mut f, 10, 5);
}

#[test]
fn a_corrupt_fmi3_blob_is_refused_naming_fmi3_deserialize() {
    corrupt_blob("fmi3/InchwormPlant.fmu", "fmi3DeserializeFMUState");
}

#[test]
fn a_corrupt_fmi2_blob_is_refused_naming_fmi2_deserialize() {
    corrupt_blob("InchwormPlant.fmu", "fmi2DeSerializeFMUstate");
}

#[test]
fn without_the_capability_state_calls_are_unsupported_naming_the_flag() {
    let dir = common::scratch("nostate");
    let path = dir.join("nostate.fmu");
    let e: Vec<_> = common::entries(&dist("fmi3/InchwormPlant.fmu"))
        .into_iter()
        .map(|(n, b)| {
            if n == "modelDescription.xml" {
                let md = String::from_utf8(b).unwrap();
                // In <ModelExchange> and <CoSimulation> alike.
                let md =
                    md.replace(r#"canGetAndSetFMUState="true""#, r#"canGetAndSetFMUState="false""#);
                (n, md.into_bytes())
            } else {
                (n, b)
            }
        })
        .collect();
    common::write_zip(&path, &e);
    let mut f = CsFmu::load(&path, "plant", false).unwrap();
    let e = f.get_state().unwrap_err().to_string();
    assert!(
        e.contains("fmi3GetFMUState is not available: the FMU's modelDescription.xml does not declare canGetAndSetFMUState=\"true\""),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
