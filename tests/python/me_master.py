"""A small Model Exchange master over FMPy: FMPy's own FMU classes and its CVode solver
(`fmpy.sundials.CVodeSolver`, constructed as `fmpy.simulation.simulateME` constructs it),
driving InchwormPlant as Model Exchange with the DAC volts held over 2 ms samples, either
from a schedule (the check trace) or from InchwormController as Model Exchange (its time
events at every 2 ms instant). At each instant both FMUs are in event mode together: the
plant's update samples its encoder, the controller latches it and writes its sample, and
the plant takes the new volts in a second update of the same event iteration. Between
instants CVode integrates the plant and stops at its state events.

It also counts what the acceptance asks for: events and CVode's internal steps (read from
CVode itself before each re-initialization)."""
from ctypes import POINTER, byref, c_long, c_void_p

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Model
from fmpy.fmi3 import FMU3Model
from fmpy.sundials import CVodeSolver
from fmpy.sundials.libraries import sundials_cvode

from conftest import DIST
from inchworm_variables import InchwormController as Controller, InchwormPlant as Plant

T = 0.002
DAC = [Plant.DAC_EARTH, Plant.DAC_NONEARTH, Plant.DAC_EXTENSION]

_num_steps = sundials_cvode.CVodeGetNumSteps
_num_steps.argtypes = [c_void_p, POINTER(c_long)]


class NoInput:
    """The inputs are set by the master at the instants, never by the solver."""

    def apply(self, *args, **kwargs):
        pass


class Me:
    """One FMU as Model Exchange: FMI 2.0 or 3.0 through one set of method names."""

    def __init__(self, path, name, start_values=None, booleans=None):
        md = read_model_description(path)
        self.fmi3 = md.fmiVersion.startswith("3")
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.nx = md.numberOfContinuousStates
        self.nz = md.numberOfEventIndicators
        cls = FMU3Model if self.fmi3 else FMU2Model
        # FMPy passes FMI 3.0's instantiation token under the name `guid` as well.
        self.fmu = cls(unzipDirectory=extract(path), modelIdentifier=md.modelExchange.modelIdentifier,
                       instanceName=name, guid=md.guid)
        self.fmu.instantiate()
        if self.fmi3:
            self.fmu.enterInitializationMode(startTime=0.0)
        else:
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
        for k, v in (start_values or {}).items():
            self.set_real([k], [v])
        for k, v in (booleans or {}).items():
            self.fmu.setBoolean([self.vr[k]], [v])
        self.fmu.exitInitializationMode()
        self.update()

    def set_real(self, names, values):
        setter = self.fmu.setFloat64 if self.fmi3 else self.fmu.setReal
        setter([self.vr[n] for n in names], list(values))

    def real(self, names):
        getter = self.fmu.getFloat64 if self.fmi3 else self.fmu.getReal
        return getter([self.vr[n] for n in names])

    def integer(self, name):
        getter = self.fmu.getInt32 if self.fmi3 else self.fmu.getInteger
        return getter([self.vr[name]])[0]

    def set_integer(self, name, value):
        setter = self.fmu.setInt32 if self.fmi3 else self.fmu.setInteger
        setter([self.vr[name]], [value])

    def update(self):
        """The event iteration: updates until the FMU needs none; its next time event."""
        step = self.fmu.updateDiscreteStates if self.fmi3 else self.fmu.newDiscreteStates
        while True:
            need, terminate, _, _, defined, next_time = step()
            assert not terminate, "the FMU asked to terminate"
            if not need:
                return next_time if defined else None

    def derivatives(self):
        return self.fmu.getContinuousStateDerivatives if self.fmi3 else self.fmu.getDerivatives

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


class Counted(CVodeSolver):
    """FMPy's CVode solver, counting its internal steps across re-initializations."""

    steps = 0

    def _nst(self):
        n = c_long(0)
        _num_steps(self.cvode_mem, byref(n))
        return n.value

    def reset(self, time):
        self.steps += self._nst()
        super().reset(time)

    def total_steps(self):
        return self.steps + self._nst()


def run(plant_path, samples, rtol=None, schedule=None, controller_path=None, reference=100e-6,
        controller_start=None, controller_bools=None, substeps=4, plant_start=None):
    """Runs `samples` instants of 2 ms. The DAC volts come from `schedule[k]` (a triple) or
    from the controller at `controller_path` (with `reference`). Returns rows
    `(t_k, encoder_counts, runner_position, mode, dac held during [t_(k-1), t_k))` for
    k = 1..samples and the counts `{"events", "state_events", "steps"}`."""
    plant = Me(plant_path, "plant", plant_start)
    # The reference is there at the first latch (t = 0), as before a first step in CS.
    ctrl_start = {Controller.REFERENCE: reference, **(controller_start or {})}
    ctrl = Me(controller_path, "controller", ctrl_start, controller_bools) if controller_path else None
    stop = samples * T
    solver = Counted(
        nx=plant.nx, nz=plant.nz,
        get_x=plant.fmu.getContinuousStates, set_x=plant.fmu.setContinuousStates,
        get_dx=plant.derivatives(), get_z=plant.fmu.getEventIndicators, input=NoInput(),
        get_nominals=plant.fmu.getNominalsOfContinuousStates, set_time=plant.fmu.setTime,
        startTime=0.0, maxStep=stop / 50.0,
        relativeTolerance=rtol if rtol is not None else 1e-9)
    rows, held = [], [0.0, 0.0, 0.0]
    events = state_events = 0
    for k in range(samples + 1):
        t = k * T
        if k > 0:
            plant.fmu.enterEventMode()
            if ctrl:
                ctrl.fmu.setTime(t)
                ctrl.fmu.enterEventMode()
            plant.update()
            events += 1
            rows.append((t, plant.integer(Plant.ENCODER_COUNTS), plant.real([Plant.RUNNER_POSITION])[0],
                         plant.integer(Plant.MODE), tuple(held)))
            if k == samples:
                break
        if ctrl:
            ctrl.set_integer(Plant.ENCODER_COUNTS, plant.integer(Plant.ENCODER_COUNTS))
            ctrl.set_real([Controller.REFERENCE], [reference])
            next_time = ctrl.update()
            assert next_time is not None and abs(next_time - (t + T)) < 1e-12, next_time
            held = ctrl.real(DAC)
        else:
            held = list(schedule[k])
        plant.set_real(DAC, held)
        plant.update()
        plant.fmu.enterContinuousTimeMode()
        if ctrl:
            ctrl.fmu.enterContinuousTimeMode()
        solver.reset(t)
        now = t
        for j in range(1, substeps + 1):
            target = t + T * j / substeps
            while True:
                state_event, _, now = solver.step(now, target)
                plant.fmu.setTime(now)
                if not state_event:
                    break
                plant.fmu.enterEventMode()
                plant.update()
                plant.fmu.enterContinuousTimeMode()
                solver.reset(now)
                state_events += 1
                events += 1
    counts = {"events": events, "state_events": state_events, "steps": solver.total_steps()}
    plant.close()
    if ctrl:
        ctrl.close()
    return rows, counts
