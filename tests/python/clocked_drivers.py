"""Low-level FMPy drivers of the FMI 3.0 controller (dist/fmi3/InchwormController.fmu) in
its three ways: plain Co-Simulation (2 ms steps), Co-Simulation with event mode
(`fmi3SetClock` of `sample_clock` at each tick) and Scheduled Execution
(`fmi3ActivateModelPartition` every 2 ms), each fed the same encoder sequence. They are the
Python counterparts of crates/controller-fmu3/tests/clocks.rs (docs/fmi-export.md, "The
clocked controller in FMPy and fmusim")."""
import os
from dataclasses import dataclass, field

from fmpy import extract, read_model_description
from fmpy.fmi3 import (FMU3ScheduledExecution, FMU3Slave, fmi3Boolean, fmi3ClockUpdateCallback,
                       fmi3InstanceEnvironment, fmi3LockPreemptionCallback, fmi3LogMessageCallback,
                       fmi3UnlockPreemptionCallback)
from inchworm_variables import InchwormController as ControllerVars, InchwormPlant as Plant

# The controller's sample period (the interval of `sample_clock`), the run's samples and the
# reference its tests set (crates/controller-fmu3/tests/clocks.rs).
H = 0.002
SAMPLES = 500
REFERENCE = 30e-6
STOP_TIME = SAMPLES * H
CODES = [ControllerVars.DAC_EARTH_CODE, ControllerVars.DAC_NONEARTH_CODE, ControllerVars.DAC_EXTENSION_CODE]
# The estimates `gait_step` clocks: the disturbance and the first scale-factor weight.
ESTIMATES = [ControllerVars.DISTURBANCE_ESTIMATE, "scale_weights"]


@dataclass
class Run:
    """What a run records at each instant k = 0 ... 500: the three DAC codes, the
    disturbance estimate and first weight, and (clocked runs) whether `gait_step` ticked."""
    codes: list = field(default_factory=list)
    estimates: list = field(default_factory=list)
    gait: list = field(default_factory=list)


class Log:
    """The FMU's log lines as (status, category, message), through FMPy's callback type."""

    def __init__(self):
        self.lines = []
        self.callback = fmi3LogMessageCallback(self._log)

    def _log(self, _env, status, category, message):
        self.lines.append((status, category.decode(), message.decode()))

    def errors(self):
        return [m for s, _, m in self.lines if s >= 3]


class Controller:
    """The unpacked FMU and its value references by name."""

    def __init__(self, path):
        self.md = read_model_description(path)
        self.unzipdir = extract(path)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.codes = [self.vr[n] for n in CODES]
        self.estimates = [self.vr[n] for n in ESTIMATES]

    def args(self, interface, name):
        return dict(guid=self.md.guid, unzipDirectory=self.unzipdir, instanceName=name,
                    modelIdentifier=interface.modelIdentifier)

    def slave(self, name, log, event_mode, early_return=False):
        """A Co-Simulation instance, instantiated (not initialized)."""
        fmu = FMU3Slave(**self.args(self.md.coSimulation, name))
        fmu.instantiate(eventModeUsed=event_mode, earlyReturnAllowed=early_return, logMessage=log.callback)
        return fmu

    def initialize(self, fmu):
        """Initialized at t = 0 to stop at 1 s, with the reference set."""
        fmu.enterInitializationMode(startTime=0.0, stopTime=STOP_TIME)
        fmu.setFloat64([self.vr[ControllerVars.REFERENCE]], [REFERENCE])
        fmu.exitInitializationMode()

    def record(self, fmu, run):
        run.codes.append(tuple(fmu.getInt32(self.codes)))
        # getFloat64 reads an array's values: scale_weights gives ten, its first is kept.
        values = fmu.getFloat64(self.estimates, nValues=11)
        run.estimates.append((values[0], values[1]))

    def gait_step(self, fmu):
        return fmu.getClock([self.vr[ControllerVars.GAIT_STEP]])[0]


def plain(ctrl, encoder, log):
    """Plain Co-Simulation: the step from instant k writes the sample of instant k + 1, so
    instant 0 holds the parked outputs (read before the first step)."""
    fmu = ctrl.slave("plain", log, event_mode=False)
    ctrl.initialize(fmu)
    run = Run()
    ctrl.record(fmu, run)
    for k, counts in enumerate(encoder[:SAMPLES]):
        fmu.setInt32([ctrl.vr[Plant.ENCODER_COUNTS]], [counts])
        event, terminate, early, _ = fmu.doStep(k * H, H)
        assert (event, terminate, early) == (False, False, False), f"step {k}"
        ctrl.record(fmu, run)
    fmu.terminate()
    fmu.freeInstance()
    return run


