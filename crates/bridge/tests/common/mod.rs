//! The plain-Rust plant and controller behind the bridge's traits, a virtual board on a
//! loopback socket in a thread, and the co-simulation the lock-step runs must equal.
#![allow(dead_code)]

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::thread::JoinHandle;

use inchworm_bridge::board::{run_board, Board, BoardConfig};
use inchworm_bridge::faults::{FaultPlan, FaultyTransport};
use inchworm_bridge::transport::{Transport, UdpTransport};
use inchworm_bridge::{Compensator, Mechanism, ModelError, Schedule};
use inchworm_controller::{volts_of_code, Controller, Params};
use inchworm_plant::{Dac, Plant, PlantParams};

pub const H: f64 = 0.002;

/// Every bridge test runs against the wall clock (real-time periods, or the board's
/// watchdog in lock-step) and takes this, so two of them never compete for the machine's
/// cores and miss deadlines the bridge would meet on its own. It also puts the test's
/// thread under SCHED_FIFO, as `inchworm bridge` puts itself: the board and controller
/// threads the test starts, and the processes it spawns, inherit it, so other work on
/// the machine (a CPU-bound process on every core) cannot stall them past a watchdog.
/// Without the privilege the test runs under the default scheduler, as the bridge does.
pub fn real_time_slot() -> RealTimeSlot {
    static SLOT: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let lock = SLOT.lock().unwrap_or_else(|e| e.into_inner());
    RealTimeSlot { _lock: lock, before: inchworm_bridge::realtime::fifo_thread(50).ok() }
}

pub struct RealTimeSlot {
    _lock: std::sync::MutexGuard<'static, ()>,
    before: Option<(i32, i32)>,
}

impl Drop for RealTimeSlot {
    fn drop(&mut self) {
        if let Some(b) = self.before {
            inchworm_bridge::realtime::restore_scheduling(b);
        }
    }
}

pub struct DirectPlant(pub Plant);

impl DirectPlant {
    pub fn new() -> DirectPlant {
        DirectPlant(Plant::new(PlantParams::default()).unwrap())
    }
}

impl Mechanism for DirectPlant {
    fn counts(&mut self) -> Result<i32, ModelError> {
        Ok(self.0.outputs().encoder_counts as i32)
    }
    fn step(&mut self, codes: [u16; 3]) -> Result<i32, ModelError> {
        self.0
            .step(
                Dac {
                    earth: volts_of_code(codes[0]),
                    nonearth: volts_of_code(codes[1]),
                    extension: volts_of_code(codes[2]),
                },
                H,
            )
            .map_err(|e| e.to_string())?;
        self.counts()
    }
    fn reinitialise(&mut self) -> Result<(), ModelError> {
        self.0 = Plant::new(PlantParams::default()).map_err(|e| e.to_string())?;
        Ok(())
    }
}

pub struct DirectController {
    pub ctrl: Controller,
    pub codes: [u16; 3],
}

impl DirectController {
    pub fn new() -> DirectController {
        DirectController { ctrl: Controller::new(Params::default()).unwrap(), codes: [0; 3] }
    }
}

impl Compensator for DirectController {
    fn codes(&mut self) -> Result<[u16; 3], ModelError> {
        Ok(self.codes)
    }
    fn step(&mut self, counts: i32, reference: f64) -> Result<(), ModelError> {
        self.codes = self.ctrl.tick(i64::from(counts), reference).codes;
        Ok(())
    }
}

/// The controller as Scheduled Execution runs it ([`Schedule::AtTick`]): each step
/// writes the sample of the interval that starts now, computed from the count latched at
/// the previous tick, then latches this tick's; before the first write the codes are the
/// parked zeros. The output clock `gait_step` ticks at the writes that ended a gait step.
pub struct ScheduledController {
    pub ctrl: Controller,
    latched: Option<(i32, f64)>,
    codes: [u16; 3],
    gait_step: bool,
}

impl ScheduledController {
    pub fn new() -> ScheduledController {
        ScheduledController {
            ctrl: Controller::new(Params::default()).unwrap(),
            latched: None,
            codes: [0; 3],
            gait_step: false,
        }
    }
}

