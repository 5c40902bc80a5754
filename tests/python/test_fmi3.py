"""The FMI 3.0 FMUs (dist/fmi3/) in FMPy: only fmi3* symbols, clean validation, default
and gait-input simulation, the FMI 2.0 FMUs' traces bit for bit (plant on the passive
check trace, closed loop through FMPy's FMI 3.0 API), state round trips and refusals."""
import pathlib
import shutil
import subprocess
import sys
import zipfile

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

from conftest import DIST, assert_check_values, write_gait_input
from inchworm_variables import InchwormController as Controller, InchwormPlant as Plant

FMI3 = DIST / "fmi3"
FMPY = [str(pathlib.Path(sys.executable).parent / "fmpy")]
NAMES = ["InchwormPlant", "InchwormController"]
# glibc before 2.34 (the floor is 2.17) kept libdl and libpthread apart from libc; every
# glibc since still ships both names.
ALLOWED_NEEDED = {"libc.so.6", "libm.so.6", "libgcc_s.so.1", "ld-linux-x86-64.so.2", "libdl.so.2", "libpthread.so.0"}
# Every function of fmi3Functions.h (FMI 3.0): common, Model Exchange, Co-Simulation,
# Scheduled Execution.
N_FMI3_FUNCTIONS = 75
H = 0.002
PLANT_OUTPUTS = [Plant.ENCODER_COUNTS, Plant.ENCODER_POSITION, Plant.RUNNER_POSITION, Plant.EXTENSION, Plant.VOLTAGE_EARTH,
                 Plant.VOLTAGE_NONEARTH, Plant.VOLTAGE_EXTENSION, Plant.MODE, Plant.EARTH_CLOSED, Plant.NONEARTH_CLOSED, Plant.SLIP_EVENTS]


def fmu3(name):
    path = FMI3 / f"{name}.fmu"
    if not path.exists():
        pytest.fail(f"{path} is missing: run `cargo run --release -p fmu-build` first")
    return str(path)


@pytest.mark.parametrize("name", NAMES)
def test_only_fmi3_symbols_and_only_the_c_runtime(name, tmp_path):
    if not (shutil.which("nm") and shutil.which("readelf")):
        pytest.fail("nm and readelf (Debian binutils) are needed for this check")
    with zipfile.ZipFile(fmu3(name)) as z:
        so = z.extract(f"binaries/x86_64-linux/{name}.so", tmp_path)
    out = subprocess.run(["nm", "-D", "--defined-only", so], capture_output=True, text=True, check=True).stdout
    names = [line.split()[-1] for line in out.split("\n") if line.strip()]
    assert len([n for n in names if n.startswith("fmi3")]) == N_FMI3_FUNCTIONS
    assert [n for n in names if not n.startswith("fmi3")] == []
    dynamic = subprocess.run(["readelf", "-d", so], capture_output=True, text=True, check=True).stdout
    needed = {line.split("[")[1].rstrip("]") for line in dynamic.splitlines() if "(NEEDED)" in line}
    assert needed <= ALLOWED_NEEDED, needed - ALLOWED_NEEDED


