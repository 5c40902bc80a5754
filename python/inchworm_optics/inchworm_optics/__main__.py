"""`python -m inchworm_optics` (or `inchworm-optics`): the mirror mount's scenario through
the telescope, for the paper's stepping controller and analog mode near the target, and
the fine-guidance loop against a line-of-sight drift; prints the numbers, writes the CSVs
and PNGs."""
import argparse
import contextlib
import csv
import errno
import json
import os
import pathlib
import signal
import sys
import time

from inchworm_inputs import command
from inchworm_output import OutputError, check, replacing

from .inputs import (ANGLE, BOUND, DURATION, GAIN, GRID, MEMORY_BYTES, PHOTONS, RATE, RATE_OF_ANGLE, READ_NOISE,
                     REGULATION_S, SECONDS, SEED, STEP_S, InputError, check_pupil_grid, memory_bytes, sample_counts,
                     window_end_s)
from .telescope import Prescription

RUNS = ("stepping", "analog", "drift", "guided", "guided-analog")
#: The runs against a line-of-sight drift and offset, and the one of them unguided.
DRIFT_RUNS = ("drift", "guided", "guided-analog")
#: What the CLI writes into --out.
OUTPUTS = ("optics-timeseries.csv", "optics-samples.csv", "optics-timeseries.png", "optics-psf-strip.png",
           "optics-psf-strip.csv", "optics-guidance.png", "optics-guidance.csv", "optics-summary.csv",
           "optics-prescription.json")


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        # One line, as every other refusal (argparse would print the usage first and exit 2).
        raise InputError(f"{message} (see --help)")


def parse_args(argv):
    p = _Parser(prog="inchworm-optics", description=__doc__)
    p.add_argument("--dist", default="dist", help="folder with MirrorMount.ssp (cargo run --release -p fmu-build)")
    p.add_argument("--out", default="out/optics", help="folder for the CSVs and PNGs")
    p.add_argument("--prescription", help="JSON file of telescope parameters (telescope.Prescription's fields)")
    p.add_argument("--duration", type=float, default=10.0,
                   help=f"seconds simulated (default 10: the SSP's scenario), {DURATION}")
    p.add_argument("--frame-rate", type=float, default=20.0, help=f"detector frames per second (default 20), {RATE}")
    p.add_argument("--pupil", type=int, default=48, help=f"pupil grid, pixels across (default 48), {GRID}")
    p.add_argument("--fov", type=int, default=48, help=f"detector pixels across (default 48), {GRID}")
    p.add_argument("--runs", default=",".join(RUNS), help=f"comma-separated subset of {','.join(RUNS)}")
    p.add_argument("--drift", default="20,10", help="line-of-sight drift x,y in mas/s for the drift and guided runs")
    p.add_argument("--offset", default="0,0", help="constant line-of-sight offset x,y in mas for the drift and guided runs")
    p.add_argument("--guide-rate", type=float, default=10.0, help=f"guide frames per second (default 10), {RATE}")
    p.add_argument("--guide-gain", type=float, default=0.2,
                   help=f"guider integrator gain with the stepping controller (default 0.2: it moves every 0.2 s), {GAIN}")
    p.add_argument("--guide-gain-analog", type=float, default=0.5,
                   help=f"guider integrator gain with analog mode (default 0.5), {GAIN}")
    p.add_argument("--guide-pause", type=float, default=0.4,
                   help=f"seconds the guider holds its offset after a commanded move (default 0.4), {SECONDS}")
    p.add_argument("--guide-photons", type=float, default=2e5,
                   help=f"photo-electrons per guide frame (0: noiseless), {PHOTONS}")
    p.add_argument("--read-noise", type=float, default=5.0, help=f"read noise per pixel, electrons, {READ_NOISE}")
    p.add_argument("--seed", type=int, default=2026, help=f"the guider's noise, {SEED}")
    p.add_argument("--held-from", type=float, default=5.0,
                   help=f"measure how well the image is held from this time, {SECONDS}")
    p.add_argument("--bound", type=float, default=20.0, help=f"stated bound on the guided image error, {BOUND}")
    p.add_argument("--regulation", type=float, default=REGULATION_S, help=f"regulation from this time, {SECONDS}")
    p.add_argument("--param", action="append", default=[], metavar="COMPONENT.VARIABLE=VALUE",
                   help="set an SSP parameter in every run, as `inchworm run --param` (repeatable)")
    return p.parse_args(argv)


