//! One FMU instance for every standard: the model, its state in the one core state
//! machine, its time, its log categories and its link to the master. What a standard
//! adds is its [`Standard`] impl: the logger call, the names it gives states, types and
//! arguments, and the few rules where FMI 2.0 and FMI 3.0 truly differ.

use std::ffi::{CStr, CString};
use std::fmt::{self, Write as _};
use std::os::raw::c_int;

use crate::access::Row;
use crate::arrays;
pub use crate::standards::Facts;
use crate::table::{Causality, Kind, Variability, Variable};
use crate::{Model, StepLog};

/// A status as both standards' C enums code it (`fmi2Status` and `fmi3Status` agree on
/// every value the layer returns, checked below at compile time).
pub type Status = c_int;
pub const OK: Status = 0;
pub const WARNING: Status = 1;
pub const ERROR: Status = 3;
pub const FATAL: Status = 4;

const _: () = {
    use inchworm_fmi_abi::{fmi2, fmi3};
    assert!(fmi2::fmi2OK == OK && fmi3::fmi3OK == OK);
    assert!(fmi2::fmi2Warning == WARNING && fmi3::fmi3Warning == WARNING);
    assert!(fmi2::fmi2Error == ERROR && fmi3::fmi3Error == ERROR);
    assert!(fmi2::fmi2Fatal == FATAL && fmi3::fmi3Fatal == FATAL);
};

pub use crate::state::State;

/// The interface an instance was instantiated for: one model, one core, two sets of
/// states and calls.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interface {
    CoSimulation,
    ModelExchange,
    /// FMI 3.0 Scheduled Execution: the importer's scheduler activates the model
    /// partitions (one per input clock) with `fmi3ActivateModelPartition`.
    ScheduledExecution,
}

/// How a Co-Simulation or Scheduled Execution instance was asked to run, beyond its
/// interface (FMI 3.0's instantiation arguments; FMI 2.0 has none of them).
#[derive(Clone, Copy, Debug, Default)]
pub struct Modes {
    /// `eventModeUsed`: steps end at input-clock ticks and the importer handles them in
    /// event mode.
    pub event_mode: bool,
    /// `earlyReturnAllowed`: a step that would pass a tick returns early at it.
    pub early_return: bool,
    /// Scheduled Execution's callbacks.
    pub scheduler: Option<Scheduler>,
}

/// The callbacks of a Scheduled Execution instance (FMI 3.0 section 5.2.1): the
/// environment they are called with, `clockUpdate` (an output clock ticked) and the
/// preemption lock the FMU takes around what its partitions share with the importer.
#[derive(Clone, Copy, Debug)]
pub struct Scheduler {
    pub env: *mut std::ffi::c_void,
    pub clock_update: Option<unsafe extern "C" fn(*mut std::ffi::c_void)>,
    pub lock: Option<unsafe extern "C" fn()>,
    pub unlock: Option<unsafe extern "C" fn()>,
}

impl Interface {
    /// The states an instance of this interface can be in, so that a saved state of the
    /// other interface is refused rather than restored into a state machine without it.
    pub fn states(self) -> u16 {
        let stepping = State::StepComplete as u16
            | State::StepInProgress as u16
            | State::StepFailed as u16
            | State::StepCanceled as u16;
        let (events, continuous) = (State::EventMode as u16, State::ContinuousTimeMode as u16);
        let activating = State::ClockActivationMode as u16;
        let only_other = match self {
            Interface::CoSimulation => continuous | activating,
            Interface::ModelExchange => stepping | activating,
            Interface::ScheduledExecution => stepping | events | continuous,
        };
        crate::state::ALL_STATES & !only_other
    }

    pub fn name(self) -> &'static str {
        match self {
            Interface::CoSimulation => "Co-Simulation",
            Interface::ModelExchange => "Model Exchange",
            Interface::ScheduledExecution => "Scheduled Execution",
        }
    }
}

/// One FMI standard's ABI as the core sees it: its facts ([`Facts`], side by side with
/// the other standard's in [`crate::standards`]) and what takes code. Every item is a
/// fact of the standard, not a policy: the policy (checks, masks, status) is the core's.
pub trait Standard: Facts + Sized + 'static {
    /// The logger and its environment.
    type Callbacks: Copy;

    fn state_name(s: State) -> &'static str;
    fn type_name(k: Kind) -> &'static str;
    fn has_logger(cb: &Self::Callbacks) -> bool;
    /// Calls the master's logger with one message.
    ///
    /// # Safety
    /// `cb` holds what the master passed at instantiation.
    unsafe fn emit(cb: &Self::Callbacks, line: Line);
}

