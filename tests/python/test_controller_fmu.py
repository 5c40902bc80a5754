"""InchwormController.fmu in FMPy: validation, default simulation, the timing contract at any
communication step, and the Fig. 5 loop at sub-sample master steps (FMPy and `inchworm run`)."""
import subprocess

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu

from conftest import DIST
from test_closed_loop import load
from inchworm_variables import InchwormController as Controller, InchwormPlant as Plant



def test_validates_without_problems(controller_fmu):
    assert validate_fmu(controller_fmu) == []


def test_simulates_with_defaults_and_starts_stepping_towards_the_reference(controller_fmu):
    # Encoder held at 0, reference 100 µm: the controller plans 3 full forward steps of ~26 µm and a
    # fraction, and drives the forward gait (non-earth brake powered from sample 15).
    result = simulate_fmu(controller_fmu, stop_time=0.2, start_values={Controller.REFERENCE: 100e-6},
                          output=[Plant.DAC_NONEARTH, Controller.DAC_NONEARTH_CODE, Controller.N_STEPS, Controller.MOVING])
    assert result[Controller.N_STEPS][-1] == 3
    assert result[Controller.DAC_NONEARTH_CODE].max() == 65535
    assert result[Plant.DAC_NONEARTH].max() == 10.0
    assert result[Controller.MOVING][-1]


def first_powered(result):
    """Time the non-earth brake DAC first reads 10 V (sample 15 of the first move)."""
    return next(t for t, v in zip(result["time"], result[Plant.DAC_NONEARTH]) if v > 5.0)


def test_any_output_interval_is_accepted_and_outputs_change_only_at_2_ms_instants(controller_fmu):
    # docs/model.md §5: the latch at each 2 ms instant in [t, t + h), the DAC write at each
    # in (t, t + h]. Encoder held (0), so every run sees the same inputs at every instant.
    out = [Plant.DAC_NONEARTH, Plant.DAC_EXTENSION, Controller.N_STEPS, Controller.SERVO_ERROR]
    args = dict(stop_time=0.2, start_values={Controller.REFERENCE: 100e-6}, output=out)
    two = simulate_fmu(controller_fmu, output_interval=0.002, **args)
    assert first_powered(two) == pytest.approx(0.028, abs=1e-12)
    for h in (0.001, 0.0005, 0.0001):
        r = simulate_fmu(controller_fmu, output_interval=h, **args)
        m = round(0.002 / h)
        assert len(r) == len(two) * m - (m - 1)
        for name in out:
            # At the instants the 2 ms run's values, between them held.
            assert np.array_equal(r[name][::m], two[name]), (h, name)
            assert np.array_equal(np.repeat(two[name][:-1], m), r[name][:-1]), (h, name)
        assert first_powered(r) == pytest.approx(0.028, abs=1e-12)
    # 3 ms straddles the instants: the sample written at 28 ms reaches this master at 30 ms.
    three = simulate_fmu(controller_fmu, output_interval=0.003, **args)
    assert first_powered(three) == pytest.approx(0.030, abs=1e-12)
    assert three[Controller.N_STEPS][-1] == two[Controller.N_STEPS][-1] == 3


def fig5_counts(plant_fmu, controller_fmu, h, duration):
    """Plant and controller in a plain Jacobi loop at step h (points k h), the Fig. 5
    reference: the encoder counts at the 2 ms instants from 2 ms on."""
    plant, pv = load(plant_fmu, "plant")
    ctrl, cv = load(controller_fmu, "controller")
    dac = [Plant.DAC_EARTH, Plant.DAC_NONEARTH, Plant.DAC_EXTENSION]
    m = round(0.002 / h)
    counts = []
    for k in range(round(duration / h)):
        t = k * h
        enc = plant.getInteger([pv[Plant.ENCODER_COUNTS]])
        volts = ctrl.getReal([cv[n] for n in dac])
        plant.setReal([pv[n] for n in dac], volts)
        ctrl.setInteger([cv[Plant.ENCODER_COUNTS]], enc)
        ctrl.setReal([cv[Controller.REFERENCE]], [100e-6])
        plant.doStep(t, h)
        ctrl.doStep(t, h)
        if (k + 1) % m == 0:
            counts.append(plant.getInteger([pv[Plant.ENCODER_COUNTS]])[0])
    for f in (plant, ctrl):
        f.terminate()
        f.freeInstance()
    return counts


def test_fmpy_jacobi_fig5_at_1_05_01_ms_settles_within_a_sample_of_the_2_ms_run(plant_fmu, controller_fmu):
    from test_system_ssp import settle_time

    t = [0.002 * (i + 1) for i in range(600)]
    two = fig5_counts(plant_fmu, controller_fmu, 0.002, 1.2)
    reference = settle_time(t, two)
    for h in (0.001, 0.0005, 0.0001):
        counts = fig5_counts(plant_fmu, controller_fmu, h, 1.2)
        assert len(counts) == 600
        assert abs(settle_time(t, counts) - reference) <= 0.002 + 1e-9, h
        assert abs(counts[-1] * 1.2e-9 - 100e-6) < 1e-6, h


def test_inchworm_run_of_the_system_at_sub_sample_steps_settles_within_a_sample(tmp_path):
    from ssp_masters import EXE
    from test_system_ssp import settle_time

    assert EXE.exists(), "build the CLI first: cargo build --release"
    runs = {}
    for h in (0.002, 0.001, 0.0005, 0.0001):
        out = tmp_path / f"run-{h}.csv"
        cmd = [str(EXE), "run", str(DIST / "InchwormSystem.ssp"), "--stop-time", "1.2", "--step-size", str(h), "--output", "plant.encoder_counts", "--out", str(out)]
        r = subprocess.run(cmd, capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        rows = np.loadtxt(out, delimiter=",", skiprows=1, ndmin=2)
        m = round(0.002 / h)
        runs[h] = (rows[m::m, 0], rows[m::m, 1])
        assert len(runs[h][0]) == 600, h
    t, two = runs[0.002]
    reference = settle_time(t, two)
    for h in (0.001, 0.0005, 0.0001):
        assert np.allclose(runs[h][0], t, rtol=0, atol=1e-9)
        assert abs(settle_time(t, runs[h][1]) - reference) <= 0.002 + 1e-9, h
