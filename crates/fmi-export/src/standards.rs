//! The facts each standard gives the core, side by side: one row per fact, so that where
//! FMI 2.0 and FMI 3.0 differ, the difference is that row. What takes code rather than a
//! value (the logger call, the names of states and types) is each standard's
//! [`crate::Standard`] impl, next to its C functions.

use crate::api::Fmi2;
use crate::entry::ALL_STATES;
use crate::fmi3::{api::Fmi3, TIME_VR};
use crate::instance::State;

macro_rules! facts {
    ($($(#[doc = $doc:literal])* $name:ident: $ty:ty = $two:expr, $three:expr;)*) => {
        /// The facts of one standard, for the core.
        pub trait Facts {
            $($(#[doc = $doc])* const $name: $ty;)*
        }
        impl Facts for Fmi2 {
            $(const $name: $ty = $two;)*
        }
        impl Facts for Fmi3 {
            $(const $name: $ty = $three;)*
        }
    };
}

/// The core states FMI 3.0 Co-Simulation without event mode never enters.
const FMI2_ONLY: u16 =
    State::StepInProgress as u16 | State::StepFailed as u16 | State::StepCanceled as u16;

facts! {
    /// For messages.
    VERSION: &'static str = "FMI 2.0", "FMI 3.0";
    /// The major version, which a serialized state carries.
    MAJOR: u16 = 2, 3;
    /// The function-name prefix.
    PREFIX: &'static str = "fmi2", "fmi3";
    /// The core states the standard has; a serialized state in another is refused.
    STATES: u16 = ALL_STATES, ALL_STATES & !FMI2_ONLY;
    /// FMI 2.0 allows `fmi2GetFMUstate` in Error (the table of section 4.2.4); FMI 3.0
    /// (section 2.2.3) leaves Error only by `fmi3SetFMUState`, `fmi3Reset` or freeing, so
    /// there is no state in Error worth saving. The one rule in which they differ here.
    GET_STATE_IN_ERROR: bool = true, false;
    /// FMI 3.0 has clocks (section 2.2.8); FMI 2.0 FMUs built from a table with clock
    /// rows leave them, and the clocked variables' `clocks`, out.
    CLOCKS: bool = false, true;
    /// FMI 3.0 declares a marked run of scalars as one array variable (crate::arrays).
    ARRAYS: bool = false, true;
    /// The independent variable `time` FMI 3.0 requires, owned by the layer.
    TIME_VR: Option<u32> = None, Some(TIME_VR);
    /// FMI 3.0's logger has no instance-name argument, so the name leads the message.
    NAME_IN_MESSAGE: bool = false, true;
    /// Where the master sets the stop time, for the message of a step past it.
    EXPERIMENT_FN: &'static str = "fmi2SetupExperiment", "fmi3EnterInitializationMode";
    /// How the standard calls the value-reference and value arguments.
    VALUE_ARGS: &'static str = "vr or value", "valueReferences or values";
    /// How it calls the token checked at instantiation.
    TOKEN_ARG: &'static str = "fmuGUID", "instantiationToken";
    /// Why `Get*DirectionalDerivative` is refused by a model without them.
    NO_DIRECTIONAL_DERIVATIVES: &'static str = "providesDirectionalDerivative is false (estimate derivatives by finite differences over fmi2GetFMUstate and fmi2SetFMUstate)", "providesDirectionalDerivatives is false (estimate derivatives by finite differences over fmi3GetFMUState and fmi3SetFMUState)";
    /// How it spells an FMU state.
    FMU_STATE: &'static str = "FMUstate", "FMUState";
}
