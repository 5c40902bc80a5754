//! What the master accepts, defined once: the sizes it allocates for from a model
//! description (checked before the FMU is unpacked, let alone called) and the ranges of
//! the numbers it is given, by its caller (tolerances, step sizes) or by an FMU (event
//! times, nominals, states, derivatives). docs/model-exchange.md ("Caps and ranges")
//! says why each figure is what it is.

use inchworm_fmi_import::ModelDescription;

use crate::Error;

/// The most continuous states of a Model Exchange component. The BDF's Newton iteration
/// keeps dense `nx × nx` matrices (the Jacobian and its LU), so memory grows with `nx²`
/// and each factorization with `nx³`, and building the Jacobian costs `nx` directional
/// derivatives: at 1000 states a matrix is 8 MB and one communication step of a linear
/// test model already costs seconds (docs/model-exchange.md), at 30 000 a matrix would be
/// 7.2 GB. Past this the master refuses the FMU rather than integrate it densely (it has
/// no sparse or matrix-free method).
pub const MAX_CONTINUOUS_STATES: usize = 1000;

/// The most event indicators of a Model Exchange component: the root finding keeps a few
/// vectors of this length and reads them all at every integrator step (linear, not
/// squared, in the count), so the cap is far above the states' (800 kB a vector). FMI 2.0
/// gives the count as a bare number (`numberOfEventIndicators`), not backed by anything
/// in the file.
pub const MAX_EVENT_INDICATORS: usize = 100_000;

/// The most variables (scalars and FMI 3.0 array elements) of any component's FMU: the
/// master keeps a few values per variable it connects or records (a single FMU records
/// every output by default), so this bounds each row it writes (8 MB of values).
pub const MAX_VARIABLES: usize = 1_000_000;

/// A closed range a number must lie in, finite, and what the number is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    /// What the number is, for the messages: "the relative tolerance".
    pub what: &'static str,
    pub min: f64,
    pub max: f64,
}

impl Range {
    /// Whether `v` is finite and in `[min, max]`.
    pub fn contains(&self, v: f64) -> bool {
        v.is_finite() && self.min <= v && v <= self.max
    }

    /// `v`, or [`Error::OutOfRange`] naming `given`: who gave it (a command-line option,
    /// a field of the caller's options).
    pub fn check(&self, given: &str, v: f64) -> Result<f64, Error> {
        if self.contains(v) {
            Ok(v)
        } else {
            Err(Error::OutOfRange { given: given.to_owned(), value: v, range: *self })
        }
    }
}

/// "a finite number in [1e-14, 0.5]"
impl std::fmt::Display for Range {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "a finite number in [{}, {}]", Number(self.min), Number(self.max))
    }
}

/// A number for a message: in exponent form when very small or large (`1e-13`, not
/// `0.0000000000001`), `inf` and `NaN` as such.
#[derive(Clone, Copy, Debug)]
pub struct Number(pub f64);

impl std::fmt::Display for Number {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let a = self.0.abs();
        if a.is_finite() && a != 0.0 && !(1e-3..1e6).contains(&a) {
            write!(f, "{:e}", self.0)
        } else {
            write!(f, "{}", self.0)
        }
    }
}

/// The integrator's relative tolerance. Below 1e-14 (about 45 ulp of a state) the error
/// test asks for what f64 cannot resolve and the steps shrink toward zero; above 0.5 the
/// error test accepts any step.
pub const RTOL: Range = Range { what: "the relative tolerance", min: 1e-14, max: 0.5 };

/// The integrator's absolute tolerance, a multiple of each state's nominal. With a nominal
/// in [`NOMINAL`], the tolerance of a state stays a normal positive f64 (at least 1e-130);
/// above 0.5 of a nominal the error test accepts any step.
pub const ATOL: Range = Range { what: "the absolute tolerance", min: 1e-30, max: 0.5 };

/// A state's nominal, as `fmi*GetNominalsOfContinuousStates` returns it (both standards
/// say it is > 0).
pub const NOMINAL: Range = Range { what: "a state's nominal", min: 1e-100, max: 1e100 };

/// A communication step of a Model Exchange component, in seconds. Below a nanosecond per
/// step nothing a master's exchange resolves is left; the stop time's own checks bound
/// the other end.
pub const STEP: Range = Range { what: "the communication step", min: 1e-9, max: 1e9 };

/// A time the master hands an FMU or takes from it (a next time event), in seconds.
pub const TIME: Range = Range { what: "a time", min: -1e12, max: 1e12 };

/// What a description asks the master to allocate, against the caps: `component` is the
/// component's name, `model_exchange` whether it is to be integrated as Model Exchange
/// (only then do its states and event indicators count).
pub fn check_description(
    component: &str,
    description: &ModelDescription,
    model_exchange: bool,
) -> Result<(), Error> {
    let too_many = |what: &'static str, count: usize, limit: usize| {
        Err(Error::TooLarge {
            component: component.to_owned(),
            what,
            count: count as u64,
            limit: limit as u64,
        })
    };
    let variables = description.variables.len();
    if variables > MAX_VARIABLES {
        return too_many("variables", variables, MAX_VARIABLES);
    }
    let me = match &description.model_exchange {
        Some(me) if model_exchange => me,
        _ => return Ok(()),
    };
    if me.states.len() > MAX_CONTINUOUS_STATES {
        return too_many("continuous states", me.states.len(), MAX_CONTINUOUS_STATES);
    }
    if me.number_of_event_indicators > MAX_EVENT_INDICATORS {
        return too_many("event indicators", me.number_of_event_indicators, MAX_EVENT_INDICATORS);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_take_finite_numbers_inside_only() {
        assert!(RTOL.contains(1e-9) && RTOL.contains(1e-14) && RTOL.contains(0.5));
        for v in [f64::NAN, f64::INFINITY, -1e-9, 0.0, 1e-15, 0.6] {
            assert!(!RTOL.contains(v), "{v}");
        }
        assert!(!ATOL.contains(5e-324));
        let e = RTOL.check("--me-rtol", f64::INFINITY).unwrap_err().to_string();
        assert_eq!(
            e,
            "--me-rtol = inf: the relative tolerance must be a finite number in [1e-14, 0.5]"
        );
    }

    #[test]
    fn the_smallest_tolerance_is_a_normal_number() {
        assert!((ATOL.min * NOMINAL.min).is_normal());
        assert!((ATOL.max * NOMINAL.max).is_finite());
    }
}
