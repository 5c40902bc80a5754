"""python/inchworm_segments on inputs out of their ranges: every option of the command, every
value of the poses CSV, every argument of the package's functions (`config.Telescope`,
`poses.synthetic`, `poses.check_poses`, `frames.run`, `frames.frame_batch`,
`figures.summary`) and the memory bound. Each refusal names the input, its value, the
accepted range and its unit, before any optics is computed: the command's is one line on
stderr and exit status 2 (no traceback), the functions' an `InputError` (a ValueError).
hcipy is never imported here: every refusal comes first."""
import io
import math
import re
import sys
import types

import numpy as np
import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT / "python" / "inchworm_segments"))
from inchworm_segments import __main__ as cli  # noqa: E402
from inchworm_segments import compare, figures  # noqa: E402
from inchworm_segments import frames as F  # noqa: E402
from inchworm_segments import poses as P  # noqa: E402
from inchworm_segments.config import InputError, Telescope, memory_bytes  # noqa: E402


def refused(capsys, argv, *words):
    """The command's one-line refusal, exit 2, naming each of `words`."""
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") == 1 and err.startswith("inchworm-segments: error: "), err
    for w in words:
        assert w in err, f"{w!r} not in {err!r}"
    return err


SYNTHETIC = "0 < value ≤ 3600 s"
FRAME = "0 < value ≤ 3.6e+06 ms"