@pytest.mark.parametrize("name", NAMES)
def test_validates_without_problems(name):
    assert validate_fmu(fmu3(name)) == []
    out = subprocess.run(FMPY + ["validate", fmu3(name)], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "no problems" in out.stdout.lower(), out.stdout


@pytest.mark.parametrize("name", NAMES)
def test_same_variables_as_fmi2(name):
    md2 = read_model_description(str(DIST / f"{name}.fmu"))
    md3 = read_model_description(fmu3(name))
    assert md3.fmiVersion == "3.0"
    assert md3.guid == md2.guid, "instantiationToken is the FMI 2.0 GUID"
    types = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean"}
    v2 = [(v.name, v.valueReference, types[v.type], v.causality, v.start) for v in md2.modelVariables]
    v3 = []
    for v in md3.modelVariables:
        if v.causality == "independent" or v.type == "Clock":  # FMI 2.0 has no clocks
            continue
        if not v.dimensions:
            v3.append((v.name, v.valueReference, v.type, v.causality, v.start))
            continue
        # An FMI 3.0 array is the FMI 2.0 scalars name[1] ... name[n], one value
        # reference apart, its start one item each.
        (n,) = [int(d.start) for d in v.dimensions]
        starts = v.start.split() if v.start is not None else [None] * n  # an output has none
        assert len(starts) == n
        v3 += [(f"{v.name}[{k + 1}]", v.valueReference + k, v.type, v.causality, starts[k]) for k in range(n)]
    assert v3 == v2
    clocks = [(v.name, v.valueReference, v.causality) for v in md3.modelVariables if v.type == "Clock"]
    expected = {"InchwormController": [(Controller.SAMPLE_CLOCK, 5, "input"), (Controller.GAIT_STEP, 25, "output")]}
    assert clocks == expected.get(name, [])
    time = [v for v in md3.modelVariables if v.causality == "independent"]
    assert [(v.name, v.valueReference) for v in time] == [("time", 0)]


def test_plant_simulates_with_defaults_and_stays_at_rest():
    result = simulate_fmu(fmu3("InchwormPlant"))
    assert len(result) > 10
    assert np.all(result[Plant.ENCODER_COUNTS] == 0)
    assert np.all(result[Plant.MODE] == 1)


def test_controller_simulates_with_defaults():
    r3 = simulate_fmu(fmu3("InchwormController"))
    r2 = simulate_fmu(str(DIST / "InchwormController.fmu"))
    assert r3.tobytes() == r2.tobytes()


def gait(reference_rows, tmp_path):
    path = tmp_path / "gait.csv"
    write_gait_input(reference_rows, path)
    return path, np.genfromtxt(path, delimiter=",", names=True)


def test_plant_gives_the_fmi2_trace_bit_for_bit(reference_rows, tmp_path):
    _, signals = gait(reference_rows, tmp_path)
    kw = dict(stop_time=1.0, output_interval=H, input=signals, output=PLANT_OUTPUTS)
    r3 = simulate_fmu(fmu3("InchwormPlant"), **kw)
    r2 = simulate_fmu(str(DIST / "InchwormPlant.fmu"), **kw)
    assert len(r3) == len(r2) == 501
    for name in PLANT_OUTPUTS:
        assert r3[name].tobytes() == r2[name].tobytes(), name
    counts = list(r3[Plant.ENCODER_COUNTS][1:])
    assert_check_values(counts)
    ref = np.array([r["encoder_counts_after"] for r in reference_rows])
    assert np.max(np.abs(np.array(counts) - ref)) <= 1


def test_fia6_parameters_through_fmpy_fmi3(reference_rows, tmp_path):
    _, signals = gait(reference_rows, tmp_path)
    kw = dict(stop_time=1.0, output_interval=H, input=signals, output=[Plant.ENCODER_COUNTS],
              start_values={"T_em": 2.5, "F_d0": 105.0})
    r3 = simulate_fmu(fmu3("InchwormPlant"), **kw)
    r2 = simulate_fmu(str(DIST / "InchwormPlant.fmu"), **kw)
    assert r3[Plant.ENCODER_COUNTS].tobytes() == r2[Plant.ENCODER_COUNTS].tobytes()
    assert_check_values(list(r3[Plant.ENCODER_COUNTS][1:]), "fia6")


def test_command_line_simulate_with_input_file(reference_rows, tmp_path):
    inp, _ = gait(reference_rows, tmp_path)
    out3, out2 = tmp_path / "fmi3.csv", tmp_path / "fmi2.csv"
    for fmu, out in [(fmu3("InchwormPlant"), out3), (str(DIST / "InchwormPlant.fmu"), out2)]:
        run = subprocess.run(FMPY + ["simulate", fmu, "--stop-time", "1.0", "--output-interval", "0.002",
                                     "--input-file", str(inp), "--output-file", str(out)],
                             capture_output=True, text=True)
        assert run.returncode == 0, run.stdout + run.stderr
    assert out3.read_text() == out2.read_text()


def load3(name, instance):
    path = fmu3(name)
    md = read_model_description(path)
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=extract(path),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName=instance)
    fmu.instantiate()
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    return fmu, {v.name: v.valueReference for v in md.modelVariables}


def load2(name, instance):
    path = str(DIST / f"{name}.fmu")
    md = read_model_description(path)
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName=instance)
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    return fmu, {v.name: v.valueReference for v in md.modelVariables}


DAC = [Plant.DAC_EARTH, Plant.DAC_NONEARTH, Plant.DAC_EXTENSION]


def jacobi3(steps):
    plant, pv = load3("InchwormPlant", "plant")
    ctrl, cv = load3("InchwormController", "controller")
    counts = []
    for k in range(steps):
        t = k * H
        enc = plant.getInt32([pv[Plant.ENCODER_COUNTS]])
        volts = ctrl.getFloat64([cv[n] for n in DAC])
        plant.setFloat64([pv[n] for n in DAC], volts)
        ctrl.setInt32([cv[Plant.ENCODER_COUNTS]], enc)
        ctrl.setFloat64([cv[Controller.REFERENCE]], [100e-6])
        for f in (plant, ctrl):
            event, terminate, early, last = f.doStep(t, H)
            assert (event, terminate, early) == (False, False, False)
            assert last == t + H
        counts.append(plant.getInt32([pv[Plant.ENCODER_COUNTS]])[0])
    for f in (plant, ctrl):
        f.terminate()
        f.freeInstance()
    return counts


