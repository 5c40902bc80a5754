"""The segments' poses per sample: the CSV the command reads (and writes for its synthetic
input), and a seeded synthetic co-phasing run for the tests and the figures.

CSV columns: `time` (s, uniform steps), then for each segment k = 0 … N−1 `seg{k}_piston_m`,
`seg{k}_tip_rad`, `seg{k}_tilt_rad`, then optionally `parked` (1 where every segment's
mount is parked, else 0). Segment k is hcipy's k-th segment: the centre (when present),
then ring by ring, each ring anticlockwise from its segment below-right of the centre.
"""
import csv
import math

import numpy as np
from inchworm_output import replacing

from .config import SAMPLE_S, InputError

POSE_NAMES = ("piston_m", "tip_rad", "tilt_rad")


def header(segment_count, with_parked=True):
    cols = ["time"] + [f"seg{k}_{n}" for k in range(segment_count) for n in POSE_NAMES]
    return cols + (["parked"] if with_parked else [])


def write_csv(path, t_s, poses, parked=None):
    poses = np.asarray(poses, dtype=float)
    with replacing(path) as f:
        w = csv.writer(f)
        w.writerow(header(poses.shape[1], parked is not None))
        for i in range(len(t_s)):
            row = [repr(float(t_s[i]))] + [repr(v) for v in poses[i].ravel().tolist()]
            w.writerow(row + ([int(bool(parked[i]))] if parked is not None else []))


def read_csv(path):
    """(t_s (samples,), poses (samples, N, 3), parked (samples,) bool or None) from a poses
    CSV, or an InputError naming the file, the row or column and what is accepted."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        raise InputError(f"{path}: empty; accepted a header row `time,seg0_piston_m,...` and one row per sample")
    head = [c.strip() for c in rows[0]]
    with_parked = bool(head) and head[-1] == "parked"
    n_cols = len(head) - 1 - with_parked
    if n_cols <= 0 or n_cols % 3 or head != header(n_cols // 3, with_parked):
        raise InputError(f"{path}: header {','.join(head[:5])}...: accepted time, then seg{{k}}_piston_m, "
                         f"seg{{k}}_tip_rad, seg{{k}}_tilt_rad for k = 0, 1, ..., then optionally parked")
    data = []
    for i, row in enumerate(rows[1:], start=2):
        if len(row) != len(head):
            raise InputError(f"{path}: row {i} has {len(row)} columns, the header {len(head)}")
        try:
            values = [float(v) for v in row]
        except ValueError:
            raise InputError(f"{path}: row {i}: accepted numbers only") from None
        if not all(math.isfinite(v) for v in values):
            raise InputError(f"{path}: row {i}: accepted finite numbers (no NaN or infinity)")
        if with_parked and values[-1] not in (0.0, 1.0):
            raise InputError(f"{path}: row {i}: parked {row[-1]}: accepted 0 or 1")
        data.append(values)
    if len(data) < 1:
        raise InputError(f"{path}: no samples")
    a = np.array(data)
    t = a[:, 0]
    step = np.diff(t)
    if len(t) > 1 and not np.all(np.abs(step - SAMPLE_S) <= 1e-9 + 1e-6 * SAMPLE_S):
        bad = int(np.argmax(np.abs(step - SAMPLE_S) > 1e-9 + 1e-6 * SAMPLE_S)) + 3
        raise InputError(f"{path}: row {bad}: time step {step[bad - 3]:g} s: accepted the engine's "
                         f"{SAMPLE_S:g} s sample step throughout")
    poses = a[:, 1:1 + n_cols].reshape(len(a), n_cols // 3, 3)
    parked = a[:, -1].astype(bool) if with_parked else None
    return t, poses, parked


def synthetic(segment_count, duration_s=2.0, seed=2026, start_piston_m=60e-9, start_tilt_rad=40e-9,
              jitter_piston_m=4e-9, jitter_tilt_rad=2e-9, residual_piston_m=1.5e-9, residual_tilt_rad=1e-9,
              settle_s=0.08):
    """A seeded co-phasing run: every segment starts off by a random piston, tip and tilt,
    and in turn (segment k moves from (k + 1) T / (N + 2)) its mount steps it to a small
    residual, converging with time constant `settle_s` and jittering by the steps' motion
    while it moves (for 4 time constants); after that it is parked and holds. `parked` is
    true where no segment moves. Returns (t_s, poses, parked)."""
    rng = np.random.default_rng(seed)
    n = int(round(duration_s / SAMPLE_S))
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
