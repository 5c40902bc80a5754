"""The co-phasing scenario end to end on a small system (scripts/cophase.sh's path, docs/segments.md):
`fmu-build segmented --rings 1 --cophase --controller C` → `inchworm run --poses` → the
optics of python/inchworm_segments → the side-by-side table. Seven segments, 1.2 s, a
32-pixel pupil.

* The poses' first row is every segment's drawn error as the SSP binds it to its mount
  (`seg{k}_mount.default.ssv`), to the bit, and the same for both controllers (one seed,
  one draw); so the first sample's co-phasing error is the aperture RMS of the drawn
  pistons' wavefront (−2 piston), computed here from the bindings.
* Analog mode phases the mirror: over the last frame every sample's co-phasing error is
  below two encoder counts of wavefront (a segment's piston is the mean of three runners,
  each held to the encoder's 1.2 nm; the wavefront doubles it).
* The stepping gait is still walking at 1.2 s (its 5 Hz iterations), so its error there
  lies between the analog one and the start.
"""
import csv
import math
import os
import pathlib
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

from conftest import ROOT
from inchworm_variables import InchwormMount as Mount, InchwormPlant as Plant

sys.path.insert(0, str(ROOT / "python" / "inchworm_segments"))
from inchworm_segments import __main__ as cli  # noqa: E402
from inchworm_segments import compare  # noqa: E402
from inchworm_segments import frames as F  # noqa: E402
from inchworm_segments.config import Telescope  # noqa: E402

FMU_BUILD = ROOT / "target" / "release" / "fmu-build"
EXE = pathlib.Path(os.environ.get("INCHWORM_BIN", ROOT / "target" / "release" / "inchworm"))
#: The encoder's resolution (crates/board: ENCODER_RESOLUTION), what the end is held to.
Q_ENC = 1.2e-9
STOP = "1.2"
SMALL = ["--pupil-px", "32", "--supersampling", "2", "--frame-ms", "50", "--workers", "2"]
SEGMENTS = 7


def _outputs():
    out = []
    for k in range(SEGMENTS):
        out += [a for v in (Mount.PISTON, Mount.TIP, Mount.TILT) for a in ("--output", f"seg{k}_mount.{v}")]
        out += [a for x in "abc" for v in (Plant.DAC_EARTH, Plant.DAC_NONEARTH, Plant.DAC_EXTENSION)
                for a in ("--output", f"seg{k}_controller_{x}.{v}")]
    return out


def _run(cmd):
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 0, p.stdout + p.stderr
    return p.stdout


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    assert FMU_BUILD.exists() and EXE.exists(), "build first: cargo run --release -p fmu-build; cargo build --release"
    assert (ROOT / "dist" / "InchwormMount.fmu").exists(), "build dist/ first: cargo run --release -p fmu-build"
    d = tmp_path_factory.mktemp("cophase")
    out = {}
    for c in ("stepping", "analog"):
        ssp = d / f"{c}.ssp"
        _run([FMU_BUILD, "segmented", "--rings", "1", "--seed", "4", "--cophase", "--controller", c, "--out", ssp])
        printed = _run([EXE, "run", ssp, "--jobs", "2", "--stop-time", STOP, *_outputs(),
                        "--out", d / f"{c}-run.csv", "--poses", d / f"{c}-poses.csv"])
        assert f"({SEGMENTS} mounts)" in printed
        assert cli.main(["--poses", str(d / f"{c}-poses.csv"), "--out", str(d / c), "--regulation-from", "0.8",
                         *SMALL]) == 0
        out[c] = (ssp, d / f"{c}-poses.csv", d / c)
    return d, out


def _drawn(ssp):
    """Each segment's mount binding, name → value, read from the SSP's parameter sets."""
    ns = {"ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues"}
    with zipfile.ZipFile(ssp) as z:
        drawn = []
        for k in range(SEGMENTS):
            root = ET.fromstring(z.read(f"resources/seg{k}_mount.default.ssv"))
            drawn.append({p.get("name"): float(p.find("ssv:Real", ns).get("value"))
                          for p in root.iter(f"{{{ns['ssv']}}}Parameter")})
    return drawn