def jacobi2(steps):
    plant, pv = load2("InchwormPlant", "plant")
    ctrl, cv = load2("InchwormController", "controller")
    counts = []
    for k in range(steps):
        t = k * H
        enc = plant.getInteger([pv[Plant.ENCODER_COUNTS]])
        volts = ctrl.getReal([cv[n] for n in DAC])
        plant.setReal([pv[n] for n in DAC], volts)
        ctrl.setInteger([cv[Plant.ENCODER_COUNTS]], enc)
        ctrl.setReal([cv[Controller.REFERENCE]], [100e-6])
        plant.doStep(t, H)
        ctrl.doStep(t, H)
        counts.append(plant.getInteger([pv[Plant.ENCODER_COUNTS]])[0])
    for f in (plant, ctrl):
        f.terminate()
        f.freeInstance()
    return counts


def test_closed_loop_through_fmpy_fmi3_api_equals_fmi2():
    c3 = jacobi3(5000)
    c2 = jacobi2(5000)
    first = next((i for i, (a, b) in enumerate(zip(c2, c3)) if a != b), None)
    assert first is None, f"FMI 3.0 and FMI 2.0 loops differ first at sample {first}"
    assert abs(c3[-1] * 1.2e-3 - 100.0) < 1.0


def test_state_round_trip_and_corrupt_blob():
    plant, pv = load3("InchwormPlant", "plant")
    plant.setFloat64([pv[Plant.DAC_EXTENSION]], [10.0])
    t = 0.0
    for _ in range(50):
        plant.doStep(t, H)
        t += H
    saved = plant.getFMUState()
    blob = plant.serializeFMUState(saved)
    ahead = []
    for _ in range(50):
        plant.doStep(t, H)
        t += H
        ahead.append(plant.getFloat64([pv[Plant.EXTENSION]])[0])
    restored = plant.deserializeFMUState(blob)
    plant.setFMUState(restored)
    t = 50 * H
    again = []
    for _ in range(50):
        plant.doStep(t, H)
        t += H
        again.append(plant.getFloat64([pv[Plant.EXTENSION]])[0])
    assert again == ahead
    bad = bytearray(blob)
    bad[len(bad) // 2] ^= 0x10
    with pytest.raises(FMICallException):
        plant.deserializeFMUState(bytes(bad))
    plant.freeFMUState(saved)
    plant.freeFMUState(restored)
    plant.terminate()
    plant.freeInstance()


def test_refusals_reach_the_logger():
    messages = []

    def log(env, status, category, message):
        messages.append((status, category.decode(), message.decode()))

    path = fmu3("InchwormPlant")
    md = read_model_description(path)
    plant = FMU3Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier="InchwormPlant", instanceName="p")
    plant.instantiate(logMessage=log)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    with pytest.raises(FMICallException):
        plant.doStep(0.0, H)  # before initialization
    plant.enterInitializationMode(startTime=0.0)
    plant.exitInitializationMode()
    with pytest.raises(FMICallException):
        plant.getFloat64([9999])
    with pytest.raises(FMICallException):
        plant.setFloat64([vr[Plant.DAC_EARTH]], [float("nan")])
    with pytest.raises(FMICallException):
        plant.setFloat64([vr[Plant.M_P]], [1.0])  # a fixed parameter after initialization
    with pytest.raises(FMICallException):
        plant.getInt32([vr[Plant.DAC_EARTH]])  # a Float64 asked as Int32
    plant.setFloat64([vr[Plant.DAC_EARTH]], [12.0])  # clamped, with a warning
    assert plant.getFloat64([0]) == [0.0]  # time
    with pytest.raises(FMICallException):
        plant.enterEventMode()
    plant.doStep(0.0, H)
    assert plant.getFloat64([0]) == [H]
    with pytest.raises(FMICallException):
        plant.doStep(1.0, H)  # not where the last step ended
    plant.terminate()
    plant.freeInstance()
    text = "\n".join(m[2] for m in messages)
    for expected in ["illegal call sequence", "unknown value reference 9999", "must be finite",
                     "cannot be set in state StepMode", "is Float64, not Int32", "clamped to 10",
                     "hasEventMode is false", "does not match the FMU time"]:
        assert expected in text, (expected, text)
    assert all(m[1] in ("logStatusError", "logStatusWarning") for m in messages)


