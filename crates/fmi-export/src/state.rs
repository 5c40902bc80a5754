//! The core's states and the masks of the states each call is allowed in: one bit per
//! [`State`], so that an entry point names its allowed states as one mask.

/// The core state machine: the states of FMI 2.0 Co-Simulation (section 4.2.4), one bit
/// each so that every entry point names the states it is allowed in as a mask. FMI 3.0
/// Co-Simulation without event mode (section 4.2) is the same machine with fewer states:
/// its Step Mode is StepComplete, and it never enters StepInProgress, StepFailed or
/// StepCanceled ([`Standard::STATES`]). Model Exchange (FMI 2.0 section 3.2.3, FMI 3.0
/// section 3.2) shares Instantiated, InitializationMode, Terminated, Error and Fatal and
/// adds EventMode and ContinuousTimeMode; which states an instance may be in is its
/// [`Interface`]'s. The codes are also those of the serialized-state frame, so a blob
/// saved through one standard restores through the other.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
pub enum State {
    Instantiated = 1 << 0,
    InitializationMode = 1 << 1,
    StepComplete = 1 << 2,
    StepInProgress = 1 << 3,
    StepFailed = 1 << 4,
    StepCanceled = 1 << 5,
    Terminated = 1 << 6,
    Error = 1 << 7,
    Fatal = 1 << 8,
    EventMode = 1 << 9,
    ContinuousTimeMode = 1 << 10,
    /// FMI 3.0 Scheduled Execution (section 5.2): initialized, the scheduler activates
    /// model partitions.
    ClockActivationMode = 1 << 11,
}

impl State {
    /// The FMI 2.0 name; [`Standard::state_name`] gives each standard's own.
    pub fn name(self) -> &'static str {
        match self {
            State::Instantiated => "Instantiated",
            State::InitializationMode => "InitializationMode",
            State::StepComplete => "StepComplete",
            State::StepInProgress => "StepInProgress",
            State::StepFailed => "StepFailed",
            State::StepCanceled => "StepCanceled",
            State::Terminated => "Terminated",
            State::Error => "Error",
            State::Fatal => "Fatal",
            State::EventMode => "EventMode",
            State::ContinuousTimeMode => "ContinuousTimeMode",
            State::ClockActivationMode => "ClockActivationMode",
        }
    }
}

const I: u16 = State::Instantiated as u16;
const IM: u16 = State::InitializationMode as u16;
const SC: u16 = State::StepComplete as u16;
const SIP: u16 = State::StepInProgress as u16;
const SF: u16 = State::StepFailed as u16;
const SCA: u16 = State::StepCanceled as u16;
const T: u16 = State::Terminated as u16;
const E: u16 = State::Error as u16;
const EM: u16 = State::EventMode as u16;
const CTM: u16 = State::ContinuousTimeMode as u16;
const CAM: u16 = State::ClockActivationMode as u16;

/// The allowed-state masks, named for the calls that use them.
pub const INSTANTIATED: u16 = I;
pub const INITIALIZATION: u16 = IM;
pub const STEPPING: u16 = SC;
pub const STEP_ENDED: u16 = SC | SF | SCA;
pub const TERMINABLE: u16 = STEP_ENDED | EM | CTM | CAM;
pub const LIVE: u16 = I | IM | SC | SIP | SF | SCA | T | E | EM | CTM | CAM;
pub const GETTABLE: u16 = IM | SC | SF | SCA | T | E | EM | CTM | CAM;
pub const SETTABLE: u16 = I | IM | SC | EM | CTM | CAM;
pub const STATE_CALLS: u16 = I | IM | SC | SF | SCA | T | E | EM | CTM | CAM;
/// Model Exchange (FMI 2.0 section 3.2.3, FMI 3.0 section 3.2): time moves in both
/// modes; the integrator sets states only between events; states, derivatives and
/// indicators are readable once initialized (the model is built at exit from
/// initialization); nominals are constants of the table.
pub const TIMED: u16 = EM | CTM;
pub const EVENT_MODE: u16 = EM;
/// Clocks (FMI 3.0 section 2.2.8): output clocks are read in event mode and, in Scheduled
/// Execution, after the FMU's `clockUpdate`; intervals are known once initializing.
pub const CLOCK_READABLE: u16 = EM | CAM;
pub const INTERVALS: u16 = IM | SC | EM | CTM | CAM | T;
pub const CONTINUOUS_TIME: u16 = CTM;
pub const ME_READABLE: u16 = EM | CTM | T | E;
pub const NOMINALS: u16 = I | IM | EM | CTM | T | E;
pub const STATUS_CALLS: u16 = SC | SIP | SF | SCA | T;
pub const AFTER_STEP: u16 = SC | SF | SCA | T | E;
/// Every state the core has; a standard has those of [`Standard::STATES`].
pub const ALL_STATES: u16 = LIVE | State::Fatal as u16;
