"""The segments' poses per sample: the CSV the command reads (and writes for its synthetic
input), the check every run's poses pass, and a seeded synthetic co-phasing run for the
tests and the figures.

CSV columns: `time` (s, uniform steps), then for each segment k = 0 … N−1 `seg{k}_piston_m`,
`seg{k}_tip_rad`, `seg{k}_tilt_rad`, then optionally `parked` (1 where every segment's
mount is parked, else 0). Segment k is hcipy's k-th segment: the centre (when present),
then ring by ring, each ring anticlockwise from its segment below-right of the centre.
Every value is checked against its range (`config`: time, piston, tip and tilt) before any
optics is computed.
"""
import array
import csv
import io

import numpy as np
from inchworm_inputs import open_bounded
from inchworm_output import replacing

from .config import (LONGEST_RUN_S, POSE_RANGES, SAMPLE_S, SEED, SEGMENTS, SETTLE_S, SYNTHETIC_PISTON_M,
                     SYNTHETIC_S, SYNTHETIC_TILT_RAD, TIME_S, InputError, Range, rings_for)
from .files import csv_rows

POSE_NAMES = ("piston_m", "tip_rad", "tilt_rad")
#: The most values (samples × columns) a run's poses may hold: 64 Mi values, 512 MiB of
#: floats (an hour of 7 segments is 41 M). Past it a CSV is refused as it is read, and the
#: synthetic run before it is drawn.
MAX_POSE_VALUES = 1 << 26
#: The largest poses CSV read, bytes: MAX_POSE_VALUES values of 16 characters.
MAX_CSV_BYTES = 1 << 30
#: The longest line, characters: far above the 127-segment row of 382 values of 25.
MAX_LINE_CHARS = 64 << 10
#: The engine's step as the CSV's times must hold it.
STEP_TOLERANCE_S = 1e-9 + 1e-6 * SAMPLE_S


def header(segment_count, with_parked=True):
    """The poses CSV's header of `segment_count` segments (1 to 127)."""
    segment_count = SEGMENTS.check("segment_count", segment_count)
    cols = ["time"] + [f"seg{k}_{n}" for k in range(segment_count) for n in POSE_NAMES]
    return cols + (["parked"] if with_parked else [])


def _inside(rng, x):
    """Where `x` (an array) is in `rng` (NaN is not)."""
    lo = x > rng.lo if rng.lo_open else x >= rng.lo
    hi = x < rng.hi if rng.hi_open else x <= rng.hi
    return lo & hi


def check_poses(t_s, poses, parked=None, name="poses", where=None):
    """(t (samples,), poses (samples, N, 3), parked (samples,) bool or None) as float arrays if
    they are a run's poses: at least one sample, every time, piston, tip and tilt finite and
    in its range (`config`), parked 0 or 1, the times on the engine's 2 ms step, N a ring
    count; else an InputError naming `name`, the first sample not (as `where(i)` says sample
    i: a file's row), the value and its range."""
    where = where or (lambda i: f"{name}: sample {i}")
    try:
        t = np.asarray(t_s, dtype=float)
        p = np.asarray(poses, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"{name}: accepted arrays of numbers: times (samples,), poses (samples, segments, 3)") from None
    if p.ndim != 3 or p.shape[2] != 3 or p.shape[0] < 1 or t.shape != p.shape[:1]:
        raise InputError(f"{name}: times of shape {t.shape}, poses {p.shape}: accepted (samples,) and "
                         "(samples, segments, 3), at least one sample")
    if p.size + t.size > MAX_POSE_VALUES:
        raise InputError(f"{name}: {p.size + t.size} values: accepted at most {MAX_POSE_VALUES}")
    check_pose_values(p, where, t)
    if parked is not None:
        k = np.asarray(parked)
        if k.shape != t.shape or not (k.dtype == bool or np.issubdtype(k.dtype, np.number)):
            raise InputError(f"{name}: parked of shape {k.shape}: accepted (samples,) = {t.shape} of 0 or 1")
        bad = ~((k == 0) | (k == 1))
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(f"{where(i)}: parked {float(k[i]):g}: accepted 0 or 1")
        parked = k.astype(bool)
    step = np.diff(t)
    off = np.abs(step - SAMPLE_S) > STEP_TOLERANCE_S
    if off.any():
        i = int(np.argmax(off))
        raise InputError(f"{where(i + 1)}: time step {step[i]:g} s: accepted the engine's {SAMPLE_S:g} s sample "
                         "step throughout")
    try:
        rings_for(p.shape[1])
    except InputError as e:
        raise InputError(f"{name}: {e}") from None
    return t, p, parked


