//! Pacing against absolute deadlines on the monotonic clock, and the real-time set-up of
//! the process. Absolute deadlines (`clock_nanosleep(TIMER_ABSTIME)`) keep the 500 Hz
//! schedule free of drift: a late wake-up shortens the next sleep instead of shifting
//! every later period.

use std::time::Duration;

/// Monotonic time in nanoseconds.
pub fn now_ns() -> u64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: a valid timespec to fill; CLOCK_MONOTONIC always exists on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// Sleeps until the monotonic clock reads `deadline_ns` (returns at once if it has passed).
pub fn sleep_until(deadline_ns: u64) {
    let ts = libc::timespec {
        tv_sec: (deadline_ns / 1_000_000_000) as libc::time_t,
        tv_nsec: (deadline_ns % 1_000_000_000) as libc::c_long,
    };
    // SAFETY: a valid timespec; EINTR simply restarts the same absolute sleep.
    while unsafe {
        libc::clock_nanosleep(libc::CLOCK_MONOTONIC, libc::TIMER_ABSTIME, &ts, std::ptr::null_mut())
    } == libc::EINTR
    {}
}

/// What one wake-up looked like.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Wake {
    /// Index of the period that starts now.
    pub period: u64,
    /// How late the wake-up was against its deadline (ns, ≥ 0).
    pub lateness_ns: u64,
    /// The work of the previous period ran past this deadline.
    pub overrun: bool,
    /// Deadlines skipped because the loop fell more than a whole period behind.
    pub skipped: u64,
}

pub struct Pacer {
    period_ns: u64,
    next: u64,
    period: u64,
}

impl Pacer {
    /// The first deadline is one period from now.
    pub fn new(period: Duration) -> Pacer {
        let period_ns = period.as_nanos().max(1) as u64;
        Pacer { period_ns, next: now_ns() + period_ns, period: 0 }
    }

    pub fn period(&self) -> Duration {
        Duration::from_nanos(self.period_ns)
    }

    /// The deadline the loop is heading for.
    pub fn next_deadline_ns(&self) -> u64 {
        self.next
    }

    /// Waits for the next deadline. A loop that fell behind by more than a period skips
    /// the deadlines it missed (counted) rather than running them back to back, which
    /// would feed the plant a burst of samples.
    pub fn wait(&mut self) -> Wake {
        let before = now_ns();
        let overrun = before > self.next;
        let mut skipped = 0;
        if overrun {
            skipped = (before - self.next) / self.period_ns;
            self.next += skipped * self.period_ns;
        } else {
            sleep_until(self.next);
        }
        let woke = now_ns();
        let wake = Wake {
            period: self.period + skipped,
            lateness_ns: woke.saturating_sub(self.next),
            overrun,
            skipped,
        };
        self.period += skipped + 1;
        self.next += self.period_ns;
        wake
    }
}

/// What the process got of the real-time set-up it asked for.
#[derive(Clone, Debug, Default)]
pub struct RealTimeSetup {
    pub fifo_priority: Option<i32>,
    pub memory_locked: bool,
    /// Why a part was refused, for the operator (the run goes on without it).
    pub warnings: Vec<String>,
}

/// Locks the process's memory (no page faults in the loop) and switches the calling thread
/// to SCHED_FIFO at `priority`. Both need privileges (CAP_SYS_NICE, CAP_IPC_LOCK or the
/// rlimits); without them the bridge still runs, with more jitter, and says so.
pub fn enter_real_time(priority: i32) -> RealTimeSetup {
    let mut setup = RealTimeSetup::default();
    // SAFETY: plain system calls with valid arguments.
    unsafe {
        if libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) == 0 {
            setup.memory_locked = true;
        } else {
            setup.warnings.push(format!(
                "memory not locked (mlockall: {}); page faults may add latency",
                std::io::Error::last_os_error()
            ));
        }
        let param = libc::sched_param { sched_priority: priority };
        if libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) == 0 {
            setup.fifo_priority = Some(priority);
        } else {
            setup.warnings.push(format!(
                "SCHED_FIFO priority {priority} refused (needs CAP_SYS_NICE or an rtprio limit); running under the default scheduler"
            ));
        }
    }
    setup
}

/// The system refused SCHED_FIFO at `priority` ([`fifo_thread`]).
#[derive(Debug, thiserror::Error)]
#[error("SCHED_FIFO priority {priority} refused ({source})")]
pub struct FifoRefused {
    pub priority: i32,
    #[source]
    pub source: std::io::Error,
}

/// Switches the calling thread to SCHED_FIFO at `priority` (threads and processes it
/// starts afterwards inherit it) and gives back the policy and priority it had, for
/// [`restore_scheduling`]. Tests take it so the bridge's deadlines hold on a machine whose
/// cores are busy with other work, as they do for the bridge itself on a rig.
pub fn fifo_thread(priority: i32) -> Result<(i32, i32), FifoRefused> {
    // SAFETY: plain system calls on the calling thread with valid arguments.
    unsafe {
        let mut policy = 0;
        let mut was = libc::sched_param { sched_priority: 0 };
        libc::pthread_getschedparam(libc::pthread_self(), &mut policy, &mut was);
        let param = libc::sched_param { sched_priority: priority };
        match libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) {
            0 => Ok((policy, was.sched_priority)),
            e => Err(FifoRefused { priority, source: std::io::Error::from_raw_os_error(e) }),
        }
    }
}

/// Puts the calling thread back to what [`fifo_thread`] returned.
pub fn restore_scheduling((policy, priority): (i32, i32)) {
    let param = libc::sched_param { sched_priority: priority };
    // SAFETY: the policy and priority this thread had before.
    unsafe { libc::pthread_setschedparam(libc::pthread_self(), policy, &param) };
}

/// Percentiles of a sample set (nearest rank), in the samples' unit.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Percentiles {
    pub count: usize,
    pub p50: f64,
    pub p99: f64,
    pub max: f64,
}

pub fn percentiles(samples: &[f64]) -> Percentiles {
    if samples.is_empty() {
        return Percentiles::default();
    }
    let mut s = samples.to_vec();
    s.sort_by(f64::total_cmp);
    let rank = |p: f64| s[((p * s.len() as f64).ceil() as usize).clamp(1, s.len()) - 1];
    Percentiles { count: s.len(), p50: rank(0.50), p99: rank(0.99), max: s[s.len() - 1] }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_by_nearest_rank() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        let p = percentiles(&v);
        assert_eq!((p.count, p.p50, p.p99, p.max), (100, 50.0, 99.0, 100.0));
        assert_eq!(percentiles(&[]).count, 0);
    }

    #[test]
    fn pacer_keeps_absolute_deadlines_and_counts_skips() {
        let mut pacer = Pacer::new(Duration::from_millis(2));
        let start = pacer.next_deadline_ns();
        let mut skipped = 0;
        for _ in 0..5 {
            // A loaded machine may wake late; the schedule must not move because of it.
            skipped += pacer.wait().skipped;
        }
        assert_eq!(
            pacer.next_deadline_ns(),
            start + (5 + skipped) * 2_000_000,
            "no drift: the schedule is k · period"
        );
        std::thread::sleep(Duration::from_millis(7));
        let w = pacer.wait();
        assert!(w.overrun && w.skipped >= 2, "{w:?}");
        assert_eq!((pacer.next_deadline_ns() - start) % 2_000_000, 0, "skips keep the phase");
    }
}