def _pair(flag, text, rng):
    """`X,Y` of two finite numbers."""
    try:
        values = tuple(float(v) for v in text.split(","))
        if len(values) != 2:
            raise ValueError
        for v in values:
            rng.check(flag, v)
    except ValueError:  # InputError is one
        raise InputError(f"{flag} {text}: accepted X,Y, two finite numbers in {rng.unit}") from None
    return values


def check_arguments(a, rx):
    """Every argument in its range (`inputs`), and the run's windows, the star's path on the
    detector and the run's memory, before anything is imported or run. Returns the run
    names, the frame time (a whole number of samples), the drift and the offset."""
    DURATION.check("--duration", a.duration)
    for flag in ("--frame-rate", "--guide-rate"):
        RATE.check(flag, getattr(a, flag[2:].replace("-", "_")))
    check_pupil_grid(rx, a.pupil, a.fov)
    drift = _pair("--drift", a.drift, RATE_OF_ANGLE)
    offset = _pair("--offset", a.offset, ANGLE)
    GAIN.check("--guide-gain", a.guide_gain)
    GAIN.check("--guide-gain-analog", a.guide_gain_analog)
    SECONDS.check("--guide-pause", a.guide_pause)
    PHOTONS.check("--guide-photons", a.guide_photons)
    READ_NOISE.check("--read-noise", a.read_noise)
    SEED.check("--seed", a.seed)
    SECONDS.check("--held-from", a.held_from)
    BOUND.check("--bound", a.bound)
    SECONDS.check("--regulation", a.regulation)
    names = [n.strip() for n in a.runs.split(",") if n.strip()]
    bad = [n for n in names if n not in RUNS]
    if bad or not names:
        raise InputError(f"--runs {a.runs}: accepted a comma-separated subset of {','.join(RUNS)}")

    n, per_frame = sample_counts(a.duration, 1.0 / a.frame_rate)
    frame_s = per_frame * STEP_S
    end = window_end_s(a.duration, frame_s)
    if end is None:
        raise InputError(f"--duration {a.duration:g}: shorter than one {frame_s:g} s frame (--frame-rate "
                         f"{a.frame_rate:g}); accepted value ≥ {frame_s:g} s")
    if a.regulation > end:
        raise InputError(f"--regulation {a.regulation:g}: the {a.duration:g} s run has no frame or no sample from "
                         f"then on; accepted 0 ≤ value ≤ {end:g} s (the last {frame_s:g} s frame's middle)")
    drifting = [x for x in names if x in DRIFT_RUNS]
    if drifting and a.held_from > window_end_s(a.duration, frame_s, every_sample=False):
        end = window_end_s(a.duration, frame_s, every_sample=False)
        raise InputError(f"--held-from {a.held_from:g}: the {a.duration:g} s run has no frame to measure the held "
                         f"image on; accepted 0 ≤ value ≤ {end:g} s (the last frame's middle)")

    half_mas = a.fov / 2 * rx.pixel_scale_mas
    if drifting and max(abs(v) for v in offset) > half_mas:
        raise InputError(f"--offset {a.offset}: the star starts off the {a.fov}-px detector; accepted |X|, |Y| ≤ "
                         f"{half_mas:.1f} mas (half the detector's field)")
    if "drift" in names and max(abs(o + d * a.duration) for o, d in zip(offset, drift)) > half_mas:
        raise InputError(f"--drift {a.drift} with --offset {a.offset} over {a.duration:g} s: the unguided run's star "
                         f"leaves the {a.fov}-px detector; accepted |offset + drift × duration| ≤ {half_mas:.1f} mas "
                         "on each axis (half the detector's field)")

    _, per_guide = sample_counts(a.duration, 1.0 / a.guide_rate)
    need = memory_bytes(len(names), n, per_frame, per_guide, a.pupil, a.fov)
    if need > MEMORY_BYTES:
        raise InputError(f"--pupil {a.pupil} --fov {a.fov}, {per_frame}-sample frames, {n} samples × {len(names)} "
                         f"run(s): about {need / 2**30:.1f} GiB of arrays, above the {MEMORY_BYTES / 2**30:g} GiB "
                         "bound; use smaller grids, a higher --frame-rate, a shorter --duration or fewer --runs")
    return names, frame_s, drift, offset