def check_pose_values(p, where, t=None):
    """Every pose of `p` (samples, N, 3) (and time of `t`) finite and in its range, or the
    InputError of the first one not, by `where(sample)` and its column's name."""
    ok = np.ones(p.shape[0], dtype=bool) if t is None else _inside(TIME_S, t)
    for j, rng in enumerate(POSE_RANGES):
        ok &= _inside(rng, p[:, :, j]).all(axis=1)
    if ok.all():
        return
    i = int(np.argmax(~ok))
    if t is not None:
        TIME_S.check(f"{where(i)}: time", float(t[i]))
    for k in range(p.shape[1]):
        for j, rng in enumerate(POSE_RANGES):
            rng.check(f"{where(i)}: seg{k}_{POSE_NAMES[j]}", float(p[i, k, j]))


def write_rows(f, t_s, poses, parked=None):
    """The poses CSV into the text file `f`, every value in the shortest text that reads
    back as the same float (`repr`), parked as 0 or 1; the poses checked first
    (`check_poses`), so that what is written reads back."""
    t_s, poses, parked = check_poses(t_s, poses, parked)
    w = csv.writer(f)
    w.writerow(header(poses.shape[1], parked is not None))
    for i in range(len(t_s)):
        row = [repr(float(t_s[i]))] + [repr(v) for v in poses[i].ravel().tolist()]
        w.writerow(row + ([int(bool(parked[i]))] if parked is not None else []))


def write_csv(path, t_s, poses, parked=None):
    """The poses CSV at `path` (written beside it and renamed over it when complete), after
    the check every run's poses pass (`check_poses`), so that it reads back."""
    t, p, parked = check_poses(t_s, poses, parked)
    with replacing(path) as f:
        write_rows(f, t, p, parked)


def read_csv(path):
    """(t_s (samples,), poses (samples, N, 3), parked (samples,) bool or None) from a poses
    CSV, or an InputError naming the file, the row or column and what is accepted."""
    with open_bounded(path, MAX_CSV_BYTES) as f:
        return parse_csv(f, path)


