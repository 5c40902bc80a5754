//! Feedforward of the reference increment with a one-iteration delay on the feedback path
//! (paper Fig. 4).
//!
//! A reference change `r_k − r_{k−1}` is moved at once; the feedback compares the position
//! with the *previous* reference, `e_k = r_{k−1} − y_k`. When the feedforward move has been
//! made, `y_{k+1} ≈ r_k` and the feedback sees only what the move missed, instead of also
//! integrating the full new error that the same command is already removing.

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Feedforward {
    previous_reference: f64,
}

impl Feedforward {
    /// The first iteration takes the measured position as the previous reference, so a
    /// reference already far away at t = 0 is fed forward, not left to the integrators.
    pub fn start(&mut self, y: f64) {
        self.previous_reference = y;
    }

    /// Splits reference `r` at measured position `y` into (feedback error, move fed
    /// forward). Disabled, the feedback sees `r − y` and nothing is fed forward; the
    /// previous reference is tracked either way, so enabling it later does not jump.
    pub fn split(&mut self, r: f64, y: f64, enabled: bool) -> (f64, f64) {
        let out = if enabled {
            (self.previous_reference - y, r - self.previous_reference)
        } else {
            (r - y, 0.0)
        };
        self.previous_reference = r;
        out
    }

    /// Remembers `r` without a move (deadband hold).
    pub fn hold(&mut self, r: f64) {
        self.previous_reference = r;
    }

    pub fn previous_reference(&self) -> f64 {
        self.previous_reference
    }

    pub(crate) fn with_previous(previous_reference: f64) -> Feedforward {
        Feedforward { previous_reference }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn increment_now_error_against_the_previous_reference() {
        let mut ff = Feedforward::default();
        ff.start(2.0);
        assert_eq!(ff.split(10.0, 2.0, true), (0.0, 8.0));
        // The move landed at 9.5: the feedback sees the 0.5 it missed, nothing new is fed.
        assert_eq!(ff.split(10.0, 9.5, true), (0.5, 0.0));
        // Reference steps to 15 while at 10: 5 fed forward, feedback still on the old 10.
        assert_eq!(ff.split(15.0, 10.0, true), (0.0, 5.0));
        assert_eq!(ff.split(20.0, 15.0, false), (5.0, 0.0));
        assert_eq!(ff.previous_reference(), 20.0);
    }
}