@pytest.mark.parametrize("args,words", [
    (["--synthetic", "0"], ["--synthetic 0", SYNTHETIC]),
    (["--synthetic", "-1"], ["--synthetic -1", SYNTHETIC]),
    (["--synthetic", "nan"], ["--synthetic nan", "a finite number", SYNTHETIC]),
    (["--synthetic", "inf"], ["--synthetic inf", SYNTHETIC]),
    (["--synthetic", "3601"], ["--synthetic 3601", SYNTHETIC]),
    (["--rings", "0"], ["--rings 0", "an integer, 1 ≤ value ≤ 6 rings"]),
    (["--rings", "7"], ["--rings 7", "an integer, 1 ≤ value ≤ 6 rings"]),
    (["--seed", "-1"], ["--seed -1", "an integer, value ≥ 0"]),
    (["--frame-ms", "0"], ["--frame-ms 0", FRAME]),
    (["--frame-ms", "-2"], ["--frame-ms -2", FRAME]),
    (["--frame-ms", "nan"], ["--frame-ms nan", FRAME]),
    (["--frame-ms", "inf"], ["--frame-ms inf", FRAME]),  # an OverflowError traceback before
    (["--frame-ms", "1e9"], ["--frame-ms 1e+09", FRAME]),
    (["--frame-ms", "3"], ["--frame-ms 3", "a whole number of 2 ms samples"]),
    (["--frame-ms", "1"], ["--frame-ms 1", "a whole number of 2 ms samples, at least one"]),
    (["--workers", "0"], ["--workers 0", "an integer, 1 ≤ value ≤ 256 processes"]),
    (["--workers", "100000"], ["--workers 100000", "1 ≤ value ≤ 256 processes"]),
    (["--regulation-from", "-1"], ["--regulation-from -1", "value ≥ 0 s"]),
    (["--regulation-from", "nan"], ["--regulation-from nan", "a finite number, value ≥ 0 s"]),
    (["--synthetic", "0.2", "--regulation-from", "5"], ["--regulation-from 5", "0 ≤ value ≤ 0.198 s"]),
    (["--flat-to-flat-m", "0"], ["--flat-to-flat-m 0", "0.001 ≤ value ≤ 20 m"]),
    (["--flat-to-flat-m", "21"], ["--flat-to-flat-m 21", "0.001 ≤ value ≤ 20 m"]),
    (["--flat-to-flat-m", "nan"], ["--flat-to-flat-m nan", "0.001 ≤ value ≤ 20 m"]),
    (["--gap-m", "-0.001"], ["--gap-m -0.001", "0 ≤ value ≤ 1 m"]),
    (["--gap-m", "2"], ["--gap-m 2", "0 ≤ value ≤ 1 m"]),
    (["--gap-m", "0.2"], ["gap_m 0.2", "0 ≤ value < 0.15 m", "below flat_to_flat_m"]),
    (["--wavelength-m", "0"], ["--wavelength-m 0", "1e-07 ≤ value ≤ 2e-05 m"]),
    (["--wavelength-m", "1"], ["--wavelength-m 1", "1e-07 ≤ value ≤ 2e-05 m"]),
    (["--wavelength-m", "inf"], ["--wavelength-m inf", "1e-07 ≤ value ≤ 2e-05 m"]),
    (["--pupil-px", "15"], ["--pupil-px 15", "an integer, 16 ≤ value ≤ 1024 px"]),
    (["--pupil-px", "1025"], ["--pupil-px 1025", "an integer, 16 ≤ value ≤ 1024 px"]),
    (["--pupil-px", "1e3"], ["--pupil-px", "invalid int value"]),
    (["--rings", "3", "--pupil-px", "16"], ["pupil_px 16", "≤ value ≤ 1024 px", "a segment at least 4 pixels across"]),
    (["--supersampling", "0"], ["--supersampling 0", "an integer, 1 ≤ value ≤ 16 sub-pixels"]),
    (["--supersampling", "17"], ["--supersampling 17", "1 ≤ value ≤ 16 sub-pixels"]),
    (["--q", "0"], ["--q 0", "an integer, 1 ≤ value ≤ 16 px per λ/D"]),
    (["--q", "17"], ["--q 17", "1 ≤ value ≤ 16 px per λ/D"]),
    (["--fov-lambda-d", "1"], ["--fov-lambda-d 1", "2 ≤ value ≤ 200 λ/D"]),
    (["--fov-lambda-d", "201"], ["--fov-lambda-d 201", "2 ≤ value ≤ 200 λ/D"]),
    (["--fov-lambda-d", "nan"], ["--fov-lambda-d nan", "2 ≤ value ≤ 200 λ/D"]),
    (["--dark-inner-lambda-d", "-1"], ["--dark-inner-lambda-d -1", "0 ≤ value ≤ 200 λ/D"]),
    (["--dark-outer-lambda-d", "0.1"], ["--dark-outer-lambda-d 0.1", "0.5 ≤ value ≤ 200 λ/D"]),
    (["--dark-outer-lambda-d", "201"], ["--dark-outer-lambda-d 201", "0.5 ≤ value ≤ 200 λ/D"]),
    (["--dark-outer-lambda-d", "13"], ["dark_outer_lambda_d 13", "3 < value ≤ 12 λ/D"]),
    (["--dark-inner-lambda-d", "10", "--dark-outer-lambda-d", "5"], ["dark_outer_lambda_d 5", "10 < value ≤ 12 λ/D"]),
    # 1024 px across D, 16 px per λ/D out to 200 λ/D: a 6400² focal plane, 133 GiB of frames.
    (["--pupil-px", "1024", "--q", "16", "--fov-lambda-d", "200", "--dark-outer-lambda-d", "100", "--synthetic",
      "0.05", "--workers", "2"], ["GiB of arrays, above the 4 GiB bound"]),
    # An hour of 127 segments: 1.8 M samples of 381 poses.
    (["--synthetic", "3600", "--rings", "6", "--workers", "1"], ["127 segments", "above the 4 GiB bound"]),
    (["--synthetic", "0.02"], ["10 samples: accepted at least one frame", "25 samples of --frame-ms 50"]),
])
def test_an_option_out_of_its_range_is_refused_in_one_line(capsys, tmp_path, args, words):
    refused(capsys, [*args, "--out", str(tmp_path / "out")], *words)
    assert not (tmp_path / "out").exists(), "nothing is written before the checks pass"


