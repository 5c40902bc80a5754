//! State to bytes and back (for fmi2Get/Set/SerializeFMUstate): a restored controller
//! continues bit for bit; a bad payload is refused with a reason and changes nothing.

mod common;

use common::StepPlant;
use inchworm_controller::{Controller, Params, Sample, STATE_VERSION};

/// Runs `ticks` Jacobi samples from the controller's and plant's current states.
fn continue_run(
    c: &mut Controller,
    plant: &mut StepPlant,
    dac: &mut [f64; 3],
    ticks: usize,
) -> Vec<Sample> {
    (0..ticks)
        .map(|_| {
            let s = c.tick(plant.counts(), 100e-6);
            plant.interval(*dac);
            *dac = s.dac;
            s
        })
        .collect()
}

#[test]
fn a_restored_controller_continues_bit_for_bit() {
    let p = Params { prefilter: true, ..Params::default() };
    let mut a = Controller::new(p.clone()).unwrap();
    let mut plant = StepPlant::new(4.5e-6);
    let mut dac = [0.0; 3];
    // Mid-step of the prefiltered approach (several moves to go): 1234 ticks in.
    continue_run(&mut a, &mut plant, &mut dac, 1234);
    let mut bytes = Vec::new();
    a.save_state(&mut bytes);
    assert_eq!(bytes[0], STATE_VERSION);

    let mut b = Controller::new(p).unwrap();
    b.load_state(&bytes).unwrap();
    let (mut plant_a, mut dac_a) = (plant.clone(), dac);
    let (mut plant_b, mut dac_b) = (plant, dac);
    let sa = continue_run(&mut a, &mut plant_a, &mut dac_a, 3000);
    let sb = continue_run(&mut b, &mut plant_b, &mut dac_b, 3000);
    assert_eq!(sa, sb, "restored controller diverges");
    let mut again = Vec::new();
    b.save_state(&mut again);
    let mut now = Vec::new();
    a.save_state(&mut now);
    assert_eq!(again, now);
}

#[test]
fn bad_payloads_are_refused_and_change_nothing() {
    let mut c = Controller::new(Params::default()).unwrap();
    for j in 0..150 {
        c.tick(j * 10, 50e-6);
    }
    let mut good = Vec::new();
    c.save_state(&mut good);
    let before = c.clone();
    let refuse = |c: &mut Controller, bytes: &[u8], why: &str| {
        let e = c.load_state(bytes).expect_err(why);
        assert!(e.contains(why), "error {e:?} should say {why:?}");
    };
    let mut wrong_version = good.clone();
    wrong_version[0] = STATE_VERSION + 1;
    refuse(&mut c, &wrong_version, "version");
    refuse(&mut c, &good[..good.len() - 3], "truncated");
    let mut trailing = good.clone();
    trailing.push(0);
    refuse(&mut c, &trailing, "trailing");
    let mut ten = Controller::new(Params { samples_per_step: 10, ..Params::default() }).unwrap();
    refuse(&mut ten, &good, Params::SAMPLES_PER_STEP.name());
    let mut after = Vec::new();
    c.save_state(&mut after);
    assert_eq!(after, good, "a refused load leaves the controller as it was");
    assert_eq!(c.tick(1500, 50e-6), before.clone().tick(1500, 50e-6));
}
