"""InchwormSystem.ssp (closed: reference, controller, plant) and InchwormSystemOpen.ssp:
valid SSP 1.0 (FMPy validates against the schemas it ships), connections only between
components in the closed one, component-level parameter bindings with the default set
first and equal to the FMUs' defaults, and every set changes the run."""
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.ssp.simulation import simulate_ssp
from fmpy.ssp.ssd import read_ssd, read_ssv

import ssp_masters as m
from conftest import DIST
from inchworm_variables import InchwormController as Controller, InchwormPlant as Plant

SETS = {
    "plant": ["default", "fia20", "fia6"],
    "controller": ["default", "full-control", "feedback-only", "prefilter"],
    "reference": ["default", "staircase"],
}


def built(name):
    path = DIST / name
    if not path.exists():
        pytest.fail(f"{path} is missing: run `cargo run --release -p fmu-build` first")
    return str(path)


@pytest.fixture(scope="session")
def system_ssp():
    return built("InchwormSystem.ssp")


@pytest.fixture(scope="session")
def open_ssp():
    return built("InchwormSystemOpen.ssp")


def test_closed_system_validates_and_connects_only_components(system_ssp, tmp_path):
    ssd = read_ssd(system_ssp, validate=True)
    assert [e.name for e in ssd.system.elements] == ["reference", "controller", "plant"]
    assert ssd.system.connectors == [], "no system connectors: nothing to feed from outside"
    ends = {(c.startElement, c.startConnector, c.endElement, c.endConnector) for c in ssd.system.connections}
    assert all(a is not None and b is not None for a, _, b, _ in ends), "a component at both ends"
    for ch in [Plant.DAC_EARTH, Plant.DAC_NONEARTH, Plant.DAC_EXTENSION]:
        assert ("controller", ch, "plant", ch) in ends
    assert ("plant", Plant.ENCODER_COUNTS, "controller", Plant.ENCODER_COUNTS) in ends
    assert ("reference", Controller.REFERENCE, "controller", Controller.REFERENCE) in ends
    with zipfile.ZipFile(system_ssp) as z:
        z.extractall(tmp_path)
        ssvs = [n for n in z.namelist() if n.endswith(".ssv")]
    for n in ssvs:
        read_ssv(str(tmp_path / n), validate=True)
    _, order = m.bindings(system_ssp)
    assert order == SETS, "each component's bindings, default first"


def test_each_components_first_binding_equals_the_fmu_defaults(system_ssp):
    sets, _ = m.bindings(system_ssp)
    sources = {"plant": "InchwormPlant", "controller": "InchwormController", "reference": "InchwormReference"}
    for comp, fmu in sources.items():
        starts = {v.name: v.start for v in read_model_description(built(f"{fmu}.fmu")).modelVariables}
        values = sets["default"][comp]
        assert values, comp
        for name, (ty, text) in values.items():
            assert ty in ("Real", "Integer", "Boolean"), name
            assert m._python_value(ty, text) == m._python_value(ty, starts[name]), f"{comp}.{name}: {text} vs {starts[name]}"
    # Names are relative to the component: no prefix in any set.
    assert all("." not in n for s in sets.values() for c in s.values() for n in c)
    assert sets["fia6"]["plant"]["T_em"] == ("Real", "2.5") and sets["fia20"]["plant"]["T_em"] == ("Real", "8.8")
    assert sets["feedback-only"]["controller"][Controller.FEEDFORWARD] == ("Boolean", "false")


def settle_time(t, counts, target=100e-6, tol=1e-6):
    """The first parked sample (encoder still for 8 samples: between moves) from which
    every parked sample is within `tol` of `target`, as `inchworm scenario` reports it."""
    counts = np.asarray(counts)
    parked = [i for i in range(7, len(counts)) if np.all(counts[i - 7:i + 1] == counts[i])]
    bad = [j for j, i in enumerate(parked) if abs(counts[i] * 1.2e-9 - target) > tol]
    if not bad:
        return t[parked[0]]
    assert bad[-1] + 1 < len(parked), "does not settle"
    return t[parked[bad[-1] + 1]]


def test_inchworm_runs_the_closed_system_with_no_input_and_every_set_changes_the_run(system_ssp):
    n = ["plant.encoder_counts"]
    t, base = m.inchworm(system_ssp, 10, n + ["reference.reference"])
    assert np.all(base["reference.reference"] == 100e-6), "the Fig. 5 step from t = 0"
    enc = base["plant.encoder_counts"]
    assert abs(enc[-1] * 1.2e-9 - 100e-6) < 1e-6
    runs = {s: m.inchworm(system_ssp, 10, n, parameter_set=s)[1][n[0]] for s in ["default", "full-control", "feedback-only", Controller.PREFILTER, "fia20", "fia6"]}
    assert np.array_equal(runs["default"], enc) and np.array_equal(runs["full-control"], enc) and np.array_equal(runs["fia20"], enc)
    for s in ["feedback-only", Controller.PREFILTER, "fia6"]:
        assert not np.array_equal(runs[s], enc), s
    assert settle_time(t, runs["feedback-only"]) > settle_time(t, enc) + 0.5, "feedback only settles later"
    _, stair = m.inchworm(system_ssp, 2, ["reference.reference"], parameter_set="staircase")
    assert stair["reference.reference"][0] == 100 * 1e-6, "the staircase profile, as the scenario computes it"
    _, moved = m.inchworm(system_ssp, 2, ["reference.reference"], params=["reference.positions[1]=30e-6"])
    assert np.all(moved["reference.reference"] == 30e-6)


def test_open_variant_validates_and_runs_in_fmpy_with_a_system_input(open_ssp, tmp_path):
    ssd = read_ssd(open_ssp, validate=True)
    assert [e.name for e in ssd.system.elements] == ["plant", "controller"]
    assert [c.name for c in ssd.system.connectors][0] == Controller.REFERENCE
    stop = 4.0
    r = simulate_ssp(open_ssp, stop_time=stop, step_size=0.002, input={Controller.REFERENCE: lambda t: 100e-6})
    ref = tmp_path / "ref.csv"
    ref.write_text("time,reference\n0,0\n0.002,100e-6\n")
    out = tmp_path / "run.csv"
    import subprocess
    p = subprocess.run([str(m.EXE), "run", open_ssp, "--input", str(ref), "--stop-time", str(stop), "--step-size", "0.002",
                        "--output", "plant.encoder_counts", "--out", str(out)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    rows = np.loadtxt(out, delimiter=",", skiprows=1)
    # FMPy feeds system inputs one step late and labels row k with the start of its step.
    # Its accumulated time may add a row past the stop time.
    n = len(rows) - 1
    assert len(r) in (n, n + 1)
    assert np.array_equal(rows[1:, 1], r["plant.encoder_counts"][:n])