def poses_csv(tmp_path, rows, segments=7, parked=True):
    head = ",".join(P.header(segments, parked))
    path = tmp_path / "poses.csv"
    path.write_text(head + "\n" + "".join(r + "\n" for r in rows))
    return path


def row(t="0", values=None, parked="1", segments=7):
    v = ["0"] * (3 * segments)
    for k, x in (values or {}).items():
        v[k] = x
    return ",".join([t, *v, parked])


RANGE_M = "-1 ≤ value ≤ 1 m"
RANGE_RAD = "-1 ≤ value ≤ 1 rad"


@pytest.mark.parametrize("rows,words", [
    ([row(t="-1")], ["row 2: time -1", "0 ≤ value ≤ 1e+06 s"]),
    ([row(t="2e6")], ["row 2: time 2e+06", "0 ≤ value ≤ 1e+06 s"]),
    ([row(values={0: "2"})], ["row 2: seg0_piston_m 2", RANGE_M]),
    ([row(values={3: "-1.5"})], ["row 2: seg1_piston_m -1.5", RANGE_M]),
    ([row(values={0: "1e308"})], ["row 2: seg0_piston_m 1e+308", RANGE_M]),
    ([row(values={0: "nan"})], ["row 2: seg0_piston_m nan", "a finite number", RANGE_M]),
    ([row(values={1: "inf"})], ["row 2: seg0_tip_rad inf", "a finite number", RANGE_RAD]),
    ([row(values={20: "-1e300"})], ["row 2: seg6_tilt_rad -1e+300", RANGE_RAD]),
    ([row(values={4: "abc"})], ["row 2: seg1_tip_rad 'abc'", RANGE_RAD]),
    ([row(values={4: "1_0"})], ["row 2: seg1_tip_rad '1_0'", RANGE_RAD]),
    ([row(values={4: "١"})], ["row 2: seg1_tip_rad '١'", RANGE_RAD]),
    ([row(parked="2")], ["row 2: parked 2: accepted 0 or 1"]),
    ([row(parked="0.5")], ["row 2: parked 0.5: accepted 0 or 1"]),
    ([row(), row(t="0.004")], ["row 3: time step 0.004 s", "the engine's 0.002 s sample step"]),
    ([row() + ",0"], ["row 2 has 24 columns, the header 23"]),
    ([], ["no samples"]),
])
def test_a_poses_value_out_of_its_range_is_refused_naming_the_file_and_row(capsys, tmp_path, rows, words):
    src = poses_csv(tmp_path, rows)
    refused(capsys, ["--poses", str(src), "--out", str(tmp_path / "out")], str(src), *words)


def test_a_poses_csv_that_is_not_text_or_too_long_is_refused(capsys, tmp_path):
    src = tmp_path / "poses.csv"
    src.write_bytes(b"time\xff\n")
    refused(capsys, ["--poses", str(src), "--out", str(tmp_path / "o")], str(src), "not UTF-8 text")
    src.write_text("time," + "x" * (P.MAX_LINE_CHARS + 1) + "\n")
    refused(capsys, ["--poses", str(src), "--out", str(tmp_path / "o")], "line 1: longer than 65536 characters")
    with open(src, "wb") as f:
        f.truncate(P.MAX_CSV_BYTES + 1)
    refused(capsys, ["--poses", str(src), "--out", str(tmp_path / "o")], f"{P.MAX_CSV_BYTES + 1} bytes: accepted at most")


def test_a_poses_csv_past_the_values_bound_is_refused_as_it_is_read(monkeypatch, tmp_path):
    monkeypatch.setattr(P, "MAX_POSE_VALUES", 50)
    src = poses_csv(tmp_path, [row(), row(t="0.002"), row(t="0.004")])
    with pytest.raises(InputError, match="row 4: more than the 50 values"):
        P.read_csv(src)


def test_rings_and_no_centre_are_refused_with_poses(capsys, tmp_path):
    src = poses_csv(tmp_path, [row()])
    refused(capsys, ["--poses", str(src), "--rings", "2", "--out", str(tmp_path / "o")], "--rings and --no-centre")