def event_mode(ctrl, encoder, log):
    """Co-Simulation with event mode: fmi3ExitInitializationMode leaves the instance in the
    event at t = 0 (a tick); at each tick the importer activates `sample_clock`, sets the
    encoder, updates, reads the DAC codes and `gait_step`, enters step mode and steps to the
    next tick, where the step ends with eventHandlingNeeded."""
    fmu = ctrl.slave("events", log, event_mode=True)
    ctrl.initialize(fmu)
    sample, run = ctrl.vr[ControllerVars.SAMPLE_CLOCK], Run()
    for k, counts in enumerate(encoder):
        t = k * H
        fmu.setClock([sample], [True])
        fmu.setInt32([ctrl.vr[Plant.ENCODER_COUNTS]], [counts])
        need_update, terminate, _, _, next_defined, next_time = fmu.updateDiscreteStates()
        assert (need_update, terminate, next_defined) == (False, False, True), f"update at tick {k}"
        assert abs(next_time - (t + H)) < 1e-12, f"the next tick after {t}"
        ctrl.record(fmu, run)
        run.gait.append(ctrl.gait_step(fmu))
        if k == SAMPLES:
            break
        fmu.enterStepMode()
        event, terminate, early, last = fmu.doStep(t, H)
        assert (event, terminate, early) == (True, False, False), f"step {k} ends at a tick"
        assert last == t + H
        fmu.enterEventMode()
    fmu.terminate()
    fmu.freeInstance()
    return run


class Scheduler(FMU3ScheduledExecution):
    """FMPy's Scheduled Execution instance with the importer's own callbacks: FMPy 0.3.32's
    `FMU3ScheduledExecution.instantiate` passes no-ops for clockUpdate, lockPreemption and
    unlockPreemption, so this instantiates through the same `fmi3InstantiateScheduledExecution`
    with callables of the scheduler."""

    def instantiate_with(self, log, clock_update, lock, unlock):
        # Kept on the instance so the ctypes callbacks outlive the call.
        self.logMessage = log.callback
        self.clockUpdate = fmi3ClockUpdateCallback(lambda _env: clock_update())
        self.lockPreemption = fmi3LockPreemptionCallback(lock)
        self.unlockPreemption = fmi3UnlockPreemptionCallback(unlock)
        resources = os.path.join(self.unzipDirectory, "resources") + os.path.sep
        self.component = self.fmi3InstantiateScheduledExecution(
            self.instanceName.encode(), self.guid.encode(), resources.encode(),
            fmi3Boolean(False), fmi3Boolean(False), fmi3InstanceEnvironment(),
            self.logMessage, self.clockUpdate, self.lockPreemption, self.unlockPreemption)
        if not self.component:
            raise RuntimeError(f"fmi3InstantiateScheduledExecution refused: {log.errors()}")


@dataclass
class Schedule:
    """What the scheduler saw: the instants at which `clockUpdate` was called, what
    `fmi3GetClock(gait_step)` read inside the callback, and the lock and unlock calls in
    order."""
    updates: list = field(default_factory=list)
    read_in_callback: list = field(default_factory=list)
    preemption: list = field(default_factory=list)


def scheduled(ctrl, encoder, log):
    """Scheduled Execution: the scheduler sets the encoder and activates the sample
    partition every 2 ms. When the partition ticks `gait_step` the FMU calls `clockUpdate`
    after it; the callback reads the clock (which deactivates it), so after the activation
    it reads false."""
    fmu = Scheduler(**ctrl.args(ctrl.md.scheduledExecution, "scheduled"))
    schedule, now = Schedule(), [0]

    def clock_update():
        schedule.updates.append(now[0])
        schedule.read_in_callback.append(ctrl.gait_step(fmu))

    fmu.instantiate_with(log, clock_update, lambda: schedule.preemption.append("lock"),
                         lambda: schedule.preemption.append("unlock"))
    ctrl.initialize(fmu)
    sample, run = ctrl.vr[ControllerVars.SAMPLE_CLOCK], Run()
    for k, counts in enumerate(encoder):
        fmu.setInt32([ctrl.vr[Plant.ENCODER_COUNTS]], [counts])
        now[0] = k
        signalled = len(schedule.updates)
        fmu.activateModelPartition(sample, k * H)
        ctrl.record(fmu, run)
        run.gait.append(len(schedule.updates) > signalled)
        assert ctrl.gait_step(fmu) is False, f"gait_step reads false once read, at {k}"
    fmu.terminate()
    fmu.freeInstance()
    return run, schedule
