"""InchwormPlant.fmu in FMPy: validation, default simulation, docs/model.md §2.9 check values,
sample-by-sample reference trace, through both FMPy's Python API and its command line."""
import csv
import pathlib
import subprocess
import sys

import numpy as np
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

from conftest import assert_check_values, write_gait_input
from inchworm_variables import InchwormPlant as Plant

# The `fmpy` console command itself, as users run it in their CI.
FMPY = [str(pathlib.Path(sys.executable).parent / "fmpy")]


def test_validates_without_problems(plant_fmu):
    problems = validate_fmu(plant_fmu)
    assert problems == [], problems


def test_command_line_validate(plant_fmu):
    out = subprocess.run(FMPY + ["validate", plant_fmu], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "problem" not in out.stdout.lower() or "no problems" in out.stdout.lower(), out.stdout


def test_model_description_declares_the_interface(plant_fmu):
    md = read_model_description(plant_fmu)
    assert md.coSimulation.modelIdentifier == "InchwormPlant"
    assert md.defaultExperiment.stepSize == "0.002" or float(md.defaultExperiment.stepSize) == 0.002
    by_name = {v.name: v for v in md.modelVariables}
    for name in [Plant.DAC_EARTH, Plant.DAC_NONEARTH, Plant.DAC_EXTENSION]:
        assert by_name[name].causality == "input"
    for name in [Plant.ENCODER_COUNTS, Plant.ENCODER_POSITION, Plant.RUNNER_POSITION, Plant.EXTENSION, Plant.VOLTAGE_EARTH,
                 Plant.VOLTAGE_NONEARTH, Plant.VOLTAGE_EXTENSION, Plant.MODE, Plant.EARTH_CLOSED, Plant.NONEARTH_CLOSED, Plant.SLIP_EVENTS]:
        assert by_name[name].causality == "output", name
    for name in [Plant.M_P, Plant.K_P, "T_em", "C", Plant.PLAY_RADIUS_1, Plant.PLAY_WEIGHT_5, "F_d0", Plant.GAMMA, "V_th", Plant.Q_ENC, Plant.REL_TOL]:
        assert by_name[name].causality == "parameter", name
    assert float(by_name["F_d0"].start) == 175.0


def test_simulates_with_defaults_and_stays_at_rest(plant_fmu):
    result = simulate_fmu(plant_fmu)
    assert len(result) > 10
    assert np.all(result[Plant.ENCODER_COUNTS] == 0)
    assert np.all(result[Plant.MODE] == 1)


def simulate_reference(plant_fmu, reference_rows, tmp_path, **kw):
    path = tmp_path / "gait.csv"
    write_gait_input(reference_rows, path)
    signals = np.genfromtxt(path, delimiter=",", names=True)
    return simulate_fmu(plant_fmu, stop_time=1.0, output_interval=0.002, input=signals,
                        output=[Plant.ENCODER_COUNTS, Plant.MODE, Plant.RUNNER_POSITION], **kw)


def test_check_values_and_trace_through_fmpy(plant_fmu, reference_rows, tmp_path):
    result = simulate_reference(plant_fmu, reference_rows, tmp_path)
    # result row k is the communication point t = 0.002 k: the end of reference row k-1.
    assert len(result) == 501
    counts = list(result[Plant.ENCODER_COUNTS][1:])
    assert_check_values(counts)
    ref_counts = np.array([r["encoder_counts_after"] for r in reference_rows])
    dev = np.abs(np.array(counts) - ref_counts)
    k = int(np.argmax(dev))
    assert dev[k] <= 1, f"encoder differs from the reference by {dev[k]} counts at t = {reference_rows[k]['time'] + 0.002} s"
    ref_modes = np.array([r["mode_after"] for r in reference_rows])
    assert np.array_equal(result[Plant.MODE][1:], ref_modes)


def test_fia6_check_values_through_fmpy(plant_fmu, reference_rows, tmp_path):
    # The gait volts do not depend on the device: the fia20 trace's inputs drive fia6 too.
    fia6 = simulate_reference(plant_fmu, reference_rows, tmp_path, start_values={"T_em": 2.5, "F_d0": 105.0})
    assert_check_values(list(fia6[Plant.ENCODER_COUNTS][1:]), "fia6")


def test_command_line_simulate_with_input_file(plant_fmu, reference_rows, tmp_path):
    inp = tmp_path / "gait.csv"
    write_gait_input(reference_rows, inp)
    out = tmp_path / "result.csv"
    run = subprocess.run(FMPY + ["simulate", plant_fmu, "--input-file", str(inp), "--output-file", str(out),
                                 "--stop-time", "1.0", "--output-interval", "0.002",
                                 "--output-variables", Plant.ENCODER_COUNTS, Plant.MODE],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    counts = [int(float(r[Plant.ENCODER_COUNTS])) for r in rows[1:]]
    assert len(counts) == 500
    assert_check_values(counts)
