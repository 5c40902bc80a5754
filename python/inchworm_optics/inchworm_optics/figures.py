"""The PNG figures and the CSV behind each: the frames' time series (stepping controller
and analog mode side by side), a strip of PSF frames, and the guided run against the
unguided one. matplotlib comes with poppy (a dependency of it), pinned in setup.sh."""
import csv

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from inchworm_output import replacing, replacing_path


def _frame_rows(name, result, instrument):
    err = result.frame_error_mas(instrument)
    scale = instrument.rx.pixel_scale_mas
    for f, e, tg in zip(result.frames, err, result.frame_target_px):
        yield [name, f"{f.t_start_s:.3f}", f"{f.t_end_s:.3f}", f.centroid_px[0], f.centroid_px[1],
               f.centroid_px[0] * scale, f.centroid_px[1] * scale, tg[0], tg[1], e[0], e[1],
               f.wfe_rms_m * 1e9, f.wfe_rms_max_m * 1e9, f.strehl, f.ee]


FRAME_HEADER = ["run", "t_start_s", "t_end_s", "centroid_x_px", "centroid_y_px", "centroid_x_mas",
                "centroid_y_mas", "target_x_px", "target_y_px", "error_x_mas", "error_y_mas",
                "wfe_rms_nm", "wfe_rms_max_nm", "strehl", "ee"]


def write_frames_csv(path, results, instrument):
    with replacing(path) as f:
        w = csv.writer(f)
        w.writerow(FRAME_HEADER)
        for name, r in results.items():
            w.writerows(_frame_rows(name, r, instrument))


def write_samples_csv(path, results):
    with replacing(path) as f:
        w = csv.writer(f)
        w.writerow(["run", "t_s", "piston_m", "tip_rad", "tilt_rad", "tip_command_rad", "tilt_command_rad",
                    "parked", "centroid_x_px", "centroid_y_px", "target_x_px", "target_y_px"])
        for name, r in results.items():
            for i in range(len(r.t_s)):
                w.writerow([name, f"{r.t_s[i]:.3f}", *r.pose[i], *r.command[i], int(r.parked[i]),
                            *r.sample_centroid_px[i], *r.sample_target_px[i]])


def _log_floor(x, floor):
    return np.maximum(np.abs(np.asarray(x)), floor)


def timeseries_png(path, results, instrument, names=("stepping", "analog")):
    """Per run (columns): despace per sample and frame WFE; image error per sample and per
    frame; Strehl and encircled energy per frame."""
    rx = instrument.rx
    names = [n for n in names if n in results]
    fig, axes = plt.subplots(4, len(names), figsize=(6.5 * len(names), 11), sharex=True, squeeze=False)
    for j, name in enumerate(names):
        r = results[name]
        tm = r.frame_mid_s()
        ax = axes[0][j]
        ax.semilogy(r.t_s, _log_floor((r.pose[:, 0] - rx.focus_piston_m) * 1e9, 1e-2), lw=0.5, color="0.5",
                    label="|despace| per 2 ms sample (nm)")
        ax.set_ylabel("|despace| (nm)")
        ax.set_title(f"{name}: {instrument.rx.aperture_m:g} m f/{rx.f_number:g} Cassegrain, secondary on the mount")
        ax.legend(loc="upper right", fontsize=8)
        ax = axes[1][j]
        ax.semilogy(tm, _log_floor([f.wfe_rms_m * 1e9 for f in r.frames], 1e-3), ".-", ms=3, label="frame WFE RMS")
        ax.semilogy(tm, _log_floor([f.wfe_rms_max_m * 1e9 for f in r.frames], 1e-3), lw=0.6,
                    label="largest sample WFE RMS in the frame")
        ax.set_ylabel("WFE RMS (nm)")
        ax.legend(loc="upper right", fontsize=8)
        ax = axes[2][j]
        se = np.hypot(*(r.sample_centroid_px - r.sample_target_px).T) * rx.pixel_scale_mas
        ax.semilogy(r.t_s, _log_floor(se, 1e-4), lw=0.5, color="0.6", label="per 2 ms sample")
        ax.semilogy(tm, _log_floor(np.hypot(*r.frame_error_mas(instrument).T), 1e-4), ".-", ms=3,
                    label=f"per {r.config.frame_s * 1e3:.0f} ms frame")
        ax.set_ylabel("image error (mas)")
        ax.legend(loc="upper right", fontsize=8)
        ax = axes[3][j]
        ax.plot(tm, [f.strehl for f in r.frames], ".-", ms=3, label=f"Strehl at {rx.wavelength_m * 1e9:.0f} nm")
        ax.plot(tm, [f.ee for f in r.frames], ".-", ms=3, label="EE within 1.22 λ/D")
        ax.set_ylim(0, 1.05)
        ax.set_xlabel("time (s)")
        ax.legend(loc="lower right", fontsize=8)
    for row in axes:
        for ax in row:
            ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    with replacing_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