def _rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_the_first_sample_is_the_drawn_errors(runs):
    _, out = runs
    first = {c: _rows(out[c][1])[0] for c in out}
    drawn = _drawn(out["stepping"][0])
    assert drawn == _drawn(out["analog"][0])
    pistons = []
    for k, d in enumerate(drawn):
        assert list(d) == [Mount.PISTON_OFFSET, Mount.TIP_OFFSET, Mount.TILT_OFFSET]
        assert abs(d[Mount.PISTON_OFFSET]) <= 10e-6 and max(abs(d[Mount.TIP_OFFSET]), abs(d[Mount.TILT_OFFSET])) <= 5e-6
        for c in out:
            row = first[c]
            # The mount's pose before any step is its offset, to the bit: same SI units and
            # the same convention (tip = dz/dy, tilt = dz/dx) as the optics' CSV.
            assert [float(row[f"seg{k}_{n}"]) for n in ("piston_m", "tip_rad", "tilt_rad")] == \
                [d[Mount.PISTON_OFFSET], d[Mount.TIP_OFFSET], d[Mount.TILT_OFFSET]]
            assert row["parked"] == "0"
        pistons.append(d[Mount.PISTON_OFFSET])
    # The first sample's co-phasing error: the aperture-weighted RMS of the wavefront's
    # pistons −2 p_k about their mean, from the drawn values.
    w = F.optics_for(Telescope(pupil_px=32, supersampling=2)).segment_weights
    o = -2.0 * np.array(pistons)
    sigma = math.sqrt(float(np.sum(w * (o - np.sum(w * o)) ** 2)))
    assert 1e-6 < sigma < 20e-6
    for c in out:
        first_sample = _rows(out[c][2] / "segments-samples.csv")[0]
        assert float(first_sample["cophasing_rms_nm"]) == pytest.approx(sigma * 1e9, rel=1e-9)


def test_analog_mode_phases_the_mirror_to_the_encoder_and_stepping_is_on_its_way(runs):
    _, out = runs
    frame = 25  # samples of 50 ms
    last = {c: np.array([float(r["cophasing_rms_nm"]) for r in _rows(out[c][2] / "segments-samples.csv")][-frame:])
            for c in out}
    start = float(_rows(out["analog"][2] / "segments-samples.csv")[0]["cophasing_rms_nm"])
    assert np.all(last["analog"] < 2 * Q_ENC * 1e9), last["analog"]
    assert np.all(last["stepping"] > last["analog"].max())
    assert np.all(last["stepping"] < start / 10), (last["stepping"], start)
    # Analog mode holds every actuator from the regulation's start on: all parked.
    numbers = compare.summary(out["analog"][2])
    assert numbers["regulation_parked_samples"] == numbers["regulation_samples"] == 200
    assert numbers["cophasing_rms_regulation_parked_nm"] < 2 * Q_ENC * 1e9
    # Near phased, Maréchal: 1 − Strehl ≈ (2π σ/λ)², a few 1e-5 at most here.
    assert 1 - numbers["strehl_mean_regulation"] < 1e-3


def test_the_table_sets_the_controllers_side_by_side(runs, capsys):
    d, out = runs
    assert compare.main([f"{c}={out[c][2]}" for c in out] + ["--out", str(d / "side")]) == 0
    printed = capsys.readouterr().out
    assert printed.splitlines()[0] == "| from 0.8 s to the end | stepping | analog |"
    table = {r["name"]: r for r in _rows(d / "side" / "cophase-table.csv")}
    for c in out:
        numbers = compare.summary(out[c][2])
        for key, _, _ in compare.ROWS:
            assert float(table[key][c]) == numbers[key], (c, key)
        samples = _rows(out[c][2] / "segments-samples.csv")
        reg = [float(r["cophasing_rms_nm"]) for r in samples if float(r["t_s"]) >= 0.8 - 1e-9]
        assert numbers["cophasing_rms_regulation_nm"] == pytest.approx(math.sqrt(np.mean(np.square(reg))), rel=1e-9)
    assert (d / "side" / "cophase-timeseries.png").stat().st_size > 0
    assert compare.main([f"stepping={out['stepping'][2]}", "bad", "--out", str(d / "x")]) == 2
