"""`inchworm-optics` on hostile inputs: each case runs the CLI in its own process (`python -m
inchworm_optics` from this tree) with TMPDIR in tmp_path, and asserts a one-line refusal
that names the input and the accepted range (exit 2, no traceback), and an empty TMPDIR
afterwards. The checks come before numpy, poppy or FMPy is imported, so a refusal takes a
fraction of a second. The cases of --param, --out and a signal during a run need
dist/MirrorMount.ssp; the empty parked window of an analog run is in test_optics.py (its
short run)."""
import json
import math
import os
import pathlib
import signal
import subprocess
import sys
import threading

import pytest

from conftest import DIST, ROOT

# INCHWORM_OPTICS_SRC: another copy of the package to hold to the same cases (e.g. an older
# one, to see them fail).
SRC = pathlib.Path(os.environ.get("INCHWORM_OPTICS_SRC", ROOT / "python" / "inchworm_optics"))
sys.path.insert(0, str(SRC))

SSP = DIST / "MirrorMount.ssp"
#: A small, short run, so that an input the CLI accepted by mistake fails fast instead of
#: simulating 10 s; each case's own arguments come after it (argparse keeps the last).
SMALL = ["--pupil", "8", "--fov", "8", "--duration", "0.1", "--regulation", "0", "--held-from", "0",
         "--runs", "stepping,drift"]


@pytest.fixture
def tmp(tmp_path):
    """The CLI's TMPDIR; checked empty after the case."""
    t = tmp_path / "tmpdir"
    t.mkdir()
    yield t
    assert sorted(p.name for p in t.iterdir()) == [], "a temporary folder was left behind"


@pytest.fixture
def ssp():
    if not SSP.is_file():
        pytest.fail(f"{SSP} is missing: run `cargo run --release -p fmu-build` first")
    return SSP