@pytest.mark.parametrize("fmi3_file, fmi2_file", [
    ("fmi3/InchwormPlant.fmu", "InchwormPlant.fmu"),
    ("fmi3/InchwormSystemOpen.ssp", "InchwormSystemOpen.ssp"),
    ("fmi3/InchwormSystemMixed.ssp", "InchwormSystem.ssp"),
])
def test_inchworm_run_takes_fmi3_fmus_and_ssps(fmi3_file, fmi2_file, tmp_path):
    """`inchworm run` on an FMI 3.0 FMU, an SSP of FMI 3.0 FMUs and one mixing FMI 3.0 and
    FMI 2.0 writes what it writes for the FMI 2.0 files, byte for byte."""
    exe = DIST.parent / "target" / "release" / "inchworm"
    assert exe.exists(), "build the CLI first: cargo build --release"
    outs = []
    for f in (fmi3_file, fmi2_file):
        out = tmp_path / (f.replace("/", "_") + ".csv")
        run = subprocess.run([str(exe), "run", str(DIST / f), "--stop-time", "3", "--out", str(out)],
                             capture_output=True, text=True)
        assert run.returncode == 0, run.stdout + run.stderr
        outs.append(out.read_text())
    assert outs[0] == outs[1]
    assert len(outs[0].splitlines()) == 1502


ARRAYS = {"InchwormPlant": {"play_radius": 5, "play_weight": 5},
          "InchwormController": {"scale_weights": 10, "basis_peak": 10, "scale_weights_start": 10}}


@pytest.mark.parametrize("name", NAMES)
def test_the_arrays_are_declared_with_their_dimension(name):
    md = read_model_description(fmu3(name))
    arrays = {v.name: [int(d.start) for d in v.dimensions] for v in md.modelVariables if v.dimensions}
    assert arrays == {k: [n] for k, n in ARRAYS[name].items()}


def test_fmpy_reads_and_writes_the_arrays_and_the_loop_equals_fmi2():
    path = fmu3("InchwormPlant")
    md = read_model_description(path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    plant = FMU3Slave(guid=md.guid, unzipDirectory=extract(path),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="arrays")
    plant.instantiate()
    plant.enterInitializationMode(startTime=0.0)
    assert plant.getFloat64([vr["play_radius"]], nValues=5) == [15.0, 30.0, 45.0, 60.0, 75.0]
    plant.setFloat64([vr["play_radius"], vr["play_weight"]], [16, 31, 46, 61, 76, 0.09, 0.08, 0.07, 0.06, 0.05])
    assert plant.getFloat64([vr["play_weight"], vr["play_radius"]], nValues=10) == \
        [0.09, 0.08, 0.07, 0.06, 0.05, 16, 31, 46, 61, 76]
    with pytest.raises(FMICallException):
        plant.setFloat64([vr["play_radius"]], [1.0])  # one value for five
    plant.exitInitializationMode()
    plant.terminate()
    plant.freeInstance()

    # The estimator's weights after the Fig. 5 loop: the array through FMI 3.0, the
    # scalars through FMI 2.0, the same doubles.
    (ctrl3, cv3), (ctrl2, cv2) = load3("InchwormController", "c3"), load2("InchwormController", "c2")
    (plant3, pv3), (plant2, pv2) = load3("InchwormPlant", "p3"), load2("InchwormPlant", "p2")
    for k in range(500):
        t = k * H
        enc3, enc2 = plant3.getInt32([pv3[Plant.ENCODER_COUNTS]]), plant2.getInteger([pv2[Plant.ENCODER_COUNTS]])
        plant3.setFloat64([pv3[n] for n in DAC], ctrl3.getFloat64([cv3[n] for n in DAC]))
        plant2.setReal([pv2[n] for n in DAC], ctrl2.getReal([cv2[n] for n in DAC]))
        ctrl3.setInt32([cv3[Plant.ENCODER_COUNTS]], enc3)
        ctrl2.setInteger([cv2[Plant.ENCODER_COUNTS]], enc2)
        ctrl3.setFloat64([cv3[Controller.REFERENCE]], [100e-6])
        ctrl2.setReal([cv2[Controller.REFERENCE]], [100e-6])
        for f in (plant3, ctrl3):
            f.doStep(t, H)
        for f in (plant2, ctrl2):
            f.doStep(t, H)
    w3 = ctrl3.getFloat64([cv3["scale_weights"]], nValues=10)
    w2 = ctrl2.getReal([cv2[f"scale_weights[{k}]"] for k in range(1, 11)])
    assert w3 == w2
    assert w3 != ctrl3.getFloat64([cv3["scale_weights_start"]], nValues=10), "the estimator moved them"
    for f in (plant3, ctrl3, plant2, ctrl2):
        f.terminate()
        f.freeInstance()