@pytest.mark.parametrize("field,value,words", [
    ("rings", 0, "rings 0: accepted an integer, 1 ≤ value ≤ 6 rings"),
    ("rings", 2.5, "rings 2.5: accepted an integer"),
    ("rings", "2", "rings '2': accepted an integer"),
    ("rings", True, "rings True: accepted an integer"),
    ("flat_to_flat_m", math.nan, "flat_to_flat_m nan: accepted a finite number, 0.001 ≤ value ≤ 20 m"),
    ("flat_to_flat_m", 10**400, "flat_to_flat_m an integer of 401 digits: accepted 0.001 ≤ value ≤ 20 m"),
    ("gap_m", -1e-3, "gap_m -0.001: accepted 0 ≤ value ≤ 1 m"),
    ("wavelength_m", 1e-6 * 21, "wavelength_m 2.1e-05: accepted 1e-07 ≤ value ≤ 2e-05 m"),
    ("pupil_px", 2000, "pupil_px 2000: accepted an integer, 16 ≤ value ≤ 1024 px (pixels across D)"),
    ("pupil_px", 48.5, "pupil_px 48.5: accepted an integer"),
    ("supersampling", 0, "supersampling 0: accepted an integer, 1 ≤ value ≤ 16 sub-pixels"),
    ("q", 17, "q 17: accepted an integer, 1 ≤ value ≤ 16 px per λ/D"),
    ("fov_lambda_d", math.inf, "fov_lambda_d inf: accepted a finite number, 2 ≤ value ≤ 200 λ/D"),
    ("dark_inner_lambda_d", -0.5, "dark_inner_lambda_d -0.5: accepted 0 ≤ value ≤ 200 λ/D"),
    ("dark_outer_lambda_d", 0.25, "dark_outer_lambda_d 0.25: accepted 0.5 ≤ value ≤ 200 λ/D"),
    ("centre", 1, "centre 1: accepted true or false"),
])
def test_a_telescope_field_out_of_its_range_is_refused(field, value, words):
    with pytest.raises(InputError, match=re.escape(words)):
        Telescope(**{field: value})


def test_a_telescopes_integers_are_stored_as_ints():
    tel = Telescope(pupil_px=np.int64(48), q=2.0)
    assert tel.pupil_px == 48 and type(tel.pupil_px) is int and type(tel.q) is int


@pytest.mark.parametrize("kwargs,words", [
    ({"segment_count": 5}, "5 segments: accepted 3 R (R + 1) + 1"),
    ({"segment_count": 7.5}, "segment_count 7.5: accepted an integer"),
    ({"duration_s": 0}, "duration_s 0: accepted 0 < value ≤ 3600 s"),
    ({"duration_s": math.nan}, "duration_s nan: accepted a finite number, 0 < value ≤ 3600 s"),
    ({"duration_s": 4000}, "duration_s 4000: accepted 0 < value ≤ 3600 s"),
    ({"seed": -1}, "seed -1: accepted an integer, value ≥ 0"),
    ({"seed": 1.5}, "seed 1.5: accepted an integer"),
    ({"start_piston_m": -1e-9}, "start_piston_m -1e-09: accepted 0 ≤ value ≤ 0.001 m"),
    ({"jitter_piston_m": 1.0}, "jitter_piston_m 1: accepted 0 ≤ value ≤ 0.001 m"),
    ({"residual_piston_m": math.inf}, "residual_piston_m inf"),
    ({"start_tilt_rad": 2e-3}, "start_tilt_rad 0.002: accepted 0 ≤ value ≤ 0.001 rad"),
    ({"jitter_tilt_rad": math.nan}, "jitter_tilt_rad nan"),
    ({"residual_tilt_rad": -1.0}, "residual_tilt_rad -1: accepted 0 ≤ value ≤ 0.001 rad"),
    ({"settle_s": 0}, "settle_s 0: accepted 0 < value ≤ 3600 s"),
    ({"segment_count": 127, "duration_s": 3600}, "687600000 values: accepted at most the 67108864 a run's poses may hold"),
])
def test_a_synthetic_run_argument_out_of_its_range_is_refused(kwargs, words):
    kwargs = {"segment_count": 7, **kwargs}
    with pytest.raises(InputError, match=re.escape(words)):
        P.synthetic(kwargs.pop("segment_count"), **kwargs)


