"""The run's numbers, the PNGs and the CSV behind each: co-phasing error, Strehl ratio and
contrast against time; a strip of coronagraphic frames; the segment map of piston.
matplotlib is pinned in scripts/setup.sh."""
import csv
import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Circle, RegularPolygon  # noqa: E402
import numpy as np  # noqa: E402
from inchworm_output import replacing, replacing_path

from .config import STRIP_FRAMES, InputError, Range


def _rms(x):
    x = np.asarray(x)
    return float(np.sqrt(np.mean(x**2))) if x.size else None


def _mean(x):
    x = np.asarray(x)
    return float(np.mean(x)) if x.size else None


def summary(result, regulation_from_s=None):
    """The run's numbers: name → value (None where a window is empty, e.g. no parked sample).
    With `regulation_from_s`, also the regulation's: every sample from that time on, its
    parked samples, and the frames that start at it or later."""
    if regulation_from_s is not None:
        regulation_from_s = Range(unit="s").check("regulation_from_s", regulation_from_s)
    r = result
    fp = r.frame_parked()
    numbers = {
        "segments": r.poses.shape[1],
        "samples": len(r.t_s),
        "frames": r.frame_count,
        "frame_s": r.frame_samples * (r.t_s[1] - r.t_s[0]) if len(r.t_s) > 1 else None,
        "parked_samples": int(r.parked.sum()),
        "parked_frames": int(fp.sum()),
        "cophasing_rms_nm": _rms(r.cophasing_rms_m) * 1e9,
        "cophasing_max_nm": float(r.cophasing_rms_m.max()) * 1e9,
        "cophasing_rms_parked_nm": None if not r.parked.any() else _rms(r.cophasing_rms_m[r.parked]) * 1e9,
        "wfe_rms_nm": _rms(r.wfe_rms_m) * 1e9,
        "strehl_mean": _mean(r.strehl),
        "strehl_min": float(r.strehl.min()),
        "strehl_mean_parked": _mean(r.strehl[r.parked]),
        "contrast_mean": _mean(r.frame_contrast),
        "contrast_mean_parked_frames": _mean(r.frame_contrast[fp]),
        "contrast_last_frame": float(r.frame_contrast[-1]),
    }
    if regulation_from_s is not None:
        reg = r.t_s >= regulation_from_s - 1e-9
        reg_frames = r.frame_start_s() >= regulation_from_s - 1e-9
        cophasing = r.cophasing_rms_m[reg]
        numbers.update({
            "regulation_from_s": float(regulation_from_s),
            "regulation_samples": int(reg.sum()),
            "regulation_parked_samples": int((reg & r.parked).sum()),
            "regulation_frames": int(reg_frames.sum()),
            "cophasing_rms_regulation_nm": None if not reg.any() else _rms(cophasing) * 1e9,
            "cophasing_rms_regulation_parked_nm":
                None if not (reg & r.parked).any() else _rms(r.cophasing_rms_m[reg & r.parked]) * 1e9,
            "strehl_mean_regulation": _mean(r.strehl[reg]),
            "contrast_mean_regulation_frames": _mean(r.frame_contrast[reg_frames]),
        })
    return numbers


def write_summary(f, numbers):
    """`numbers` (name → value or None) as the summary CSV into the text file `f`: a float
    in its shortest exact text, None an empty cell (what `compare.summary` reads back).
    Each name a text and each value None or a finite number, checked first."""
    for k, v in numbers.items():
        if not isinstance(k, str) or not k:
            raise InputError(f"summary name {k!r:.80}: accepted a text, not empty")
        if v is not None:
            Range().check(f"summary {k[:80]}", v)
    w = csv.writer(f)
    w.writerow(["name", "value"])
    w.writerows([k, "" if v is None else v] for k, v in numbers.items())


def write_summary_csv(path, numbers):
    with replacing(path) as f:
        write_summary(f, numbers)