/// One message for [`Standard::emit`], built: the instance name (none before an instance
/// exists), the status, the category and the text.
pub struct Line<'a> {
    pub name: Option<&'a CStr>,
    pub status: Status,
    pub category: &'a CStr,
    pub message: &'a CStr,
}

/// The log categories of `modelDescription.xml`, in the order declared there. Names
/// follow the standard's recommendations (FMI 2.0 section 2.2.4); `logAll` is the one
/// that selects every message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LogCategory {
    Events,
    StatusWarning,
    StatusError,
    All,
}

impl LogCategory {
    pub const ALL: [LogCategory; 4] = [
        LogCategory::Events,
        LogCategory::StatusWarning,
        LogCategory::StatusError,
        LogCategory::All,
    ];

    pub fn name(self) -> &'static str {
        self.c_name().to_str().unwrap_or_default()
    }

    fn c_name(self) -> &'static CStr {
        match self {
            LogCategory::Events => c"logEvents",
            LogCategory::StatusWarning => c"logStatusWarning",
            LogCategory::StatusError => c"logStatusError",
            LogCategory::All => c"logAll",
        }
    }

    pub fn from_name(name: &[u8]) -> Option<LogCategory> {
        LogCategory::ALL.into_iter().find(|c| c.c_name().to_bytes() == name)
    }

    /// The description in `modelDescription.xml` of the standard with function-name
    /// `prefix`: what counts as an event is the model's to say; the other categories are
    /// the layer's own.
    pub fn description<M: Model>(self, prefix: &str) -> String {
        match self {
            LogCategory::Events => M::info().log_events.to_string(),
            LogCategory::StatusWarning => format!("Calls that returned {prefix}Warning"),
            LogCategory::StatusError => {
                format!("Calls that returned {prefix}Error or {prefix}Fatal")
            }
            LogCategory::All => "Everything, including each call".to_string(),
        }
    }

    fn bit(self) -> u8 {
        1 << self as u8
    }
}

/// The set of enabled categories, one bit per [`LogCategory`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Categories(u8);

impl Categories {
    pub const NONE: Categories = Categories(0);
    pub const ALL: Categories = Categories((1 << LogCategory::ALL.len()) - 1);

    pub fn with(self, c: LogCategory) -> Categories {
        Categories(self.0 | c.bit())
    }
    pub fn without(self, other: Categories) -> Categories {
        Categories(self.0 & !other.0)
    }
    #[inline]
    pub fn contains(self, c: LogCategory) -> bool {
        self.0 & c.bit() != 0
    }
}

/// A string from outside (a name, a token, a category) as it goes into a message: cut
/// after [`Clip::MAX`] characters, so a master's runaway string cannot flood the log.
pub struct Clip<'a>(pub &'a str);

impl Clip<'_> {
    pub const MAX: usize = 80;
}

impl fmt::Display for Clip<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0.char_indices().nth(Clip::MAX) {
            None => f.write_str(self.0),
            Some((cut, _)) => write!(f, "{}… ({} bytes)", &self.0[..cut], self.0.len()),
        }
    }
}

/// Builds and sends one message; only called once it is known to be wanted.
pub(crate) fn emit<S: Standard>(
    cb: &S::Callbacks,
    name: Option<&CStr>,
    status: Status,
    category: LogCategory,
    message: fmt::Arguments,
) {
    if !S::has_logger(cb) {
        return;
    }
    let mut text = String::new();
    if let (true, Some(name)) = (S::NAME_IN_MESSAGE, name) {
        let _ = write!(text, "{}: ", Clip(&name.to_string_lossy()));
    }
    let _ = text.write_fmt(message);
    // Interior NULs would truncate the message; replace them rather than drop it.
    let msg = CString::new(text.replace('\0', " ")).unwrap_or_default();
    // SAFETY: the callbacks are the master's, as `Standard::emit` requires.
    let line = Line { name, status, category: category.c_name(), message: &msg };
    unsafe { S::emit(cb, line) };
}

/// What `Get*FMUState` saves.
#[derive(Clone)]
pub struct Snapshot<M> {
    pub model: M,
    pub state: State,
    pub time: f64,
    pub start_time: f64,
    pub stop_time: Option<f64>,
}

