"""InchwormSystem.ssp: valid SSP 1.0 (FMPy validates against the schema it ships), with its
parameter sets, and it runs the closed loop in FMPy's SSP master."""
import os
import subprocess
import zipfile

import numpy as np
import pytest
from fmpy.ssp.simulation import simulate_ssp
from fmpy.ssp.ssd import read_ssd, read_ssv

from conftest import DIST

ROOT = DIST.parent

SETS = ["fia20", "fia6", "full-control", "feedback-only", "prefilter"]


@pytest.fixture(scope="session")
def system_ssp():
    path = DIST / "InchwormSystem.ssp"
    if not path.exists():
        pytest.fail(f"{path} is missing: run `cargo run --release -p fmu-build` first")
    return str(path)


def test_system_structure_and_parameter_sets_validate(system_ssp, tmp_path):
    ssd = read_ssd(system_ssp, validate=True)
    assert [e.name for e in ssd.system.elements] == ["plant", "controller"]
    ends = {(c.startElement, c.startConnector, c.endElement, c.endConnector) for c in ssd.system.connections}
    for ch in ["dac_earth", "dac_nonearth", "dac_extension"]:
        assert ("controller", ch, "plant", ch) in ends
    assert ("plant", "encoder_counts", "controller", "encoder_counts") in ends
    assert (None, "reference", "controller", "reference") in ends
    with zipfile.ZipFile(system_ssp) as z:
        z.extractall(tmp_path)
    values = {}
    for name in SETS:
        ps = read_ssv(os.path.join(tmp_path, "resources", f"{name}.ssv"), validate=True)
        values[name] = {p.name: p.value for p in ps.parameters}
    assert float(values["fia6"]["plant.T_em"]) == 2.5 and float(values["fia20"]["plant.T_em"]) == 8.8
    assert values["feedback-only"]["controller.feedforward"] in (False, "false")


def test_closed_loop_runs_in_fmpys_ssp_master(system_ssp):
    # FMPy's master steps every component, then applies the connections, so the system
    # input `reference` reaches the controller one communication step late; the loop still
    # settles on the reference (Fig. 5).
    result = simulate_ssp(system_ssp, stop_time=6.0, step_size=0.002, input={"reference": lambda t: 100e-6})
    t = result["time"]
    enc = result["encoder_position"]
    # Parked samples: all DACs zero for the previous 8 samples.
    dac = np.vstack([result[f"plant.{c}"] for c in ["dac_earth", "dac_nonearth", "dac_extension"]]).T
    zero = np.all(dac == 0.0, axis=1)
    parked = [i for i in range(8, len(t)) if zero[i - 7:i + 1].all()]
    late = [i for i in parked if t[i] > 3.0]
    assert late, "no parked samples after 3 s"
    err = np.abs(enc[late] - 100e-6)
    assert err.max() < 1e-6, f"parked error after 3 s up to {err.max() * 1e9:.0f} nm"


def test_fmpys_ssp_trace_is_the_inchworm_masters_with_the_reference_one_step_late(system_ssp, tmp_path):
    # FMPy's SSP master hands the system input to the controller one communication step
    # late (docs/ssp.md). Give `inchworm run` the same late reference and the two masters
    # must produce the same encoder trace, sample for sample: the SSP, the FMUs and the
    # Jacobi coupling are the same; only FMPy's input timing differs.
    stop = 4.0
    fmpy_result = simulate_ssp(system_ssp, stop_time=stop, step_size=0.002, input={"reference": lambda t: 100e-6})
    ref = tmp_path / "ref.csv"
    ref.write_text("time,reference\n0,0\n0.002,100e-6\n")
    out = tmp_path / "run.csv"
    exe = ROOT / "target" / "release" / "inchworm"
    assert exe.exists(), "build the CLI first: cargo build --release"
    r = subprocess.run(
        [str(exe), "run", system_ssp, "--input", str(ref), "--stop-time", str(stop), "--step-size", "0.002",
         "--output", "plant.encoder_counts", "--output", "encoder_position", "--out", str(out)],
        capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    rows = np.loadtxt(out, delimiter=",", skiprows=1)
    # FMPy labels each row with the time at the start of its step but records the values
    # at the end of it: its row k is the inchworm master's row k + 1.
    n = min(len(fmpy_result), len(rows) - 1)
    assert n >= int(stop / 0.002) - 1, (len(rows), len(fmpy_result))
    np.testing.assert_allclose(rows[1:n + 1, 0], fmpy_result["time"][:n] + 0.002, rtol=0, atol=1e-9)
    counts = fmpy_result["plant.encoder_counts"][:n]
    ours = rows[1:n + 1, 1]
    assert np.array_equal(ours, counts), f"first difference at sample {np.argmax(ours != counts)}"
    assert np.array_equal(rows[1:n + 1, 2], fmpy_result["encoder_position"][:n])
    assert counts.max() > 80_000, "the loop moved the runner to about 100 um"