def timeseries(png, samples_csv, frames_csv, result):
    """Co-phasing error and WFE, Strehl ratio, and contrast (per sample and per frame)
    against time, parked samples shaded."""
    r = result
    t0, t1 = r.frame_start_s(), r.frame_end_s()
    fp = r.frame_parked()
    with replacing(samples_csv) as f:
        w = csv.writer(f)
        w.writerow(["t_s", "parked", "cophasing_rms_nm", "wfe_rms_nm", "strehl", "contrast"])
        w.writerows([f"{r.t_s[i]:.4f}", int(r.parked[i]), r.cophasing_rms_m[i] * 1e9, r.wfe_rms_m[i] * 1e9,
                     r.strehl[i], r.contrast[i]] for i in range(len(r.t_s)))
    n = r.frame_samples
    with replacing(frames_csv) as f:
        w = csv.writer(f)
        w.writerow(["frame", "t_start_s", "t_end_s", "parked", "contrast", "strehl_mean", "cophasing_rms_nm"])
        w.writerows([k, f"{t0[k]:.4f}", f"{t1[k]:.4f}", int(fp[k]), r.frame_contrast[k],
                     float(np.mean(r.strehl[k * n:(k + 1) * n])), _rms(r.cophasing_rms_m[k * n:(k + 1) * n]) * 1e9]
                    for k in range(r.frame_count))
    tel = r.telescope
    fig, axes = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
    for ax in axes:
        _shade(ax, r.t_s, r.parked)
    ax = axes[0]
    ax.semilogy(r.t_s, np.maximum(r.cophasing_rms_m * 1e9, 1e-3), lw=0.8, label="co-phasing error (segment piston, WFE RMS)")
    ax.semilogy(r.t_s, np.maximum(r.wfe_rms_m * 1e9, 1e-3), lw=0.6, alpha=0.7, label="WFE RMS (piston, tip and tilt)")
    ax.set_ylabel("nm")
    ax.set_title(f"{r.poses.shape[1]} segments, {tel.flat_to_flat_m * 1e3:g} mm, D = {tel.diameter_m:.3f} m, "
                 f"{tel.wavelength_m * 1e9:g} nm; shaded: parked", fontsize=9)
    ax = axes[1]
    ax.plot(r.t_s, r.strehl, lw=0.8, label="Strehl ratio on the axis, per 2 ms sample")
    ax.set_ylim(min(0.0, float(r.strehl.min())), 1.02)
    ax = axes[2]
    ax.semilogy(r.t_s, r.contrast, lw=0.5, color="0.6", label="per 2 ms sample")
    ax.stairs(r.frame_contrast, np.append(t0, t1[-1]), lw=1.2, label=f"per {n * 2:g} ms frame")
    ax.set_ylabel(f"raw contrast, {tel.dark_inner_lambda_d:g}-{tel.dark_outer_lambda_d:g} λ/D")
    ax.set_xlabel("time (s)")
    for ax in axes:
        ax.legend(loc="upper right", fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    with replacing_path(png) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


def _shade(ax, t, parked):
    edges = np.flatnonzero(np.diff(np.concatenate([[0], parked.astype(int), [0]])))
    dt = t[1] - t[0] if len(t) > 1 else 0.0
    for a, b in zip(edges[::2], edges[1::2]):
        ax.axvspan(t[a], t[b - 1] + dt, color="0.92", lw=0)


def strip_frames(result, count):
    """`count` frames (1 to 64) evenly spread over the run, first and last included."""
    count = STRIP_FRAMES.check("count", count)
    return sorted({int(round(i)) for i in np.linspace(0, result.frame_count - 1, min(count, result.frame_count))})


def strip(png, csv_path, result, optics, count=6):
    """Coronagraphic frames (log10 contrast, dark zone circled); the CSV holds every pixel."""
    frames = strip_frames(result, count)
    shape = optics.focal_shape
    ext = [optics.fx.min(), optics.fx.max(), optics.fy.min(), optics.fy.max()]
    tel = result.telescope
    fig, axes = plt.subplots(1, len(frames), figsize=(2.3 * len(frames), 2.9), squeeze=False)
    t0, t1 = result.frame_start_s(), result.frame_end_s()
    with replacing(csv_path) as f:
        w = csv.writer(f)
        w.writerow(["frame", "t_start_s", "t_end_s", "x_lambda_d", "y_lambda_d", "contrast"])
        for ax, k in zip(axes[0], frames):
            img = result.images[k]
            w.writerows([k, f"{t0[k]:.4f}", f"{t1[k]:.4f}", optics.fx[i], optics.fy[i], img[i]] for i in range(img.size))
            im = ax.imshow(np.log10(np.maximum(img.reshape(shape), 1e-12)), origin="lower", extent=ext,
                           cmap="inferno", vmin=-10, vmax=-2)
            for rad in (tel.dark_inner_lambda_d, tel.dark_outer_lambda_d):
                ax.add_patch(Circle((0, 0), rad, fill=False, color="c", lw=0.6, ls="--"))
            ax.set_title(f"{t0[k]:.2f}-{t1[k]:.2f} s\nC = {result.frame_contrast[k]:.2e}", fontsize=7)
            ax.set_xticks([])
            ax.set_yticks([])
    fig.colorbar(im, ax=axes[0].tolist(), shrink=0.8, label="log10 contrast")
    fig.suptitle("Perfect coronagraph's frames (every 2 ms sample of the exposure); dashed: the dark zone", fontsize=9)
    with replacing_path(png) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


def piston_map(png, csv_path, result, optics):
    """Each segment's piston (surface, about the aperture-weighted mean) at the sample of the
    largest co-phasing error, averaged over the parked samples (over all if none), and its
    RMS over the run."""
    r = result
    p = r.poses[:, :, 0]
    rel = p - (p @ optics.segment_weights)[:, None]
    worst = int(np.argmax(r.cophasing_rms_m))
    held = r.parked if r.parked.any() else np.ones_like(r.parked)
    maps = [(f"at the worst sample, t = {r.t_s[worst]:.3f} s", rel[worst] * 1e9),
            ("mean over the parked samples" if r.parked.any() else "mean over the run", rel[held].mean(axis=0) * 1e9),
            ("RMS over the run", np.sqrt(np.mean(rel**2, axis=0)) * 1e9)]
    with replacing(csv_path) as f:
        w = csv.writer(f)
        w.writerow(["segment", "x_m", "y_m", "weight", "piston_worst_nm", "piston_parked_mean_nm", "piston_rms_nm"])
        for k, (x, y) in enumerate(optics.segment_centres_m):
            w.writerow([k, x, y, optics.segment_weights[k]] + [m[1][k] for m in maps])
    tel = r.telescope
    radius = tel.flat_to_flat_m / math.sqrt(3.0)
    fig, axes = plt.subplots(1, 3, figsize=(12, 4.2))
    for ax, (title, values) in zip(axes, maps):
        lim = float(np.max(np.abs(values))) or 1.0
        cmap = plt.get_cmap("RdBu_r" if "RMS" not in title else "viridis")
        lo = -lim if "RMS" not in title else 0.0
        for k, (x, y) in enumerate(optics.segment_centres_m):
            c = cmap((values[k] - lo) / (lim - lo))
            ax.add_patch(RegularPolygon((x, y), 6, radius=radius, orientation=math.pi / 6, facecolor=c, edgecolor="k", lw=0.5))
            ax.text(x, y, f"{k}\n{values[k]:.1f}", ha="center", va="center", fontsize=6)
        half = tel.diameter_m / 2
        ax.set_xlim(-half, half)
        ax.set_ylim(-half, half)
        ax.set_aspect("equal")
        ax.set_title(title, fontsize=8)
        fig.colorbar(plt.cm.ScalarMappable(norm=plt.Normalize(lo, lim), cmap=cmap), ax=ax, shrink=0.8, label="nm")
    fig.subplots_adjust(wspace=0.5)
    fig.suptitle("Segment piston (surface, about the aperture mean): segment number and nm", fontsize=9)
    with replacing_path(png) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