/// One instance of `M` under the standard `S`. Entry points reach it only through a
/// pointer the registry ([`crate::registry`]) knows as a live `Instance<S, M>`.
pub struct Instance<S: Standard, M: Model> {
    pub name: CString,
    pub callbacks: S::Callbacks,
    pub interface: Interface,
    /// Categories whose debug messages (status OK) reach the logger.
    pub categories: Categories,
    pub state: State,
    pub model: M,
    pub time: f64,
    pub start_time: f64,
    pub stop_time: Option<f64>,
    pub last_step_status: Status,
    /// Snapshots handed out by `Get*FMUState`, so `Set*FMUState` can refuse a pointer
    /// that is not one of them instead of dereferencing it.
    pub snapshots: Vec<*mut Snapshot<M>>,
    /// Reused by every step, so reporting nothing allocates nothing.
    pub step_log: StepLog,
    /// The standard's variables by value reference, each with its table rows (first,
    /// count: more than one for an FMI 3.0 array).
    index: Index,
    /// How often each input with a declared range was clamped into it (its warnings
    /// are bounded by these counts, `entry`).
    pub clamps: Vec<Clamps>,
    /// `eventModeUsed`, `earlyReturnAllowed` and the scheduler's callbacks.
    pub modes: Modes,
    /// The input clocks activated in the current event (value references), cleared on
    /// leaving event mode.
    pub active_clocks: Vec<u32>,
    /// The input clocks whose partitions ran in the current event (value references),
    /// cleared on leaving event mode: the event at a tick is left only once its clocks ran.
    pub ran_clocks: Vec<u32>,
    /// Scheduled Execution: the last partition's activation time, which no later one may
    /// precede.
    pub last_activation: Option<f64>,
    /// Co-Simulation with `eventModeUsed`: the last step ended at a tick with
    /// `eventHandlingNeeded` and the importer has not entered event mode since.
    pub tick_pending: bool,
    /// Ticks whose partitions the FMU ran itself because the importer did not activate
    /// their clocks (`entry::clocks::run_unhandled_ticks`); the first is logged.
    pub unhandled_ticks: u64,
}

/// The clamps of one input into its declared range since instantiation or reset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Clamps {
    pub vr: u32,
    /// Values clamped.
    pub count: u64,
    /// Of those, the ones a warning was logged for.
    pub logged: u64,
    /// `count` when the last summary of them was logged.
    pub summarized: u64,
}

/// What the index holds of one variable: its table rows (first, count: more than one for
/// an FMI 3.0 array), its type and the states it may be set in, so that the look-up of
/// every value of every `Get*`/`Set*` reads one entry and no row of the table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Indexed {
    pub first: u32,
    pub len: u32,
    pub kind: Kind,
    /// [`settable_states`] of the variable (the same for every element of an array,
    /// which `crate::arrays` holds to one declaration).
    pub settable: u16,
}

/// Every state of the core, for tables over them.
const STATES: [State; 12] = [
    State::Instantiated,
    State::InitializationMode,
    State::StepComplete,
    State::StepInProgress,
    State::StepFailed,
    State::StepCanceled,
    State::Terminated,
    State::Error,
    State::Fatal,
    State::EventMode,
    State::ContinuousTimeMode,
    State::ClockActivationMode,
];

/// The states in which a master may set `v`, one bit each as [`State`] codes them
/// (FMI 2.0 section 4.2.4, FMI 3.0 section 2.2): before initialization what has an exact
/// or approximate start and every input; after it inputs and tunable parameters; between
/// events only continuous-time inputs, as a discrete one waits for event mode, where the
/// model sees it. The call's own mask (`entry::SETTABLE`) is checked before.
pub fn settable_states(v: &Variable) -> u16 {
    let settable = |s: State| match s {
        State::Instantiated | State::InitializationMode => v.settable_before_init(),
        State::ContinuousTimeMode => {
            v.settable_after_init() && v.variability == Variability::Continuous
        }
        _ => v.settable_after_init(),
    };
    STATES.into_iter().filter(|&s| settable(s)).fold(0, |mask, s| mask | s as u16)
}

/// Value reference → [`Indexed`]. The models number their variables densely, so a lookup
/// is one load; a sparse numbering, which a direct table would make large, is searched by
/// binary search.
enum Index {
    /// The entry at the reference, `None` where there is none.
    Direct(Box<[Option<Indexed>]>),
    /// (reference, entry), sorted.
    Sorted(Box<[(u32, Indexed)]>),
}

impl Index {
    /// The index of the variables `(reference, entry)`.
    fn new(entries: impl Iterator<Item = (u32, Indexed)>) -> Index {
        let mut sorted: Vec<(u32, Indexed)> = entries.collect();
        sorted.sort_unstable_by_key(|e| e.0);
        let top = sorted.last().map_or(0, |e| e.0 as usize);
        if top <= 4 * sorted.len() + 64 {
            let mut direct = vec![None; top + 1];
            for &(vr, entry) in &sorted {
                direct[vr as usize] = Some(entry);
            }
            Index::Direct(direct.into_boxed_slice())
        } else {
            Index::Sorted(sorted.into_boxed_slice())
        }
    }

