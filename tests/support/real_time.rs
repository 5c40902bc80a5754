//! The bridge tests' turn at the machine, under SCHED_FIFO when permitted
//! (tests/bridge_fmu.rs and tests/bridge_se.rs include this file with `#[path]`).
#![allow(dead_code)]

/// SCHED_FIFO for the test's thread while it lives, so the board thread and the processes
/// it starts inherit it and other work on the machine (a CPU-bound process on every core)
/// cannot stall them past a watchdog, as `inchworm bridge` does for itself in real time.
/// Without the privilege the test runs under the default scheduler.
/// One test of a file at a time: the harness runs tests on parallel threads, and the
/// bridge processes of one test (real-time ones, under SCHED_FIFO, and those it spawns)
/// took the two cores from another test's board for seconds, so that board missed a
/// controller's whole handshake ("no HELLO answer from the board within 5.0 s", seen in
/// about one run in three with every test of the file at once; none in serial runs).
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// This test's turn at the machine (see [`SERIAL`]); a test that failed while holding it
/// leaves nothing shared behind.
pub fn turn() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

pub struct RealTime(Option<(i32, i32)>, #[allow(dead_code)] std::sync::MutexGuard<'static, ()>);

impl RealTime {
    pub fn enter() -> RealTime {
        let turn = turn();
        RealTime(inchworm_bridge::realtime::fifo_thread(50).ok(), turn)
    }
}

impl Drop for RealTime {
    fn drop(&mut self) {
        if let Some(b) = self.0 {
            inchworm_bridge::realtime::restore_scheduling(b);
        }
    }
}