def strip_frames(result, times_s):
    """The frames whose exposure contains each of `times_s`."""
    out = []
    for t in times_s:
        for i, f in enumerate(result.frames):
            if f.t_start_s <= t < f.t_end_s:
                out.append(i)
                break
    return out


def psf_strip_png(path, csv_path, results, instrument, times_s, names=("stepping", "analog")):
    """A strip of detector frames (log stretch) at `times_s`, one row per run; the CSV has
    every pixel of every frame shown."""
    names = [n for n in names if n in results]
    fig, axes = plt.subplots(len(names), len(times_s), figsize=(1.9 * len(times_s), 2.5 * len(names)), squeeze=False)
    with replacing(csv_path) as out:  # row by row: a 1024-px frame is a million rows
        w = csv.writer(out)
        w.writerow(["run", "frame", "t_start_s", "t_end_s", "y_px", "x_px", "fraction_of_light"])
        for j, name in enumerate(names):
            r = results[name]
            for k, i in enumerate(strip_frames(r, times_s)):
                f = r.frames[i]
                img = f.image
                ax = axes[j][k]
                ax.imshow(np.log10(np.maximum(img / img.max(), 1e-4)), origin="lower", cmap="magma", vmin=-4, vmax=0)
                ax.set_xticks([])
                ax.set_yticks([])
                ax.set_title(f"{name} {f.t_start_s:.2f}-{f.t_end_s:.2f} s\nS={f.strehl:.3f}", fontsize=7)
                for y in range(img.shape[0]):
                    w.writerows([name, i, f"{f.t_start_s:.3f}", f"{f.t_end_s:.3f}", y, x, img[y, x]]
                                for x in range(img.shape[1]))
    fig.suptitle("Detector frames (log10 of the frame's peak-normalised intensity, 4 decades)", fontsize=9)
    fig.tight_layout(h_pad=1.5)
    with replacing_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


def guidance_png(path, csv_path, results, instrument, bound_mas, from_s, guide_rate_hz,
                 names=("drift", "guided", "guided-analog")):
    """Image error (x, y) of the unguided and guided runs under the line-of-sight drift,
    with the bound; and the guider's tip/tilt offset."""
    names = [n for n in names if n in results]
    fig, axes = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    for name in names:
        r = results[name]
        e = r.frame_error_mas(instrument)
        tm = r.frame_mid_s()
        axes[0].plot(tm, np.hypot(*e.T), ".-", ms=3, label=f"{name}: |image error| per frame")
    axes[0].axhline(bound_mas, color="k", ls="--", lw=0.8, label=f"bound {bound_mas:g} mas (from t = {from_s:g} s)")
    axes[0].set_yscale("log")
    axes[0].set_ylabel("image error (mas)")
    axes[0].legend(fontsize=8)
    axes[0].grid(True, which="both", alpha=0.3)
    for name in names:
        log = np.array(results[name].guide_log, dtype=float)
        if log.size:
            axes[1].plot(log[:, 0], log[:, 5] * 1e9, ".-", ms=3, label=f"{name}: guider tip offset")
            axes[1].plot(log[:, 0], log[:, 6] * 1e9, ".-", ms=3, label=f"{name}: guider tilt offset")
    axes[1].set_ylabel("offset (nrad)")
    axes[1].set_xlabel("time (s)")
    axes[1].legend(fontsize=8)
    axes[1].grid(True, alpha=0.3)
    fig.suptitle(f"Fine guidance at {guide_rate_hz:g} Hz against a line-of-sight drift the mount cannot see", fontsize=10)
    fig.tight_layout()
    with replacing_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    with replacing(csv_path) as f:
        w = csv.writer(f)
        w.writerow(FRAME_HEADER)
        for name in names:
            w.writerows(_frame_rows(name, results[name], instrument))
        for name in names:
            if results[name].guide_log:
                w.writerow([])
                w.writerow(["guide_run", "guide_t_s", "measured_x_px", "measured_y_px", "error_x_px", "error_y_px",
                            "offset_tip_rad", "offset_tilt_rad"])
                w.writerows([name, *row] for row in results[name].guide_log)