    /// The entry of the variable behind `vr`.
    #[inline]
    fn get(&self, vr: u32) -> Option<Indexed> {
        match self {
            Index::Direct(d) => *d.get(vr as usize)?,
            Index::Sorted(s) => Some(s[s.binary_search_by_key(&vr, |e| e.0).ok()?].1),
        }
    }
}

impl<S: Standard, M: Model> Instance<S, M> {
    pub fn new(
        name: CString,
        callbacks: S::Callbacks,
        (interface, modes): (Interface, Modes),
        logging_on: bool,
    ) -> Self {
        let vars = M::table();
        let mut entries = match S::ARRAYS {
            true => arrays::fmi3_entries(vars).unwrap_or_else(|_| arrays::scalar_entries(vars)),
            false => arrays::scalar_entries(vars),
        };
        entries.retain(|e| S::CLOCKS || vars[e.first].var.kind != Kind::Clock);
        let index = Index::new(entries.iter().map(|e| {
            let head = &vars[e.first].var;
            let (first, len) = (e.first as u32, e.len as u32);
            (head.vr, Indexed { first, len, kind: head.kind, settable: settable_states(head) })
        }));
        Instance {
            name,
            callbacks,
            interface,
            categories: if logging_on { Categories::ALL } else { Categories::NONE },
            state: State::Instantiated,
            model: M::new(),
            time: 0.0,
            start_time: 0.0,
            stop_time: None,
            last_step_status: OK,
            snapshots: Vec::new(),
            step_log: StepLog::default(),
            index,
            clamps: vars
                .iter()
                .map(|r| &r.var)
                .filter(|v| v.causality == Causality::Input && v.kind == Kind::Real)
                .filter(|v| v.min.is_some() || v.max.is_some())
                .map(|v| Clamps { vr: v.vr, count: 0, logged: 0, summarized: 0 })
                .collect(),
            modes,
            // Allocated once, so an activation in the loop allocates nothing.
            active_clocks: Vec::with_capacity(
                vars.iter().filter(|r| r.var.kind == Kind::Clock).count(),
            ),
            ran_clocks: Vec::with_capacity(
                vars.iter().filter(|r| r.var.kind == Kind::Clock).count(),
            ),
            last_activation: None,
            tick_pending: false,
            unhandled_ticks: 0,
        }
    }

    /// Sends a message to the master's logger. Errors and warnings always go out (the
    /// master needs them to understand a status, and FMI 2.0 section 2.1.5 has the FMU
    /// report why a call failed); debug messages only in an enabled category, or with
    /// `logAll` enabled. Nothing is formatted for a message nobody wants.
    pub fn log(&self, status: Status, category: LogCategory, message: fmt::Arguments) {
        if status >= WARNING || self.wants(category) {
            emit::<S>(&self.callbacks, Some(&self.name), status, category, message);
        }
    }

    /// Whether debug messages of `category` reach the logger.
    #[inline]
    pub fn wants(&self, category: LogCategory) -> bool {
        self.categories.contains(category) || self.categories.contains(LogCategory::All)
    }

    /// Logs why `func` was refused and returns the error.
    pub fn refuse(&self, func: &str, why: fmt::Arguments) -> Status {
        self.log(ERROR, LogCategory::StatusError, format_args!("{func}: {why}"));
        ERROR
    }

    /// The index entry of the variable behind `vr`.
    #[inline]
    pub fn indexed(&self, vr: u32) -> Option<Indexed> {
        self.index.get(vr)
    }