impl Compensator for ScheduledController {
    fn schedule(&self) -> Schedule {
        Schedule::AtTick
    }
    fn codes(&mut self) -> Result<[u16; 3], ModelError> {
        Ok(self.codes)
    }
    fn step(&mut self, counts: i32, reference: f64) -> Result<(), ModelError> {
        self.gait_step = false;
        if let Some((c, r)) = self.latched.replace((counts, reference)) {
            self.codes = self.ctrl.tick(i64::from(c), r).codes;
            self.gait_step = self.ctrl.estimated();
        }
        Ok(())
    }
    fn ticked_clock(&mut self) -> Result<Option<&str>, ModelError> {
        Ok(self.gait_step.then_some("gait_step"))
    }
}

/// [`DirectController`] that says (once) when it reaches tick `at`: an event a test can
/// wait on instead of guessing how long start-up takes (its first tick comes after its
/// ARM was answered).
pub struct Announcing {
    pub ctrl: DirectController,
    pub at: u64,
    ticks: u64,
    tell: Option<mpsc::Sender<()>>,
}

impl Announcing {
    pub fn new(at: u64) -> (Announcing, mpsc::Receiver<()>) {
        let (tx, rx) = mpsc::channel();
        (Announcing { ctrl: DirectController::new(), at, ticks: 0, tell: Some(tx) }, rx)
    }
}

impl Compensator for Announcing {
    fn codes(&mut self) -> Result<[u16; 3], ModelError> {
        self.ctrl.codes()
    }
    fn step(&mut self, counts: i32, reference: f64) -> Result<(), ModelError> {
        if self.ticks == self.at {
            if let Some(t) = self.tell.take() {
                let _ = t.send(());
            }
        }
        self.ticks += 1;
        self.ctrl.step(counts, reference)
    }
}

/// A step to 30 µm at 0.1 s, then back to 10 µm at 1 s: moves, settles, parks.
pub fn reference(t: f64) -> f64 {
    if t < 0.1 {
        0.0
    } else if t < 1.0 {
        30e-6
    } else {
        10e-6
    }
}

/// The co-simulation (Jacobi, 2 ms) of the same plant and controller: the encoder count
/// at the end of each interval.
pub fn cosimulation(ticks: usize) -> Vec<i32> {
    let mut plant = DirectPlant::new();
    let mut ctrl = DirectController::new();
    let mut counts = plant.counts().unwrap();
    let mut out = Vec::with_capacity(ticks);
    for k in 0..ticks {
        let codes = ctrl.codes().unwrap();
        ctrl.step(counts, reference(k as f64 * H)).unwrap();
        counts = plant.step(codes).unwrap();
        out.push(counts);
    }
    out
}

pub struct BoardThread {
    pub addr: SocketAddr,
    pub stop: Arc<AtomicBool>,
    pub handle: JoinHandle<(Board<DirectPlant>, Vec<f64>)>,
}

impl BoardThread {
    pub fn finish(self) -> (Board<DirectPlant>, Vec<f64>) {
        self.stop.store(true, Ordering::Relaxed);
        self.handle.join().expect("board thread")
    }
}

/// A virtual board on 127.0.0.1, its replies passed through `faults` when given.
pub fn spawn_board(cfg: BoardConfig, faults: Option<FaultPlan>) -> BoardThread {
    let stop = Arc::new(AtomicBool::new(false));
    let (tx, rx) = mpsc::channel();
    let s = Arc::clone(&stop);
    let handle = std::thread::spawn(move || {
        let udp = UdpTransport::bind("127.0.0.1:0").unwrap();
        tx.send(udp.local_addr().unwrap()).unwrap();
        let mut transport: Box<dyn Transport> = match faults {
            Some(plan) => Box::new(FaultyTransport::new(udp, plan)),
            None => Box::new(udp),
        };
        let mut board = Board::new(DirectPlant::new(), cfg, None).unwrap();
        let mut lateness = Vec::new();
        run_board(&mut board, &mut transport, &s, &mut lateness).expect("board loop");
        (board, lateness)
    });
    BoardThread { addr: rx.recv().unwrap(), stop, handle }
}
