//! Model Exchange through [`MeFmu`], for both standards, on the small FMU of
//! `tests/support/me_fmu.c`: the description's sizes, every ME call with the numbers the
//! model gives, events, and the refusals (wrong lengths, error statuses, the wrong
//! interface).

mod common;
#[path = "../../../tests/support/me_fmu.rs"]
mod me_fmu;

use inchworm_fmi_import::{ContinuousState, CsFmu, FmuError, MeFmu, VarType};
use me_fmu::Standard;

fn loaded(standard: Standard, tag: &str) -> MeFmu {
    let dir = common::scratch(tag);
    let path = me_fmu::build(&dir, "Decay", standard);
    // The FMU has no Co-Simulation interface at all.
    let e = CsFmu::load(&path, "cs", false).unwrap_err();
    assert!(matches!(e, FmuError::NotCoSimulation { .. }), "{e}");
    let mut fmu = MeFmu::load(&path, "decay", false).unwrap();
    fmu.enter_initialization(None, 0.0, None).unwrap();
    fmu.exit_initialization().unwrap();
    fmu
}

fn both(check: impl Fn(Standard, &str)) {
    check(Standard::Fmi2, "fmi2");
    check(Standard::Fmi3, "fmi3");
}

#[test]
fn the_description_gives_states_event_indicators_and_capabilities() {
    both(|standard, f| {
        let fmu = loaded(standard, "description");
        assert_eq!(fmu.nx(), 1, "{f}");
        assert_eq!(fmu.nz(), 1, "{f}");
        assert_eq!(fmu.continuous_states(), &[ContinuousState { state: 0, derivative: 1 }]);
        assert!(fmu.provides_directional_derivative());
        assert!(!fmu.completed_integrator_step_not_needed());
        assert!(fmu.is_model_exchange());
        assert_eq!(fmu.var_of("x", VarType::Real).unwrap().vr, 0);
    });
}

#[test]
fn every_call_gives_the_model_s_numbers() {
    both(|standard, f| {
        let mut fmu = loaded(standard, "calls");
        // The initial event iteration: one pass, the first time event at the period.
        let e = fmu.update_discrete_states().unwrap();
        assert!(!e.needs_update && !e.terminate && !e.states_changed, "{f}: {e:?}");
        assert_eq!(e.next_event_time, Some(0.25), "{f}");
        fmu.enter_continuous_time_mode().unwrap();

        fmu.set_time(0.1).unwrap();
        fmu.set_continuous_states(&[0.8]).unwrap();
        let mut v = [0.0];
        fmu.get_derivatives(&mut v).unwrap();
        assert_eq!(v, [-0.8], "{f}: x' = -a x + u");
        fmu.set_real(&[3], &[0.3]).unwrap();
        fmu.get_derivatives(&mut v).unwrap();
        assert_eq!(v, [-0.5], "{f}: the input reaches the derivative");
        fmu.get_event_indicators(&mut v).unwrap();
        assert!((v[0] - 0.3).abs() < 1e-15, "{f}: x - level = {}", v[0]);
        fmu.get_continuous_states(&mut v).unwrap();
        assert_eq!(v, [0.8]);
        fmu.get_nominals(&mut v).unwrap();
        assert_eq!(v, [1.0]);
        fmu.set_real(&[2], &[3.0]).unwrap();
        fmu.directional_derivative(&[1], &[0], &[0.5], &mut v).unwrap();
        assert_eq!(v, [-1.5], "{f}: ∂x'/∂x · 0.5 with a = 3");
        assert_eq!(fmu.completed_integrator_step(true).unwrap(), (false, false));

        // A state event: x below the level; then the time event at 0.25.
        fmu.set_continuous_states(&[0.4]).unwrap();
        fmu.enter_event_mode().unwrap();
        let e = fmu.update_discrete_states().unwrap();
        assert_eq!(e.next_event_time, Some(0.25));
        let mut n = [0];
        fmu.get_integer(&[7], &mut n).unwrap();
        assert_eq!(n, [1], "{f}: one crossing");
        fmu.set_time(0.25).unwrap();
        let e = fmu.update_discrete_states().unwrap();
        assert_eq!(e.next_event_time, Some(0.5), "{f}");
        fmu.get_integer(&[8], &mut n).unwrap();
        assert_eq!(n, [1], "{f}: one tick");
        fmu.enter_continuous_time_mode().unwrap();
        fmu.terminate().unwrap();
    });
}

#[test]
fn wrong_lengths_statuses_and_interfaces_are_refused_naming_the_call() {
    both(|standard, f| {
        let (two, fmi) = match standard {
            Standard::Fmi3 => (false, "fmi3"),
            _ => (true, "fmi2"),
        };
        let mut fmu = loaded(standard, "refusals");
        fmu.update_discrete_states().unwrap();
        fmu.enter_continuous_time_mode().unwrap();
        let e = fmu.get_derivatives(&mut [0.0; 2]).unwrap_err().to_string();
        let name = if two { "fmi2GetDerivatives" } else { "fmi3GetContinuousStateDerivatives" };
        assert_eq!(e, format!("Decay: {name}: a vector of 2 values, the FMU has 1"), "{f}");
        let e = fmu.get_event_indicators(&mut []).unwrap_err().to_string();
        assert!(e.contains(&format!("{fmi}GetEventIndicators: a vector of 0 values")), "{e}");
        let e = fmu.directional_derivative(&[1], &[0], &[1.0, 2.0], &mut [0.0]).unwrap_err();
        assert!(matches!(e, FmuError::InvalidArgument { .. }), "{e}");
        // The FMU refuses a NaN state.
        fmu.set_time(0.125).unwrap();
        let e = fmu.set_continuous_states(&[f64::NAN]).unwrap_err().to_string();
        assert_eq!(
            e,
            format!("Decay: {fmi}SetContinuousStates returned {fmi}Error at t = 0.125 s (the FMU's log messages above say why)")
        );
        // An unknown input of the directional derivative.
        let e = fmu.directional_derivative(&[1], &[2], &[1.0], &mut [0.0]).unwrap_err();
        assert!(
            e.to_string().contains(&format!("{fmi}GetDirectionalDerivative returned {fmi}Error")),
            "{e}"
        );
    });
}

#[test]
fn the_instance_goes_on_after_the_model_s_error_and_another_instance_shares_the_folder() {
    both(|standard, f| {
        let mut fmu = loaded(standard, "again");
        let mut other = fmu.instantiate_again("decay2", false).unwrap();
        assert_eq!(other.unpacked_dir(), fmu.unpacked_dir());
        assert!(other.is_model_exchange());
        other.set_integer(&[9], &[1]).unwrap();
        other.enter_initialization(None, 0.0, None).unwrap();
        other.exit_initialization().unwrap();
        let e = other.get_derivatives(&mut [0.0]).unwrap_err();
        assert!(matches!(e, FmuError::Call { .. }), "{f}: {e}");
        // The first instance is untouched by the second's mode.
        let mut v = [0.0];
        fmu.get_derivatives(&mut v).unwrap();
        assert_eq!(v, [-1.0], "{f}");
    });
}