    /// The table rows of `entry`: one for a scalar, an FMI 3.0 array's elements in order.
    #[inline]
    pub fn rows_of(&self, entry: Indexed) -> &'static [Row<M>] {
        let (first, len) = (entry.first as usize, entry.len as usize);
        // Built from the table, so in it; an empty slice would be refused by its reader.
        M::table().get(first..first + len).unwrap_or_default()
    }

    /// The variable behind `vr` (an array's first element) and how many values it has.
    #[inline]
    pub fn variable(&self, vr: u32) -> Option<(&'static Variable, usize)> {
        let entry = self.indexed(vr)?;
        Some((&self.rows_of(entry).first()?.var, entry.len as usize))
    }

    pub fn snapshot(&self) -> Snapshot<M> {
        Snapshot {
            model: self.model.clone(),
            state: self.state,
            time: self.time,
            start_time: self.start_time,
            stop_time: self.stop_time,
        }
    }

    pub fn restore(&mut self, s: &Snapshot<M>) {
        self.model = s.model.clone();
        self.state = s.state;
        self.time = s.time;
        self.start_time = s.start_time;
        self.stop_time = s.stop_time;
        // A state holds no clock activations: an event resumes with none, and a scheduler
        // activates again from the restored time on.
        self.active_clocks.clear();
        self.ran_clocks.clear();
        self.tick_pending = false;
        self.last_activation = match self.interface {
            Interface::ScheduledExecution => Some(self.time),
            _ => None,
        };
    }
}

impl<S: Standard, M: Model> Drop for Instance<S, M> {
    fn drop(&mut self) {
        for s in self.snapshots.drain(..) {
            // SAFETY: every pointer in the list came from Box::into_raw and is freed once.
            drop(unsafe { Box::from_raw(s) });
        }
    }
}

/// What a caught panic says, for the log line that ends the instance.
pub(crate) fn panic_text(panic: &(dyn std::any::Any + Send)) -> &str {
    panic
        .downcast_ref::<&str>()
        .copied()
        .or_else(|| panic.downcast_ref::<String>().map(String::as_str))
        .unwrap_or("unknown panic")
}

#[cfg(test)]
mod tests {
    use super::{settable_states, Clip, Index, Indexed, State, STATES};
    use crate::table::{Kind, Variability};

    #[test]
    fn long_strings_from_outside_are_cut() {
        assert_eq!(Clip("short").to_string(), "short");
        let long = "é".repeat(200);
        let cut = Clip(&long).to_string();
        assert_eq!(cut, format!("{}… (400 bytes)", "é".repeat(Clip::MAX)));
    }

    /// Both forms find every reference's rows, and nothing in a hole or past the end.
    #[test]
    fn dense_and_sparse_references_find_their_rows() {
        // (reference, entry): an array of three among scalars.
        let rows = |refs: &[u32]| -> Vec<(u32, Indexed)> {
            let mut first = 0;
            refs.iter()
                .enumerate()
                .map(|(i, &vr)| {
                    let len = if i == 1 { 3 } else { 1 };
                    first += len;
                    let kind = if i == 2 { Kind::Integer } else { Kind::Real };
                    (vr, Indexed { first: first - len, len, kind, settable: i as u16 })
                })
                .collect()
        };
        let dense = rows(&[7, 1, 2, 3, 10, 4]);
        let sparse = rows(&[7, 1, 1_000_000, 3, 70_000]);
        let (d, s) = (Index::new(dense.iter().copied()), Index::new(sparse.iter().copied()));
        assert!(matches!(d, Index::Direct(_)));
        assert!(matches!(s, Index::Sorted(_)));
        for (index, entries) in [(&d, &dense), (&s, &sparse)] {
            for &(vr, entry) in entries {
                assert_eq!(index.get(vr), Some(entry), "reference {vr}");
            }
            for vr in [0, 5, 6, 8, 11, 69_999, 1_000_001, u32::MAX] {
                assert_eq!(index.get(vr), None, "reference {vr}");
            }
        }
    }

    /// The mask is the rule of `entry::write` before it was a table: inputs always (but
    /// a discrete one not between events), tunable parameters after initialization,
    /// fixed ones and starts before it, outputs never.
    #[test]
    fn settable_states_follow_causality_and_variability() {
        use crate::table::Variable;
        let bits = |states: &[State]| states.iter().fold(0, |m, &s| m | s as u16);
        let everywhere = STATES.iter().fold(0, |m, &s| m | s as u16);
        let input = Variable::input("u", 1, 0.0, None, "");
        assert_eq!(settable_states(&input), everywhere);
        let discrete = Variable::integer_input("n", 2, 0, None, "");
        assert_eq!(settable_states(&discrete), everywhere & !(State::ContinuousTimeMode as u16));
        let fixed = Variable::parameter("k", 3, 1.0, None, "");
        assert_eq!(
            settable_states(&fixed),
            bits(&[State::Instantiated, State::InitializationMode])
        );
        let mut tunable = fixed;
        tunable.variability = Variability::Tunable;
        let continuous = everywhere & !(State::ContinuousTimeMode as u16);
        assert_eq!(settable_states(&tunable), continuous);
        let output = Variable::output("y", 4, Kind::Real, None, "");
        assert_eq!(settable_states(&output), 0);
    }
}