def load_prescription(path):
    if path is None:
        return Prescription()
    try:
        return Prescription.load(path)
    except OSError as e:
        raise InputError(f"--prescription {path}: {e.strerror}") from None


def output_folder(text):
    """--out as a folder the run can write its files into (created if missing), or an
    `InputError` saying why not: it is a file, a symlink to nothing or a loop, or it
    cannot be created or written."""
    out = pathlib.Path(text)
    why = None
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        why = e.strerror
        if out.is_symlink():
            try:
                out.stat()
            except OSError as s:
                why = ("a symlink loop" if s.errno == errno.ELOOP
                       else f"a symlink to {os.readlink(out)}, which does not exist")
        elif out.exists() and not out.is_dir():
            why = "a file, not a folder"
    else:
        if not os.access(out, os.W_OK | os.X_OK):
            why = "not writable"
        taken = [n for n in OUTPUTS if (out / n).is_symlink() and not (out / n).exists()
                 or (out / n).exists() and not (out / n).is_file()]
        if taken:
            why = f"{out / taken[0]} is not a file it can write"
    if why:
        raise InputError(f"--out {text}: cannot write the results there: {why}")
    return out


def configs(a, names, frame_s, drift, offset, params):
    from .scenario import RunConfig

    common = dict(duration_s=a.duration, frame_s=frame_s, params=params)
    guide = dict(guide_period_s=1.0 / a.guide_rate, guide_pause_s=a.guide_pause,
                 guide_photons=a.guide_photons or None, guide_read_noise_e=a.read_noise, seed=a.seed)
    all_runs = {
        "stepping": RunConfig("stepping", **common),
        "analog": RunConfig("analog", analog=True, **common),
        "drift": RunConfig("drift", drift_mas_per_s=drift, offset_mas=offset, **common),
        "guided": RunConfig("guided", drift_mas_per_s=drift, offset_mas=offset, guide=True, guide_gain=a.guide_gain,
                            **common, **guide),
        "guided-analog": RunConfig("guided-analog", analog=True, drift_mas_per_s=drift, offset_mas=offset, guide=True,
                                   guide_gain=a.guide_gain_analog, **common, **guide),
    }
    return [all_runs[n] for n in names]


class _Stopped(BaseException):
    """SIGTERM or SIGHUP, raised where the program is, so every `finally` runs (the runs'
    unpacked SSP folders are removed) as Ctrl-C's KeyboardInterrupt does."""

    def __init__(self, signum):
        super().__init__(signum)
        self.signum = signum


@contextlib.contextmanager
def _signals_raise():
    def stop(signum, frame):
        raise _Stopped(signum)

    previous = {}
    try:
        for sig in (signal.SIGTERM, getattr(signal, "SIGHUP", None)):  # no SIGHUP on Windows
            if sig is not None:
                previous[sig] = signal.signal(sig, stop)
    except ValueError:  # not the main thread: the signals keep their handlers
        pass
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _f(value, spec):
    """A figure, or "—" for an empty window's (None)."""
    return "—" if value is None else format(value, spec)