def env(tmp):
    return dict(os.environ, TMPDIR=str(tmp), PYTHONPATH=os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")]))


def optics(tmp, *args, dist=DIST, timeout=300):
    return subprocess.run([sys.executable, "-m", "inchworm_optics", "--dist", str(dist),
                           "--out", str(tmp.parent / "out"), *map(str, args)],
                          capture_output=True, text=True, timeout=timeout, env=env(tmp), cwd=tmp.parent)


def refused(r, *words):
    """The one stderr line of a refusal, which names each of `words`."""
    assert "Traceback" not in r.stderr, r.stderr[-3000:]
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("inchworm-optics: error: "), r.stderr[-3000:]
    assert 1 <= r.returncode <= 127, f"exit status {r.returncode}"
    for w in words:
        assert w in lines[0], f"{w!r} not in {lines[0]!r}"
    return lines[0]


RATE = "0 < value ≤ 500 Hz"
GRID = "an integer, 8 ≤ value ≤ 1024 px"
DURATION = "0 < value ≤ 3600 s"
GAIN = "0 < value < 2"


@pytest.mark.parametrize("args,words", [
    (["--frame-rate", "0"], ["--frame-rate 0", RATE]),
    (["--frame-rate", "-20"], ["--frame-rate -20", RATE]),
    (["--frame-rate", "nan"], ["--frame-rate nan", RATE]),
    (["--frame-rate", "inf"], ["--frame-rate inf", RATE]),
    (["--frame-rate", "1e9"], ["--frame-rate 1e+09", RATE]),
    (["--guide-rate", "0"], ["--guide-rate 0", RATE]),
    (["--pupil", "0"], ["--pupil 0", GRID]),
    (["--pupil", "65536"], ["--pupil 65536", GRID]),
    (["--fov", "-3"], ["--fov -3", GRID]),
    (["--duration", "0"], ["--duration 0", DURATION]),
    (["--duration", "-1"], ["--duration -1", DURATION]),
    (["--duration", "nan"], ["--duration nan", DURATION]),
    (["--duration", "inf"], ["--duration inf", DURATION]),
    (["--duration", "1e307"], ["--duration 1e+307", DURATION]),
    (["--drift", "1,2,3"], ["--drift 1,2,3", "X,Y"]),
    (["--drift", "nan,0"], ["--drift nan,0", "X,Y"]),
    (["--offset", "0,inf"], ["--offset 0,inf", "X,Y"]),
    (["--guide-gain", "0"], ["--guide-gain 0", GAIN]),
    (["--guide-gain-analog", "2"], ["--guide-gain-analog 2", GAIN]),
    (["--guide-photons", "nan"], ["--guide-photons nan", "0 ≤ value ≤ 1e+15 e-"]),
    (["--read-noise", "-1"], ["--read-noise -1", "value ≥ 0 e-"]),
    (["--seed", "-1"], ["--seed -1", "an integer, value ≥ 0"]),
    (["--bound", "0"], ["--bound 0", "value > 0 mas"]),
    (["--guide-pause", "-0.1"], ["--guide-pause -0.1", "value ≥ 0 s"]),
    (["--runs", ""], ["--runs", "stepping,analog,drift,guided,guided-analog"]),
    (["--pupil", "1e3"], ["--pupil", "invalid int value"]),
    # A run shorter than its windows: regulation from 8 s (the default) in a 1 s run; a hold
    # window after the last frame; a run shorter than one frame.
    (["--duration", "1", "--regulation", "8"], ["--regulation 8", "0 ≤ value ≤ 0.975 s"]),
    (["--duration", "1", "--held-from", "5"], ["--held-from 5", "0 ≤ value ≤ 0.975 s"]),
    (["--duration", "0.04"], ["--duration 0.04", "one 0.05 s frame", "value ≥ 0.05 s"]),
    # The star off the 8-px detector (103.1 mas pixels: ±412.5 mas).
    (["--offset", "500,0"], ["--offset 500,0", "≤ 412.5 mas"]),
    (["--drift", "5000,0"], ["--drift 5000,0", "≤ 412.5 mas"]),
    # Memory: 1024-px pupil samples, 5000 to a frame.
    (["--pupil", "1024", "--frame-rate", "0.1", "--duration", "20"], ["GiB", "above the 4 GiB bound"]),
])
def test_an_argument_out_of_its_range_is_refused_in_one_line(tmp, args, words):
    refused(optics(tmp, *SMALL, *args), *words)


def prescription(tmp, text):
    path = tmp.parent / "rx.json"
    path.write_text(text)
    return path


@pytest.mark.parametrize("fields,words", [
    ({"aperture_m": 0}, ["aperture_m 0", "0.001 ≤ value ≤ 100 m"]),
    ({"aperture_m": -0.5}, ["aperture_m -0.5", "0.001 ≤ value ≤ 100 m"]),
    ({"primary_focal_length_m": 0}, ["primary_focal_length_m 0", "0.001 ≤ value ≤ 1000 m"]),
    ({"wavelength_m": 0}, ["wavelength_m 0", "1e-08 ≤ value ≤ 0.001 m"]),
    ({"wavelength_m": -550e-9}, ["wavelength_m -5.5e-07", "1e-08 ≤ value ≤ 0.001 m"]),
    ({"pixel_m": 0}, ["pixel_m 0", "1e-07 ≤ value ≤ 0.01 m"]),
    ({"secondary_magnification": 0}, ["secondary_magnification 0", "0 < value ≤ 1000"]),
    ({"secondary_magnification": -5}, ["secondary_magnification -5", "0 < value ≤ 1000"]),
    ({"obscuration_m": 0.5}, ["obscuration_m 0.5", "0 ≤ value < 0.5 m"]),
    ({"obscuration_m": 0.6}, ["obscuration_m 0.6", "0 ≤ value < 0.5 m"]),
    ({"back_focal_distance_m": 5.0}, ["back_focal_distance_m 5", "-1 < value < 5 m"]),
    ({"aperture_m": "0.5"}, ["aperture_m '0.5'", "0.001 ≤ value ≤ 100 m"]),
    ({"aperture": 0.5}, ["unknown prescription keys ['aperture']"]),
    # Bounded where a product of them would overflow a float (an OverflowError before).
    ({"primary_focal_length_m": 1e308}, ["primary_focal_length_m 1e+308", "0.001 ≤ value ≤ 1000 m"]),
    ({"secondary_magnification": 1e300}, ["secondary_magnification 1e+300", "0 < value ≤ 1000"]),
    ({"focus_piston_m": 1e300}, ["focus_piston_m 1e+300", "-1 ≤ value ≤ 1 m"]),
])
def test_a_prescription_field_out_of_its_range_is_refused(tmp, fields, words):
    path = prescription(tmp, json.dumps(fields))
    refused(optics(tmp, *SMALL, "--prescription", path), str(path), *words)


@pytest.mark.parametrize("text,words", [
    ('{"aperture_m": NaN}', ["aperture_m nan", "0.001 ≤ value ≤ 100 m"]),
    ('{"obscuration_m": Infinity}', ["obscuration_m inf"]),
    ("[0.5]", ["not a JSON object"]),
    ('{"aperture_m": ', ["not a JSON object"]),
])
def test_a_prescription_that_is_not_finite_numbers_is_refused(tmp, text, words):
    path = prescription(tmp, text)
    refused(optics(tmp, *SMALL, "--prescription", path), str(path), *words)


def test_a_missing_prescription_is_refused(tmp):
    refused(optics(tmp, *SMALL, "--prescription", tmp.parent / "none.json"), "--prescription", "none.json")


def test_an_annulus_thinner_than_a_grid_pixel_is_refused(tmp):
    # An 8-px pupil of 0.5 m: obscuration ≤ 0.5 (1 − 2/8) = 0.375 m.
    path = prescription(tmp, json.dumps({"obscuration_m": 0.4}))
    refused(optics(tmp, *SMALL, "--prescription", path), "obscuration_m 0.4", "0 ≤ value ≤ 0.375 m", "--pupil 8")


@pytest.mark.parametrize("args", [
    ["--frame-rate", "500", "--guide-rate", "500", "--duration", "0.002", "--held-from", "0.001"],
    ["--pupil", "1024", "--fov", "8", "--runs", "stepping"],
    ["--guide-gain", "1.99", "--guide-photons", "0", "--read-noise", "0", "--seed", "0", "--guide-pause", "0"],
    ["--duration", "1", "--regulation", "0.975", "--held-from", "0.975"],
    ["--offset", "400,-400", "--drift=-8000,0"],
])
def test_the_edges_of_the_ranges_are_accepted(tmp, args):
    # Past every argument check to the missing SSP: the arguments themselves were taken.
    line = refused(optics(tmp, *SMALL, *args, dist=tmp.parent / "nodist"), "nodist", "is missing")
    assert "accepted" not in line


def test_the_edges_of_the_prescription_are_accepted(tmp):
    path = prescription(tmp, json.dumps({"obscuration_m": 0.375, "back_focal_distance_m": -0.99, "focus_piston_m": -1}))
    line = refused(optics(tmp, *SMALL, "--prescription", path, dist=tmp.parent / "nodist"), "is missing")
    assert "accepted" not in line


def test_a_prescription_is_checked_when_made_in_python_too():
    from inchworm_optics import inputs
    from inchworm_optics.telescope import Prescription

    with pytest.raises(inputs.InputError, match="aperture_m nan: accepted a finite number, 0.001 ≤ value ≤ 100 m"):
        Prescription(aperture_m=math.nan)
    with pytest.raises(inputs.InputError, match="obscuration_m 0.5: accepted 0 ≤ value < 0.5 m"):
        Prescription(obscuration_m=0.5)
    assert Prescription().aperture_m == 0.5


def test_docs_list_every_range():
    from inchworm_optics import inputs

    text = (ROOT / "docs" / "optics.md").read_text()
    ranges = [v for v in vars(inputs).values() if isinstance(v, inputs.Range)] + list(inputs.PRESCRIPTION.values())
    missing = sorted({str(r) for r in ranges if str(r) not in text})
    assert not missing, f"docs/optics.md does not state the ranges {missing}"
    assert f"{inputs.MEMORY_BYTES >> 30} GiB" in text


# ---- cases that read the SSP ----
@pytest.mark.parametrize("param,words", [
    ("nosuch.x=1", ["--param nosuch.x=1", "no variable `nosuch.x`"]),
    ("mount.nosuch=1", ["--param mount.nosuch=1", "no variable `mount.nosuch`"]),
    ("mount.radius", ["--param mount.radius", "COMPONENT.VARIABLE=VALUE"]),
    ("mount.radius=abc", ["--param mount.radius=abc", "0.0001 ≤ value ≤ 10"]),
    ("mount.radius=nan", ["--param mount.radius=nan", "0.0001 ≤ value ≤ 10"]),
    ("mount.radius=20", ["--param mount.radius=20", "0.0001 ≤ value ≤ 10"]),
    ("reference_a.positions[1]=inf", ["--param reference_a.positions[1]=inf", "a finite number"]),
    ("controller_a.analog=2", ["--param controller_a.analog=2", "Boolean"]),
])
def test_a_bad_param_is_refused_before_anything_is_unpacked(tmp, ssp, param, words):
    refused(optics(tmp, *SMALL, "--param", param), *words)


def test_a_param_the_fmus_refuse_is_refused_before_the_first_run(tmp, ssp):
    # Analog mode needs deadband 0 (docs/controller-design.md): the controller FMU refuses
    # the pair at initialization; the stepping run, first, must not have run.
    r = optics(tmp, *SMALL, "--runs", "stepping,analog", "--param", "controller_a.deadband=1e-6")
    refused(r, "--param controller_a.deadband=1e-6", "refused them at initialization in analog mode")
    assert "stepping (regulation" not in r.stdout, r.stdout


def test_mount_cosim_leaves_no_folder_when_its_start_fails(ssp, tmp, monkeypatch):
    import tempfile

    from inchworm_optics.cosim import MountCosim

    monkeypatch.setattr(tempfile, "tempdir", str(tmp))
    with pytest.raises(KeyError, match="nosuch"):
        MountCosim(ssp, {"mount.nosuch": 1.0})


def _file(p):
    p.write_text("x")
    return p


def _dangling(p):
    p.symlink_to(p.parent / "nowhere")
    return p


def _loop(p):
    p.symlink_to(p)
    return p


def _taken(p):
    (p / "optics-summary.csv").mkdir(parents=True)
    return p


def _under_a_file(p):
    p.write_text("x")
    return p / "sub"


@pytest.mark.parametrize("make,words", [
    (_file, ["a file, not a folder"]),
    (_dangling, ["a symlink to", "nowhere", "which does not exist"]),
    (_loop, ["a symlink loop"]),
    (_taken, ["optics-summary.csv is not a file it can write"]),
    (_under_a_file, ["cannot write the results there"]),
])
def test_an_out_it_cannot_write_into_is_refused(tmp, ssp, make, words):
    out = make(tmp.parent / "out")
    r = subprocess.run([sys.executable, "-m", "inchworm_optics", "--dist", str(DIST), *SMALL, "--out", str(out)],
                       capture_output=True, text=True, timeout=300, env=env(tmp), cwd=tmp.parent)
    refused(r, f"--out {out}", *words)
    if make is _file:
        assert out.read_text() == "x", "the file given as --out was changed"


@pytest.mark.parametrize("sig,status,line", [
    (signal.SIGTERM, 128 + signal.SIGTERM, "inchworm-optics: stopped by SIGTERM"),
    (signal.SIGINT, 130, "inchworm-optics: interrupted"),
])
def test_a_signal_during_a_run_removes_its_folder(tmp, ssp, sig, status, line):
    p = subprocess.Popen([sys.executable, "-m", "inchworm_optics", "--dist", str(DIST), "--out", str(tmp.parent / "out"),
                          *SMALL, "--duration", "30", "--runs", "stepping"],
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env(tmp), cwd=tmp.parent,
                         # A shell's background job starts with SIGINT ignored, which Python keeps;
                         # the case is about an interactive Ctrl-C, so the child takes it as one.
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    guard = threading.Timer(600, p.kill)  # a hang fails the case instead of the suite
    guard.start()
    try:
        # The first progress line: the run's loop has started, its folder unpacked.
        seen = []
        for text in p.stderr:
            seen.append(text)
            if text.startswith("  stepping:"):
                break
        assert seen and seen[-1].startswith("  stepping:"), "".join(seen)
        assert [x.name for x in tmp.iterdir() if x.name.startswith("inchworm-optics-")], "no unpacked folder seen"
        p.send_signal(sig)
        rest = p.stderr.read()
        assert p.wait() == status, rest
    finally:
        guard.cancel()
        p.kill()
    assert "Traceback" not in rest, rest
    assert rest.strip().splitlines()[-1] == line, rest
