"""The clocked FMI 3.0 controller (dist/fmi3/InchwormController.fmu) in FMPy and fmusim
(docs/fmi-export.md, "The clocked controller in FMPy and fmusim"): FMPy's low-level API
driving its clocks in Co-Simulation with event mode and in Scheduled Execution gives the
plain Co-Simulation DAC codes at all 500 samples of the check trace's encoder input;
importers that enter event mode but activate no clock (FMPy's `simulate_fmu(...,
use_event_mode=True)`, fmusim's `--event-mode-used`) get the same codes, the FMU running
each tick itself when the event is left, with one warning saying so; the description
passes FMPy's validation, its clocked-variable rules included."""
import copy
import zipfile
from xml.etree import ElementTree

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu, validate_model_description

import clocked_drivers as drv
from conftest import DIST
from inchworm_variables import InchwormController as Controller, InchwormPlant as Plant

FMU = DIST / "fmi3" / "InchwormController.fmu"
# What the FMU logs, once, when an importer leaves the event at a tick without activating
# the clock (crates/fmi-export/src/entry/clocks.rs, `run_unhandled_ticks`).
NOT_ACTIVATED = ("fmi3EnterStepMode: sample_clock ticks at 0 s and the importer did not activate it "
                 "(fmi3SetClock, then fmi3UpdateDiscreteStates, before leaving the event: FMI 3.0 "
                 "section 2.2.8.2); the FMU runs the tick itself")


def warnings(log):
    return [m for s, _, m in log.lines if s == 1]
# The outputs gait_step clocks; every other output is clocked by sample_clock.
GAIT_CLOCKED = {Controller.DISTURBANCE_ESTIMATE, "scale_weights"}


@pytest.fixture(scope="module")
def controller():
    if not FMU.exists():
        pytest.fail(f"{FMU} is missing: run `cargo run --release -p fmu-build` first")
    return drv.Controller(str(FMU))


@pytest.fixture(scope="module")
def encoder(reference_rows):
    """The encoder the controller reads at instant k: the plant's after step k - 1 of the
    check trace (tests/data/plant-check-trace-fia20-passive.csv), 0 at instant 0."""
    after = [int(r["encoder_counts_after"]) for r in reference_rows]
    assert len(after) == drv.SAMPLES
    return [0] + after


@pytest.fixture(scope="module")
def plain_run(controller, encoder):
    log = drv.Log()
    run = drv.plain(controller, encoder, log)
    assert log.errors() == []
    assert len(run.codes) == drv.SAMPLES + 1
    assert len(set(run.codes)) > 10, "the gait ran"
    return run


def estimate_changes(run):
    """The instants at which the estimates gait_step clocks changed."""
    return [k for k in range(1, len(run.estimates)) if run.estimates[k] != run.estimates[k - 1]]


def test_event_mode_driver_gives_the_plain_dac_codes(controller, encoder, plain_run):
    log = drv.Log()
    run = drv.event_mode(controller, encoder, log)
    assert log.errors() == []
    for k in range(drv.SAMPLES + 1):
        assert run.codes[k] == plain_run.codes[k], f"sample {k}"
        assert run.estimates[k] == plain_run.estimates[k], f"estimates at {k}"
    ticks = [k for k, ticked in enumerate(run.gait) if ticked]
    assert ticks == estimate_changes(plain_run) == [101, 201, 301, 401]


def test_scheduled_execution_driver_gives_the_plain_dac_codes(controller, encoder, plain_run):
    log = drv.Log()
    run, schedule = drv.scheduled(controller, encoder, log)
    assert log.errors() == []
    for k in range(drv.SAMPLES + 1):
        assert run.codes[k] == plain_run.codes[k], f"sample {k}"
        assert run.estimates[k] == plain_run.estimates[k], f"estimates at {k}"
    # clockUpdate is called exactly at the gait-step ends, where plain Co-Simulation's
    # estimates change, and fmi3GetClock from inside the callback reads the tick.
    assert schedule.updates == estimate_changes(plain_run) == [101, 201, 301, 401]
    assert [k for k, ticked in enumerate(run.gait) if ticked] == schedule.updates
    assert schedule.read_in_callback == [True] * 4
    # Each of the 501 partitions ran with preemption locked.
    assert schedule.preemption == ["lock", "unlock"] * (drv.SAMPLES + 1)


