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
    for name in ["dac_earth", "dac_nonearth", "dac_extension"]:
        assert by_name[name].causality == "input"
    for name in ["encoder_counts", "encoder_position", "runner_position", "extension", "voltage_earth",
                 "voltage_nonearth", "voltage_extension", "mode", "earth_closed", "nonearth_closed", "slip_events"]:
        assert by_name[name].causality == "output", name
    for name in ["m_p", "k_p", "T_em", "C", "play_radius[1]", "play_weight[5]", "F_d0", "gamma", "V_th", "q_enc", "rel_tol"]:
        assert by_name[name].causality == "parameter", name
    assert float(by_name["F_d0"].start) == 175.0


def test_simulates_with_defaults_and_stays_at_rest(plant_fmu):
    result = simulate_fmu(plant_fmu)
    assert len(result) > 10
    assert np.all(result["encoder_counts"] == 0)
    assert np.all(result["mode"] == 1)


def simulate_reference(plant_fmu, reference_rows, tmp_path, **kw):
    path = tmp_path / "gait.csv"
    write_gait_input(reference_rows, path)
    signals = np.genfromtxt(path, delimiter=",", names=True)
    return simulate_fmu(plant_fmu, stop_time=1.0, output_interval=0.002, input=signals,
                        output=["encoder_counts", "mode", "runner_position"], **kw)


def test_check_values_and_trace_through_fmpy(plant_fmu, reference_rows, tmp_path):
    result = simulate_reference(plant_fmu, reference_rows, tmp_path)
    # result row k is the communication point t = 0.002 k: the end of reference row k-1.
    assert len(result) == 501
    counts = list(result["encoder_counts"][1:])
    assert_check_values(counts)
    ref_counts = np.array([r["encoder_counts_after"] for r in reference_rows])
    dev = np.abs(np.array(counts) - ref_counts)
    k = int(np.argmax(dev))
    assert dev[k] <= 1, f"encoder differs from the reference by {dev[k]} counts at t = {reference_rows[k]['time'] + 0.002} s"
    ref_modes = np.array([r["mode_after"] for r in reference_rows])
    assert np.array_equal(result["mode"][1:], ref_modes)


def test_fia6_check_values_through_fmpy(plant_fmu, reference_rows, tmp_path):
    # The gait volts do not depend on the device: the fia20 trace's inputs drive fia6 too.
    fia6 = simulate_reference(plant_fmu, reference_rows, tmp_path, start_values={"T_em": 2.5, "F_d0": 105.0})
    assert_check_values(list(fia6["encoder_counts"][1:]), "fia6")


def test_command_line_simulate_with_input_file(plant_fmu, reference_rows, tmp_path):
    inp = tmp_path / "gait.csv"
    write_gait_input(reference_rows, inp)
    out = tmp_path / "result.csv"
    run = subprocess.run(FMPY + ["simulate", plant_fmu, "--input-file", str(inp), "--output-file", str(out),
                                 "--stop-time", "1.0", "--output-interval", "0.002",
                                 "--output-variables", "encoder_counts", "mode"],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    counts = [int(float(r["encoder_counts"])) for r in rows[1:]]
    assert len(counts) == 500
    assert_check_values(counts)