T1 = np.array([0.0, 0.002])


@pytest.mark.parametrize("t,poses,parked,words", [
    (T1, np.zeros((2, 7)), None, "poses: times of shape (2,), poses (2, 7)"),
    (T1, np.zeros((3, 7, 3)), None, "poses: times of shape (2,), poses (3, 7, 3)"),
    (T1[:0], np.zeros((0, 7, 3)), None, "at least one sample"),
    (T1, [["x"]], None, "accepted arrays of numbers"),
    (T1, np.zeros((2, 5, 3)), None, "poses: 5 segments"),
    (T1, np.full((2, 7, 3), 2.0), None, "poses: sample 0: seg0_piston_m 2: accepted -1 ≤ value ≤ 1 m"),
    (np.array([0.0, -0.002]), np.zeros((2, 7, 3)), None, "poses: sample 1: time -0.002"),
    (T1, np.zeros((2, 7, 3)), [1, 2], "poses: sample 1: parked 2: accepted 0 or 1"),
    (T1, np.zeros((2, 7, 3)), [1], "poses: parked of shape (1,)"),
    (np.array([0.0, 0.003]), np.zeros((2, 7, 3)), None, "poses: sample 1: time step 0.003 s"),
])
def test_poses_that_are_not_a_runs_are_refused(t, poses, parked, words):
    with pytest.raises(InputError, match=re.escape(words)):
        P.check_poses(t, poses, parked)


def test_poses_out_of_range_are_not_written(tmp_path):
    p = np.zeros((1, 7, 3))
    p[0, 3, 2] = -5.0
    with pytest.raises(InputError, match="sample 0: seg3_tilt_rad -5"):
        P.write_csv(tmp_path / "p.csv", [0.0], p)
    assert list(tmp_path.iterdir()) == []


SMALL = Telescope(pupil_px=48, supersampling=2)


@pytest.mark.parametrize("kwargs,words", [
    ({"telescope": "7 segments"}, "telescope '7 segments'"),
    ({"poses": np.zeros((10, 6, 3))}, "poses of 6 segments: the telescope has 7"),
    ({"poses": np.full((10, 7, 3), np.nan)}, "sample 0: seg0_piston_m nan"),
    ({"frame_samples": 0}, "frame_samples 0: accepted an integer, 1 ≤ value ≤ 1800000 samples"),
    ({"frame_samples": 2.5}, "frame_samples 2.5: accepted an integer"),
    ({"frame_samples": 11}, "10 samples: accepted at least one frame of 11"),
    ({"frames_per_task": 0}, "frames_per_task 0: accepted an integer"),
    ({"telescope": Telescope(pupil_px=1024, q=16, fov_lambda_d=200, dark_outer_lambda_d=100)}, "above the 4 GiB bound"),
])
def test_a_run_argument_out_of_its_range_is_refused_before_any_optics(kwargs, words):
    args = {"telescope": SMALL, "t_s": np.arange(10) * 0.002, "poses": np.zeros((10, 7, 3)), "parked": None,
            "frame_samples": 5, **kwargs}
    frames_per_task = args.pop("frames_per_task", 4)
    with pytest.raises(InputError, match=re.escape(words)):
        F.run(**args, frames_per_task=frames_per_task)


