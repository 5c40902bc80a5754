"""MirrorMount.ssp: three reference/controller/plant chains and the mount kinematics run in
`inchworm run`, Ecos, libcosim and FMPy with identical traces (FMPy with its one-step-late
start: its controllers see each reference's first point one step late), with no external
input, at 2 ms and (inchworm, Ecos, libcosim) at 1 ms; and `inchworm scenario mirror`
reports its figures."""
import subprocess

import numpy as np
import pytest

import ssp_masters as m
from conftest import DIST
from inchworm_variables import InchwormPlant as Plant

STOP = 10.0
NAMES = ["mount.piston", "mount.tip", "mount.tilt"] + [f"plant_{x}.encoder_counts" for x in "abc"]


@pytest.fixture(scope="module")
def mirror_ssp():
    path = DIST / "MirrorMount.ssp"
    if not path.exists():
        pytest.fail(f"{path} is missing: run `cargo run --release -p fmu-build` first")
    return str(path)


@pytest.fixture(scope="module")
def ours(mirror_ssp):
    return m.inchworm(mirror_ssp, STOP, NAMES)


def assert_identical(a, b, what, real_atol=0.0):
    for n in NAMES:
        if real_atol and Plant.ENCODER_COUNTS not in n:
            np.testing.assert_allclose(b[n], a[n], rtol=0, atol=real_atol, err_msg=f"{what}: {n}")
            continue
        assert len(a[n]) == len(b[n]), (what, n, len(a[n]), len(b[n]))
        diff = np.nonzero(np.asarray(a[n], dtype=float) != np.asarray(b[n], dtype=float))[0]
        assert diff.size == 0, f"{what}: {n} first differs at sample {diff[0]}: {a[n][diff[0]]} vs {b[n][diff[0]]}"


def test_the_mount_follows_its_command_in_inchworm(mirror_ssp, ours):
    sets, order = m.bindings(mirror_ssp)
    assert order["reference_a"] == ["default"] and order["mount"] == []
    assert_mount_physics(*ours)


def test_ecos_runs_the_mount_identically(mirror_ssp, ours, tmp_path, monkeypatch):
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    labels, r = m.ecos(mirror_ssp, STOP, NAMES, parameter_set="default")
    t, o = ours
    np.testing.assert_allclose(labels, t, rtol=0, atol=1e-9)
    assert_identical({n: o[n][1:] for n in NAMES}, {n: r[n][1:] for n in NAMES}, "Ecos")


def test_libcosim_runs_the_mount_with_the_same_counts(mirror_ssp, ours, tmp_path):
    # libcosim keeps time in integer nanoseconds and hands the FMUs step sizes converted
    # from it, which differ from 0.002 s in the last bits (the plant's exact solver takes
    # h as given); the plants' Real outputs differ at that level, the encoder counts are
    # identical. The mount's pose agrees within 1e-15 m or rad.
    d = m.unpack_with_first(mirror_ssp, tmp_path / "ssp", {})
    labels, r = m.libcosim(d, STOP, NAMES)
    t, o = ours
    np.testing.assert_allclose(labels, t[1:], rtol=0, atol=1e-9)
    assert_identical({n: o[n][1:] for n in NAMES}, r, "libcosim", real_atol=1e-15)


def test_fmpy_runs_the_mount_identically_with_its_late_start(mirror_ssp):
    labels, r = m.fmpy(mirror_ssp, STOP, NAMES, parameter_set="default")
    t, late = m.inchworm(mirror_ssp, STOP, NAMES, params=[f"reference_{x}.times[1]=0.002" for x in "abc"])
    np.testing.assert_allclose(labels + m.H, t[1:], rtol=0, atol=1e-9)
    assert_identical({n: late[n][1:] for n in NAMES}, r, "FMPy")


@pytest.fixture(scope="module")
def ours_1ms(mirror_ssp):
    return m.inchworm(mirror_ssp, STOP, NAMES, h=0.001)


def assert_mount_physics(t, r):
    """The mount's pose as commanded: piston 30 µm and tip 4 µm at the end, no tilt (b and c
    move alike), no tip before its command."""
    end = t >= 8.0
    assert abs(np.median(r["mount.piston"][end]) - 30e-6) < 0.1e-6
    assert abs(np.median(r["mount.tip"][end]) - 4e-6) < 0.05e-6
    assert np.max(np.abs(r["mount.tilt"])) < 1e-12, "b and c move alike: no tilt"
    assert np.all(np.abs(r["mount.tip"][(t > 0.5) & (t < 4.0)]) < 0.05e-6), "no tip before its command"


def test_at_1_ms_the_loops_sample_at_the_2_ms_instants_as_at_2_ms(ours, ours_1ms):
    """The controllers sample at each 2 ms instant their steps reach (docs/model.md §5), so
    at a 1 ms master step the loops are those of the 2 ms run; only the plants integrate in
    shorter steps. Measured: the encoder counts at the 5000 instants are the 2 ms run's."""
    (t2, two), (t1, one) = ours, ours_1ms
    assert len(t1) == 2 * len(t2) - 1
    np.testing.assert_allclose(t1[::2], t2, rtol=0, atol=1e-9)
    assert_mount_physics(t1, one)
    for x in "abc":
        n = f"plant_{x}.encoder_counts"
        diff = np.abs(one[n][::2] - two[n])
        print(f"{n}: {np.count_nonzero(diff)} of {len(diff)} instants differ from the 2 ms run, at most {diff.max()} count(s)")
        assert diff.max() <= 1 and np.count_nonzero(diff) <= 5, n


def test_ecos_at_1_ms_runs_the_mount_identically(mirror_ssp, ours_1ms, tmp_path, monkeypatch):
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    labels, r = m.ecos(mirror_ssp, STOP, NAMES, parameter_set="default", h=0.001)
    t, o = ours_1ms
    np.testing.assert_allclose(labels, t, rtol=0, atol=1e-9)
    assert_identical({n: o[n][1:] for n in NAMES}, {n: r[n][1:] for n in NAMES}, "Ecos at 1 ms")
    assert_mount_physics(labels, r)


def test_libcosim_at_1_ms_runs_the_mount_with_the_same_counts(mirror_ssp, ours_1ms, tmp_path):
    d = m.unpack_with_first(mirror_ssp, tmp_path / "ssp", {})
    labels, r = m.libcosim(d, STOP, NAMES, h=0.001)
    t, o = ours_1ms
    np.testing.assert_allclose(labels, t[1:], rtol=0, atol=1e-9)
    assert_identical({n: o[n][1:] for n in NAMES}, r, "libcosim at 1 ms", real_atol=1e-15)


def test_inchworm_scenario_mirror_reports_settling_and_pointing(tmp_path):
    p = subprocess.run([str(m.EXE), "scenario", "mirror", "--dist", str(DIST), "--out", str(tmp_path)],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert "pointing RMS" in p.stdout and "settles" in p.stdout, p.stdout
    assert (tmp_path / "mirror.csv").stat().st_size > 0 and (tmp_path / "mirror.png").stat().st_size > 0
    line = [l for l in p.stdout.splitlines() if "pointing RMS" in l][0]
    rms_nrad = float(line.split("pointing RMS")[1].split("nrad")[0])
    assert 0 < rms_nrad < 100, line
