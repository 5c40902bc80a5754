"""InchwormDelayLine.ssp, unchanged, in `inchworm run`, Ecos (ecospy), OSP libcosim
(libcosimpy) and FMPy (`fmpy.ssp`): over 3 s of the default (ground, 10 m baseline) each master gives the same
residual optical path and runner position, sample for sample: Ecos to the bit, libcosim
to 1e-15 m (libcosim keeps time in integer nanoseconds, and the plant's steps from its
times differ from the others' in the last bits, as in InchwormSystem.ssp); FMPy, whose connectors start at 0 (the controller's first
reference), to the bit until the gait's first step and to 1 % in the residual's RMS; the
`no-fine-stage` set leaves the inchworm alone behind the tracker, with a larger residual.
How each master labels its rows is in ssp_masters.py."""
import numpy as np
import pytest

import ssp_masters as m
from conftest import DIST

STOP = 3.0
NAMES = ["delay_line.residual", "plant.runner_position", "delay_line.fine_path"]


@pytest.fixture(scope="module")
def ssp():
    path = DIST / "InchwormDelayLine.ssp"
    if not path.exists():
        pytest.fail(f"{path} is missing: run `cargo run --release -p fmu-build` first")
    return path


@pytest.fixture(scope="module")
def ours(ssp):
    return m.inchworm(ssp, STOP, NAMES)


def assert_same(a, b, what, atol=0.0):
    for n in NAMES:
        x, y = np.asarray(a[n], dtype=float), np.asarray(b[n], dtype=float)
        assert x.shape == y.shape, (what, n, x.shape, y.shape)
        differ = np.flatnonzero(np.abs(x - y) > atol)
        assert differ.size == 0, f"{what}: {n} differs first at sample {differ[:1]}"


def test_the_loop_takes_out_the_sidereal_path(ours):
    t, r = ours
    assert len(t) == int(STOP / m.H) + 1
    after = t >= 1.0
    rms = np.sqrt(np.mean(r["delay_line.residual"][after] ** 2))
    assert rms < 10e-6, rms
    assert np.max(np.abs(r["delay_line.fine_path"])) > 0, "the fine stage takes part"


def test_ecos_gives_the_inchworm_run(ssp, ours, tmp_path, monkeypatch):
    monkeypatch.setenv("TMPDIR", str(tmp_path))  # Ecos unpacks the SSP into TMPDIR
    labels, r = m.ecos(ssp, STOP, NAMES)
    t, mine = ours
    np.testing.assert_allclose(labels, t, rtol=0, atol=1e-9)
    assert_same({n: v[1:] for n, v in mine.items()}, {n: v[1:] for n, v in r.items()}, "Ecos")


def test_libcosim_gives_the_inchworm_run(ssp, ours, tmp_path):
    d = m.unpack_with_first(ssp, tmp_path / "ssp", {})
    labels, r = m.libcosim(d, STOP, NAMES)
    t, mine = ours
    np.testing.assert_allclose(labels, t[1:], rtol=0, atol=1e-9)
    assert_same({n: v[1:] for n, v in mine.items()}, r, "libcosim", atol=1e-15)


def test_without_the_fine_stage_the_inchworm_is_alone(ssp, ours):
    t, alone = m.inchworm(ssp, STOP, NAMES, parameter_set="no-fine-stage")
    assert np.all(alone["delay_line.fine_path"] == 0)
    after = t >= 1.0
    rms = [np.sqrt(np.mean(r["delay_line.residual"][after] ** 2)) for r in (ours[1], alone)]
    assert rms[1] > rms[0], rms


def test_fmpy_runs_it_to_the_same_figures(ssp, ours):
    labels, r = m.fmpy(ssp, STOP, NAMES)
    t, mine = ours
    # FMPy's row k is labelled k h and holds the values at (k + 1) h: inchworm's row k + 1
    # (its last row is one step past the stop time).
    np.testing.assert_allclose(labels[:-1] + m.H, t[1:], rtol=0, atol=1e-9)
    x, y = mine["delay_line.residual"][1:], np.asarray(r["delay_line.residual"])[:-1]
    # Its controller's first tick saw a reference of 0, not the delay line's: the runner
    # is the same until the gait's first step, and the loop's figures after it.
    first = int(np.argmax(x != y))
    assert first > 20 and np.array_equal(x[:first], y[:first]), first
    after = t[1:] >= 1.0
    rms = [np.sqrt(np.mean(v[after] ** 2)) for v in (x, y)]
    assert abs(rms[1] / rms[0] - 1) < 0.01, rms