class RunError(Exception):
    """A run that failed after its inputs were accepted (an FMU's refusal, a write)."""


def main(argv=None):
    """The CLI; returns its exit status: 0; 2 for an input it refuses, 1 for a run that
    failed, each with one line on stderr; 130 after Ctrl-C, 128 + the signal after SIGTERM
    or SIGHUP. Every path removes the runs' unpacked SSP folders."""
    try:
        with _signals_raise():
            return command("inchworm-optics", lambda: _main(sys.argv[1:] if argv is None else argv),
                           refused=(InputError,), failed=(RunError,))
    except KeyboardInterrupt:
        print("inchworm-optics: interrupted", file=sys.stderr)
        return 130
    except _Stopped as e:
        print(f"inchworm-optics: stopped by {signal.Signals(e.signum).name}", file=sys.stderr)
        return 128 + e.signum


def _main(argv):
    a = parse_args(argv)
    rx = load_prescription(a.prescription)
    names, frame_s, drift, offset = check_arguments(a, rx)
    ssp = pathlib.Path(a.dist) / "MirrorMount.ssp"
    if not ssp.is_file():
        raise InputError(f"--dist {a.dist}: {ssp} is missing: run `cargo run --release -p fmu-build` first")
    from fmpy.fmi1 import FMICallException

    from .cosim import MountCosim, parse_params

    params = parse_params(ssp, a.param)
    out = output_folder(a.out)  # the last check: it creates the folder
    try:  # none of its files the prescription or the system it reads
        check({f"--out {out / n}": out / n for n in OUTPUTS}, [ssp, *([a.prescription] if a.prescription else [])])
    except OutputError as e:
        raise InputError(str(e)) from None
    from . import figures
    from .optics import Instrument
    from .scenario import figures as run_figures, held, run, ssp_params

    inst = Instrument(rx, npix_pupil=a.pupil, fov_pixels=a.fov)
    runs = configs(a, names, frame_s, drift, offset, params)
    # The FMUs' own checks of the parameters (analog mode needs deadband 0, ...) before the
    # first run: each distinct set initialized once.
    for analog, values in {c.analog: ssp_params(c) for c in runs if params}.items():
        try:
            MountCosim(ssp, values).close()
        except FMICallException as e:
            raise InputError(f"--param {' '.join(a.param)}: the FMUs refused them at initialization"
                             f"{' in analog mode' if analog else ''} ({str(e).rstrip('.')}; the FMU's message is "
                             "on stdout)") from None
    s = rx.summary()
    print(f"Telescope: D = {rx.aperture_m:g} m, f/{s['primary_f_number']:g} primary, secondary m = "
          f"{rx.secondary_magnification:g}, f = {rx.focal_length_m:g} m (f/{rx.f_number:g}), s' = "
          f"{rx.secondary_to_focus_m:.3f} m, obscuration {rx.obscuration_ratio:.2f}; {rx.wavelength_m * 1e9:g} nm, "
          f"{rx.pixel_m * 1e6:g} µm pixels ({rx.pixel_scale_mas:.1f} mas)")
    print(f"  lever: image {rx.lever_m_per_rad:g} m per rad of secondary tilt (sky {rx.sky_per_tilt:g} rad/rad); "
          f"despace -> focus shift x{rx.focus_shift_per_despace:g}, Z4 {rx.focus_z4_m(1e-6) * 1e9:.2f} nm per µm")
    results, numbers = {}, {}
    progress_at = {}

    def progress(name, t, total):
        if t - progress_at.get(name, -1.0) >= 1.0 - 1e-9 or t >= total - 1e-9:
            progress_at[name] = t
            print(f"  {name}: {t:.0f}/{total:g} s", file=sys.stderr, flush=True)

    for cfg in runs:
        wall = time.time()
        try:
            results[cfg.name] = run(ssp, inst, cfg, progress)
        except FMICallException as e:
            raise RunError(f"the {cfg.name} run: an FMU refused a call ({str(e).rstrip('.')})") from None
        numbers[cfg.name] = run_figures(results[cfg.name], inst, a.regulation)
        numbers[cfg.name]["wall_s"] = time.time() - wall
    for name, f in numbers.items():
        print(f"{name} (regulation t >= {a.regulation:g} s, {f['n_frames']} frames of "
              f"{frame_s * 1e3:g} ms; {f['wall_s']:.0f} s wall):")
        print(f"  mount: pointing RMS {_f(f['pointing_rms_parked_nrad'], '.2f')} nrad parked, "
              f"{_f(f['pointing_rms_every_nrad'], '.2f')} nrad every sample; piston RMS "
              f"{_f(f['piston_rms_parked_nm'], '.2f')} nm parked, {_f(f['piston_rms_every_nm'], '.2f')} nm every "
              f"sample (peak {_f(f['piston_peak_every_nm'], '.2f')} nm)")
        if f["n_parked_samples"] == 0:
            print("  (no parked samples in regulation, so the parked figures are empty: the analog loop dithers each "
                  "encoder between two adjacent counts, so none stands still for 8 samples)")
        print(f"  image: RMS {_f(f['image_rms_parked_nm'], '.2f')} nm parked = "
              f"{_f(f['image_over_lever_pointing_parked'], '.4f')} x lever x pointing; "
              f"{_f(f['image_rms_every_nm'], '.2f')} nm every sample = "
              f"{_f(f['image_over_lever_pointing_every'], '.4f')} x lever x pointing")
        print(f"  frames: image motion RMS {_f(f['frame_image_rms_mas'], '.3f')} mas "
              f"({_f(f['frame_image_rms_px'], '.5f')} px), max {_f(f['frame_image_max_mas'], '.3f')} mas; WFE RMS "
              f"{_f(f['frame_wfe_rms_nm'], '.2f')} nm (worst sample {_f(f['frame_wfe_max_nm'], '.1f')} nm); Strehl "
              f"mean {_f(f['frame_strehl_mean'], '.4f')}, min {_f(f['frame_strehl_min'], '.4f')}; EE(1.22 λ/D) "
              f"{_f(f['frame_ee_mean'], '.4f')}")
    for name in DRIFT_RUNS:
        if name in results:
            mx, r = held(results[name], inst, a.held_from)
            numbers[name]["held_max_mas"], numbers[name]["held_rms_mas"] = mx, r
            print(f"{name}: image error from t = {a.held_from:g} s: max {mx:.2f} mas, RMS {r:.2f} mas "
                  f"({'within' if mx <= a.bound else 'exceeds'} the {a.bound:g} mas bound)")

    try:
        figures.write_frames_csv(out / "optics-timeseries.csv", results, inst)
        figures.write_samples_csv(out / "optics-samples.csv", results)
        if {"stepping", "analog"} & set(results):
            figures.timeseries_png(out / "optics-timeseries.png", results, inst)
            figures.psf_strip_png(out / "optics-psf-strip.png", out / "optics-psf-strip.csv", results, inst,
                                  [t for t in (0.0, 1.0, 2.0, 3.0, 4.0, 4.1, 6.0, 9.0) if t < a.duration])
        if set(DRIFT_RUNS) & set(results):
            figures.guidance_png(out / "optics-guidance.png", out / "optics-guidance.csv", results, inst, a.bound,
                                 a.held_from, a.guide_rate)
        with replacing(out / "optics-summary.csv") as f:
            w = csv.writer(f)
            w.writerow(["run", "figure", "value"])
            for name, fig in numbers.items():
                for k, v in fig.items():
                    w.writerow([name, k, "" if v is None else v])  # empty: a window with no samples
        with replacing(out / "optics-prescription.json") as f:
            f.write(json.dumps({**rx.as_dict(), **{"derived": s}}, indent=2))
    except OSError as e:
        raise RunError(f"writing the results into {out}: {e}") from None
    print(f"wrote {out}/optics-*.csv, optics-*.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