def parse_csv(data, name="poses CSV"):
    """`read_csv` of bytes (or a binary stream) `data`, named `name` in its messages."""
    stream = io.BytesIO(data) if isinstance(data, (bytes, bytearray, memoryview)) else data
    rows = csv_rows(stream, name, MAX_CSV_BYTES, MAX_LINE_CHARS)
    first = next(rows, None)
    if first is None:
        raise InputError(f"{name}: empty; accepted a header row `time,seg0_piston_m,...` and one row per sample")
    head = [c.strip() for c in first[1]]
    with_parked = bool(head) and head[-1] == "parked"
    n_cols = len(head) - 1 - with_parked
    if n_cols <= 0 or n_cols % 3 or head != header(n_cols // 3, with_parked):
        shown = ",".join(head[:5])[:200]
        raise InputError(f"{name}: header {shown}...: accepted time, then seg{{k}}_piston_m, "
                         f"seg{{k}}_tip_rad, seg{{k}}_tilt_rad for k = 0, 1, ..., then optionally parked")
    ranges = [TIME_S] + [POSE_RANGES[j % 3] for j in range(n_cols)] + ([Range(0, 1, integer=True)] * with_parked)
    values = array.array("d")
    samples = 0
    for i, row in rows:
        if len(row) != len(head):
            raise InputError(f"{name}: row {i} has {len(row)} columns, the header {len(head)}")
        joined = "".join(row)
        try:
            if not joined.isascii() or "_" in joined:  # float() also takes "1_0" and non-ASCII digits
                raise ValueError
            values.extend([float(v) for v in row])
        except ValueError:
            for j, v in enumerate(row):
                if not _is_number(v):
                    ranges[j].check(f"{name}: row {i}: {head[j]}", v.strip()[:80])
            raise AssertionError(f"{name}: row {i}: a field float() refuses, and none _is_number refuses")
        samples += 1
        if samples * len(head) > MAX_POSE_VALUES:
            raise InputError(f"{name}: row {i}: more than the {MAX_POSE_VALUES} values a run's poses may hold "
                             f"({MAX_POSE_VALUES // len(head)} samples of {len(head)} columns)")
    if samples < 1:
        raise InputError(f"{name}: no samples")
    a = np.frombuffer(values, dtype=float).reshape(samples, len(head))
    t, poses, parked = check_poses(a[:, 0], a[:, 1:1 + n_cols].reshape(samples, n_cols // 3, 3),
                                   a[:, -1] if with_parked else None, name=name,
                                   where=lambda i: f"{name}: row {i + 2}")
    return t, poses, parked


def _is_number(text):
    """A number as the CSV holds it: ASCII, as float() reads it, no digit separators."""
    if not text.isascii() or "_" in text:
        return False
    try:
        float(text)
    except ValueError:
        return False
    return True


def synthetic(segment_count, duration_s=2.0, seed=2026, start_piston_m=60e-9, start_tilt_rad=40e-9,
              jitter_piston_m=4e-9, jitter_tilt_rad=2e-9, residual_piston_m=1.5e-9, residual_tilt_rad=1e-9,
              settle_s=0.08):
    """A seeded co-phasing run: every segment starts off by a random piston, tip and tilt,
    and in turn (segment k moves from (k + 1) T / (N + 2)) its mount steps it to a small
    residual, converging with time constant `settle_s` and jittering by the steps' motion
    while it moves (for 4 time constants); after that it is parked and holds. `parked` is
    true where no segment moves. Returns (t_s, poses, parked). Every argument is checked
    against its range (`config`) first, and the run's size against MAX_POSE_VALUES."""
    segment_count = SEGMENTS.check("segment_count", segment_count)
    rings_for(segment_count)
    duration_s = SYNTHETIC_S.check("duration_s", duration_s)
    seed = SEED.check("seed", seed)
    for name, value in (("start_piston_m", start_piston_m), ("jitter_piston_m", jitter_piston_m),
                        ("residual_piston_m", residual_piston_m)):
        SYNTHETIC_PISTON_M.check(name, value)
    for name, value in (("start_tilt_rad", start_tilt_rad), ("jitter_tilt_rad", jitter_tilt_rad),
                        ("residual_tilt_rad", residual_tilt_rad)):
        SYNTHETIC_TILT_RAD.check(name, value)
    settle_s = SETTLE_S.check("settle_s", settle_s)
    n = max(1, int(round(duration_s / SAMPLE_S)))
    if n * (3 * segment_count + 1) > MAX_POSE_VALUES:
        raise InputError(f"duration_s {duration_s:g}: {n} samples of {segment_count} segments are "
                         f"{n * (3 * segment_count + 1)} values: accepted at most the {MAX_POSE_VALUES} a run's poses "
                         f"may hold (≤ {MAX_POSE_VALUES // (3 * segment_count + 1) * SAMPLE_S:g} s of "
                         f"{segment_count} segments; the longest run is {LONGEST_RUN_S:g} s)")
    rng = np.random.default_rng(seed)
    t = np.arange(n) * SAMPLE_S
    scale = np.array([start_piston_m, start_tilt_rad, start_tilt_rad])
    jitter = np.array([jitter_piston_m, jitter_tilt_rad, jitter_tilt_rad])
    residual = np.array([residual_piston_m, residual_tilt_rad, residual_tilt_rad])
    start = rng.normal(size=(segment_count, 3)) * scale
    end = rng.normal(size=(segment_count, 3)) * residual
    noise = rng.normal(size=(n, segment_count, 3)) * jitter
    t_move = (np.arange(segment_count) + 1) * duration_s / (segment_count + 2)
    dt = t[:, None] - t_move[None, :]  # (samples, N)
    moving = (dt >= 0) & (dt < 4 * settle_s)
    decay = np.where(dt < 0, 1.0, np.exp(-np.clip(dt, 0, None) / settle_s))[..., None]
    poses = end + (start - end) * decay + noise * moving[..., None]
    return t, poses, ~moving.any(axis=1)

