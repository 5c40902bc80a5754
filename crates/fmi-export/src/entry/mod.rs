//! The entry points of every standard, written once. Each takes the C arguments already
//! reduced to what both standards share (an instance pointer, value references and
//! values as pointer and count, plain numbers); the per-standard files only name them.
//!
//! Every function follows one shape, as in the Reference-FMUs: check the instance pointer
//! and that the call is allowed in the current state (the masks below), check the
//! arguments, run the body inside `catch_unwind`, log every refusal with the function
//! name and the reason, and return a defined status.
//!
//! Status policy: a refused call (wrong state, bad argument, a NaN input) returns Error
//! and leaves the instance as it was, so the master can correct the call and go on; a
//! failure of the model itself (invalid parameters at exit from initialization, a failed
//! step) moves the instance to the Error state, from which only reset, free, getters and
//! state restore are allowed; a Rust panic (a bug) returns Fatal and moves it to Fatal,
//! from which only freeing the instance is allowed.
//!
//! Model Exchange is the same instance with its own states (EventMode and
//! ContinuousTimeMode, further bits of [`State`]) and its own calls, functions of the same
//! shape; an ME call on a Co-Simulation instance is refused by its mask, and a
//! Co-Simulation call on an ME instance likewise.
#![allow(clippy::missing_safety_doc, clippy::too_many_arguments)]

mod call;
mod clocks;
mod co_simulation;
mod fmu_state;
mod lifecycle;
mod model_exchange;
mod time;
mod values;

pub use crate::instance::{Standard, Status};
pub use crate::state::*;
pub use call::{unsupported, with_instance};
pub use clocks::{
    activate_model_partition, constant_intervals, enter_step_mode, get_clock, get_interval,
    get_shift, has_clocks, refusal, set_clock,
};
pub use co_simulation::{do_step, status_query, StepOutputs};
pub use fmu_state::{
    deserialize, free_fmu_state, get_fmu_state, serialize, serialized_size, set_fmu_state,
};
pub use lifecycle::{
    enter_initialization, exit_initialization, free_instance, instantiate, reset,
    set_debug_logging, setup_experiment, terminate,
};
pub use model_exchange::{
    completed_integrator_step, directional_derivative, enter_continuous_time_mode,
    enter_event_mode, get_array, get_count, set_continuous_states, set_time,
    update_discrete_states, Array, EventSink,
};
pub use time::same_time;
pub use values::{
    get, no_variables_of, set, Booleans, CBoolean, CTypes, Integers, Reals, Value, CLAMPS_IN_FULL,
};