def test_simulate_fmu_with_event_mode_gives_the_plain_codes_with_one_warning(encoder, plain_run):
    """FMPy 0.3.32's `simulateCS` (fmpy/simulation.py) with use_event_mode: after
    fmi3ExitInitializationMode it calls fmi3UpdateDiscreteStates until no update is needed
    and fmi3EnterStepMode; at each step that ends with eventHandlingNeeded it calls
    fmi3EnterEventMode, applies its inputs, fmi3UpdateDiscreteStates, fmi3EnterStepMode. It
    never calls fmi3SetClock: the FMU runs each tick at fmi3EnterStepMode with the inputs
    the event was given, so the DAC codes after each event are plain Co-Simulation's at all
    501 instants, and the first tick is logged as a warning, the only message."""
    log = drv.Log()
    signals = np.array([(k * drv.H, counts) for k, counts in enumerate(encoder)],
                       dtype=[("time", np.float64), (Plant.ENCODER_COUNTS, np.int32)])
    result = simulate_fmu(str(FMU), use_event_mode=True, input=signals, output=drv.CODES,
                          stop_time=drv.STOP_TIME, output_interval=drv.H, logger=log.callback,
                          start_values={Controller.REFERENCE: drv.REFERENCE})
    # FMPy records each event's time twice, before and after it: the later row is kept.
    after = {}
    for t, *codes in zip(result["time"], *(result[n] for n in drv.CODES)):
        after[round(t / drv.H)] = tuple(int(c) for c in codes)
    assert sorted(after) == list(range(drv.SAMPLES + 1))
    assert [after[k] for k in range(drv.SAMPLES + 1)] == plain_run.codes
    assert log.errors() == []
    [warning] = warnings(log)
    assert warning.startswith(f"InchwormController: {NOT_ACTIVATED}"), warning


def test_fmusim_event_mode_loop_runs_every_sample(controller):
    """fmusim 0.8.0's `--event-mode-used`: fmusim/src/simulate/fmi3.rs hands the run to
    fmi-rs's `sim::fmi3::cs::simulate` (fmi-rs/src/sim/fmi3/cs.rs at the submodule's
    commit d94fd12), reproduced here call for call: fmi3InstantiateCoSimulation with
    eventModeUsed, fmi3EnterInitializationMode (no stop time without --set-stop-time),
    fmi3ExitInitializationMode, fmi3UpdateDiscreteStates until discreteStatesNeedUpdate is
    false (an error if nextEventTime <= time), fmi3EnterStepMode; then fmi3DoStep and, at
    eventHandlingNeeded, fmi3EnterEventMode, fmi3UpdateDiscreteStates, fmi3EnterStepMode;
    no inputs (fmusim without an input file), no fmi3SetClock, and any status above OK
    ends the run (its `call(...)?`). Every call returns OK; the DAC codes at each of the
    501 samples are those of plain Co-Simulation with the encoder at its start value 0,
    and the first tick is logged as a warning."""
    log = drv.Log()
    fmu = controller.slave("fmusim", log, event_mode=True, early_return=False)
    fmu.enterInitializationMode(startTime=0.0)
    fmu.setFloat64([controller.vr[Controller.REFERENCE]], [drv.REFERENCE])
    fmu.exitInitializationMode()

    def settle(time):
        while True:
            need_update, terminate, _, _, next_defined, next_time = fmu.updateDiscreteStates()
            assert not (next_defined and next_time <= time), "fmusim: NextEventTime error"
            assert not terminate
            if not need_update:
                return next_defined, next_time

    assert settle(0.0) == (True, drv.H)
    fmu.enterStepMode()
    run = drv.Run()
    controller.record(fmu, run)
    for k in range(drv.SAMPLES):
        event, terminate, early, last = fmu.doStep(k * drv.H, drv.H)
        assert (event, terminate, early) == (True, False, False), f"step {k}"
        fmu.enterEventMode()
        settle(last)
        fmu.enterStepMode()
        controller.record(fmu, run)
    fmu.terminate()
    fmu.freeInstance()
    assert log.errors() == []
    [warning] = warnings(log)
    assert warning.startswith(f"fmusim: {NOT_ACTIVATED}"), warning

    zero = drv.plain(controller, [0] * (drv.SAMPLES + 1), drv.Log())
    assert run.codes == zero.codes
    assert len(set(run.codes)) > 10, "the gait ran"


def test_validation_includes_the_clocked_variable_rules():
    assert validate_fmu(str(FMU)) == []
    md = read_model_description(str(FMU))
    clocks = {v.name: v for v in md.modelVariables if v.type == "Clock"}
    sample, gait = clocks[Controller.SAMPLE_CLOCK], clocks[Controller.GAIT_STEP]
    assert (sample.causality, sample.intervalVariability) == ("input", "constant")
    assert (gait.causality, gait.intervalVariability) == ("output", "triggered")
    outputs = [v for v in md.modelVariables if v.causality == "output" and v.type != "Clock"]
    for v in outputs:
        want = gait if v.name in GAIT_CLOCKED else sample
        assert v.clocks == [want], v.name
    # FMPy's rule for clocked outputs: not initial unknowns. The same description with the
    # clocks attributes removed breaks it, so the check above is the rule's, not a blank.
    assert not {u.variable.name for u in md.initialUnknowns} & {v.name for v in outputs}
    unclocked = copy.deepcopy(md)
    for v in unclocked.modelVariables:
        v.clocks = None
    problems = validate_model_description(unclocked, validate_model_structure=True)
    assert any("InitialUnknowns" in p for p in problems), problems
    # FMPy 0.3.32 reads no interval: the description's own.
    with zipfile.ZipFile(FMU) as z:
        xml = ElementTree.fromstring(z.read("modelDescription.xml"))
    [clock] = [c for c in xml.iter("Clock") if c.get("name") == Controller.SAMPLE_CLOCK]
    assert float(clock.get("intervalDecimal")) == drv.H