@pytest.mark.parametrize("poses,words", [
    (np.zeros((0, 7, 3)), "a frame's poses of shape (0, 7, 3)"),
    (np.zeros((2, 6, 3)), "a frame's poses of shape (2, 6, 3): accepted (samples ≥ 1, 7, 3)"),
    (np.full((2, 7, 3), np.inf), "a frame's sample 0: seg0_piston_m inf"),
])
def test_a_frames_poses_are_checked_before_its_optics(poses, words):
    optics = types.SimpleNamespace(telescope=SMALL)  # never reached: the check comes first
    with pytest.raises(InputError, match=re.escape(words)):
        F.frame_batch(optics, poses)


@pytest.mark.parametrize("value", [math.nan, math.inf, "8"])
def test_a_regulation_start_that_is_not_a_finite_time_is_refused(value):
    with pytest.raises(InputError, match="regulation_from_s"):
        figures.summary(None, value)  # checked before the result is read


def test_the_memory_estimate_holds_the_defaults_and_the_cophasing_script_far_below_the_bound():
    # Below a quarter of it: the default run on 8 workers, scripts/cophase.sh's 37 segments.
    assert memory_bytes(Telescope(), 1000, 25, 8) < 1 << 30
    assert memory_bytes(Telescope(rings=3, pupil_px=96), 5000, 25, 2) < 1 << 30


def test_compare_refuses_a_run_folder_it_cannot_read_in_one_line(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "segments-summary.csv").write_text("name,value\nregulation_from_s,nan\n")
    assert compare.main([f"a={run}", "--out", str(tmp_path / "side")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "regulation_from_s nan: accepted a finite number" in err
    (run / "segments-summary.csv").write_text("name,value\nregulation_from_s,6\n")
    (run / "segments-samples.csv").write_text("t_s,cophasing_rms_nm,contrast\n0.0000,-1,0\n")
    (run / "segments-frames.csv").write_text("frame,t_start_s,t_end_s,contrast,cophasing_rms_nm\n")
    assert compare.main([f"a={run}", "--out", str(tmp_path / "side")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cophasing_rms_nm -1: accepted value ≥ 0 nm" in err
    assert compare.main(["a", "--out", str(tmp_path / "side")]) == 2
    assert "a: give NAME=DIR" in capsys.readouterr().err
    assert compare.main([f"a={tmp_path / 'none'}", "--out", str(tmp_path / "side")]) == 1
    assert compare.main(["--out"]) == 2
    assert "(see --help)" in capsys.readouterr().err


@pytest.mark.parametrize("call,words", [
    (lambda: P.header(0), "segment_count 0: accepted an integer, 1 ≤ value ≤ 127 segments"),
    (lambda: P.header(7.5), "segment_count 7.5: accepted an integer"),
    (lambda: P.write_rows(io.StringIO(), [0.0], np.full((1, 7, 3), 3.0)), "sample 0: seg0_piston_m 3"),
    (lambda: SMALL.tilt_shift_lambda_d(math.nan), "tilt_rad nan: accepted a finite number, -1 ≤ value ≤ 1 rad"),
    (lambda: SMALL.tilt_shift_lambda_d(2.0), "tilt_rad 2: accepted -1 ≤ value ≤ 1 rad"),
    (lambda: figures.strip_frames(None, 0), "count 0: accepted an integer, 1 ≤ value ≤ 64 frames"),
    (lambda: figures.strip_frames(None, 2.5), "count 2.5: accepted an integer"),
    (lambda: figures.write_summary(io.StringIO(), {"strehl_min": math.nan}), "summary strehl_min nan"),
    (lambda: figures.write_summary(io.StringIO(), {"frames": "7"}), "summary frames '7': accepted a finite number"),
    (lambda: figures.write_summary(io.StringIO(), {"": 1.0}), "summary name '': accepted a text, not empty"),
    (lambda: compare.markdown([], math.inf), "regulation_from_s inf: accepted a finite number, 0 ≤ value ≤ 1e+06 s"),
    (lambda: F.optics_for("SMALL"), "telescope 'SMALL': accepted a config.Telescope"),
])
def test_a_helpers_numeric_argument_out_of_its_range_is_refused(call, words):
    with pytest.raises(InputError, match=re.escape(words)):
        call()
