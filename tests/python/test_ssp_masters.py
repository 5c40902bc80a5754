"""InchwormSystem.ssp, unchanged, in four SSP masters: `inchworm run`, FMPy 0.3.32
(`fmpy.ssp.simulate_ssp`), Ecos 0.7.2 (ecospy) and OSP libcosim (libcosimpy 0.0.6,
`CosimExecution.from_ssp_file`). Over the Fig. 5 run (10 s) each gives the encoder trace
of `inchworm run` sample for sample, 0 counts apart, and selecting the parameter set
`feedback-only` gives the feedback-only trace. How each master labels its rows is in
ssp_masters.py."""
import numpy as np
import pytest

import ssp_masters as m
from test_system_ssp import settle_time, system_ssp  # noqa: F401  (fixture)

STOP = 10.0
ENC = "plant.encoder_counts"


@pytest.fixture(scope="module")
def inchworm_traces(system_ssp):
    """`inchworm run` of each set, and the same with the reference one step late (as
    FMPy's controller sees it: FMPy starts every connector at 0)."""
    out = {}
    for s in [None, "feedback-only"]:
        out[s] = m.inchworm(system_ssp, STOP, [ENC], parameter_set=s)
        out[s, "late"] = m.inchworm(system_ssp, STOP, [ENC], parameter_set=s, params=["reference.times[1]=0.002"])
    return out


def assert_same(ours, theirs, what):
    assert len(ours) == len(theirs) == int(STOP / m.H), (what, len(ours), len(theirs))
    diff = np.abs(np.asarray(ours, dtype=np.int64) - np.asarray(theirs, dtype=np.int64))
    assert diff.max() == 0, f"{what}: first difference at sample {np.argmax(diff > 0)}, up to {diff.max()} counts"


def test_inchworm_feedback_only_is_the_slower_trace(inchworm_traces):
    t, full = inchworm_traces[None]
    _, fb = inchworm_traces["feedback-only"]
    assert len(t) == int(STOP / m.H) + 1 and t[0] == 0.0
    assert not np.array_equal(full[ENC], fb[ENC])
    assert settle_time(t, fb[ENC]) > settle_time(t, full[ENC]) + 0.5


@pytest.mark.parametrize("parameter_set", [None, "feedback-only"])
def test_fmpy_gives_the_inchworm_trace_with_the_reference_one_step_late(system_ssp, inchworm_traces, parameter_set):
    labels, r = m.fmpy(system_ssp, STOP, [ENC], parameter_set=parameter_set)
    t, late = inchworm_traces[parameter_set, "late"]
    # FMPy's row k is labelled k h and holds the values at (k + 1) h: inchworm's row k + 1.
    np.testing.assert_allclose(labels + m.H, t[1:], rtol=0, atol=1e-9)
    assert_same(late[ENC][1:], r[ENC], f"FMPy, set {parameter_set}")
    assert not np.array_equal(late[ENC], inchworm_traces[parameter_set][1][ENC]), "the late start is visible"


@pytest.mark.parametrize("parameter_set", [None, "feedback-only"])
def test_ecos_gives_the_inchworm_trace(system_ssp, inchworm_traces, parameter_set, tmp_path, monkeypatch):
    # Ecos unpacks the SSP into TMPDIR and leaves it there.
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    labels, r = m.ecos(system_ssp, STOP, [ENC], parameter_set=parameter_set)
    t, ours = inchworm_traces[parameter_set]
    np.testing.assert_allclose(labels, t, rtol=0, atol=1e-9)
    assert r[ENC][0] == 0
    assert_same(ours[ENC][1:], r[ENC][1:], f"Ecos, set {parameter_set}")


@pytest.mark.parametrize("parameter_set", [None, "feedback-only"])
def test_libcosim_gives_the_inchworm_trace(system_ssp, inchworm_traces, parameter_set, tmp_path):
    # libcosim applies each component's first binding (here `default`) and cannot select
    # another: a set is chosen by moving its binding first in the unpacked SSD.
    first = {"controller": parameter_set} if parameter_set else {}
    d = m.unpack_with_first(system_ssp, tmp_path / "ssp", first)
    labels, r = m.libcosim(d, STOP, [ENC])
    t, ours = inchworm_traces[parameter_set]
    np.testing.assert_allclose(labels, t[1:], rtol=0, atol=1e-9)
    assert_same(ours[ENC][1:], r[ENC], f"libcosim, set {parameter_set}")
