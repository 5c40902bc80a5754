"""`python -m inchworm_optics` (or `inchworm-optics`): the mirror mount's scenario through
the telescope, for the paper's stepping controller and analog mode near the target, and
the fine-guidance loop against a line-of-sight drift; prints the numbers, writes the CSVs
and PNGs."""
import argparse
import csv
import json
import pathlib
import sys
import time

from . import figures
from .optics import Instrument
from .scenario import REGULATION_S, RunConfig, figures as run_figures, held, run
from .telescope import Prescription

RUNS = ("stepping", "analog", "drift", "guided", "guided-analog")


def parse_args(argv):
    p = argparse.ArgumentParser(prog="inchworm-optics", description=__doc__)
    p.add_argument("--dist", default="dist", help="folder with MirrorMount.ssp (cargo run --release -p fmu-build)")
    p.add_argument("--out", default="out/optics", help="folder for the CSVs and PNGs")
    p.add_argument("--prescription", help="JSON file of telescope parameters (telescope.Prescription's fields)")
    p.add_argument("--duration", type=float, default=10.0, help="seconds simulated (default 10: the SSP's scenario)")
    p.add_argument("--frame-rate", type=float, default=20.0, help="detector frames per second (default 20)")
    p.add_argument("--pupil", type=int, default=48, help="pupil grid, pixels across (default 48)")
    p.add_argument("--fov", type=int, default=48, help="detector pixels across (default 48)")
    p.add_argument("--runs", default=",".join(RUNS), help=f"comma-separated subset of {','.join(RUNS)}")
    p.add_argument("--drift", default="20,10", help="line-of-sight drift x,y in mas/s for the drift and guided runs")
    p.add_argument("--offset", default="0,0", help="constant line-of-sight offset x,y in mas for the drift and guided runs")
    p.add_argument("--guide-rate", type=float, default=10.0, help="guide frames per second (default 10)")
    p.add_argument("--guide-gain", type=float, default=0.2,
                   help="guider integrator gain with the stepping controller (default 0.2: it moves every 0.2 s)")
    p.add_argument("--guide-gain-analog", type=float, default=0.5,
                   help="guider integrator gain with analog mode (default 0.5)")
    p.add_argument("--guide-pause", type=float, default=0.4,
                   help="seconds the guider holds its offset after a commanded move (default 0.4)")
    p.add_argument("--guide-photons", type=float, default=2e5, help="photo-electrons per guide frame (0: noiseless)")
    p.add_argument("--read-noise", type=float, default=5.0, help="read noise per pixel, electrons")
    p.add_argument("--seed", type=int, default=2026)
    p.add_argument("--held-from", type=float, default=5.0, help="measure how well the image is held from this time")
    p.add_argument("--bound", type=float, default=20.0, help="stated bound on the guided image error, mas")
    p.add_argument("--regulation", type=float, default=REGULATION_S, help="regulation from this time (s)")
    p.add_argument("--param", action="append", default=[], metavar="COMPONENT.VARIABLE=VALUE",
                   help="set an SSP parameter in every run, as `inchworm run --param` (repeatable)")
    return p.parse_args(argv)


def _value(text):
    if text in ("true", "false"):
        return text == "true"
    try:
        return int(text)
    except ValueError:
        return float(text)


def configs(a):
    drift = tuple(float(v) for v in a.drift.split(","))
    offset = tuple(float(v) for v in a.offset.split(","))
    params = {}
    for p in a.param:
        name, _, text = p.partition("=")
        params[name.strip()] = _value(text.strip())
    frame_s = 1.0 / a.frame_rate
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
    names = [n.strip() for n in a.runs.split(",") if n.strip()]
    bad = [n for n in names if n not in all_runs]
    if bad:
        raise SystemExit(f"unknown run(s) {bad}: choose from {list(all_runs)}")
    return [all_runs[n] for n in names]


def main(argv=None):
    a = parse_args(sys.argv[1:] if argv is None else argv)
    rx = Prescription.load(a.prescription) if a.prescription else Prescription()
    ssp = pathlib.Path(a.dist) / "MirrorMount.ssp"
    if not ssp.exists():
        raise SystemExit(f"{ssp} is missing: run `cargo run --release -p fmu-build` first")
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    inst = Instrument(rx, npix_pupil=a.pupil, fov_pixels=a.fov)
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

    for cfg in configs(a):
        wall = time.time()
        results[cfg.name] = run(ssp, inst, cfg, progress)
        numbers[cfg.name] = run_figures(results[cfg.name], inst, a.regulation)
        numbers[cfg.name]["wall_s"] = time.time() - wall
    for name, f in numbers.items():
        print(f"{name} (regulation t >= {a.regulation:g} s, {f['n_frames']} frames of "
              f"{1e3 / a.frame_rate:.0f} ms; {f['wall_s']:.0f} s wall):")
        print(f"  mount: pointing RMS {f['pointing_rms_parked_nrad']:.2f} nrad parked, "
              f"{f['pointing_rms_every_nrad']:.2f} nrad every sample; piston RMS {f['piston_rms_parked_nm']:.2f} nm "
              f"parked, {f['piston_rms_every_nm']:.2f} nm every sample (peak {f['piston_peak_every_nm']:.2f} nm)")
        if f["n_parked_samples"] == 0:
            print("  (no parked samples: the analog loop dithers each encoder between two adjacent counts, so "
                  "none stands still for 8 samples)")
        print(f"  image: RMS {f['image_rms_parked_nm']:.2f} nm parked = {f['image_over_lever_pointing_parked']:.4f} x "
              f"lever x pointing; {f['image_rms_every_nm']:.2f} nm every sample = "
              f"{f['image_over_lever_pointing_every']:.4f} x lever x pointing")
        print(f"  frames: image motion RMS {f['frame_image_rms_mas']:.3f} mas ({f['frame_image_rms_px']:.5f} px), "
              f"max {f['frame_image_max_mas']:.3f} mas; WFE RMS {f['frame_wfe_rms_nm']:.2f} nm (worst sample "
              f"{f['frame_wfe_max_nm']:.1f} nm); Strehl mean {f['frame_strehl_mean']:.4f}, min "
              f"{f['frame_strehl_min']:.4f}; EE(1.22 λ/D) {f['frame_ee_mean']:.4f}")
    held_numbers = {}
    for name in ("drift", "guided", "guided-analog"):
        if name in results:
            mx, r = held(results[name], inst, a.held_from)
            held_numbers[name] = (mx, r)
            numbers[name]["held_max_mas"], numbers[name]["held_rms_mas"] = mx, r
            print(f"{name}: image error from t = {a.held_from:g} s: max {mx:.2f} mas, RMS {r:.2f} mas "
                  f"({'within' if mx <= a.bound else 'exceeds'} the {a.bound:g} mas bound)")

    figures.write_frames_csv(out / "optics-timeseries.csv", results, inst)
    figures.write_samples_csv(out / "optics-samples.csv", results)
    if {"stepping", "analog"} & set(results):
        figures.timeseries_png(out / "optics-timeseries.png", results, inst)
        figures.psf_strip_png(out / "optics-psf-strip.png", out / "optics-psf-strip.csv", results, inst,
                              [t for t in (0.0, 1.0, 2.0, 3.0, 4.0, 4.1, 6.0, 9.0) if t < a.duration])
    if {"drift", "guided", "guided-analog"} & set(results):
        figures.guidance_png(out / "optics-guidance.png", out / "optics-guidance.csv", results, inst, a.bound,
                             a.held_from, a.guide_rate)
    with open(out / "optics-summary.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["run", "figure", "value"])
        for name, fig in numbers.items():
            for k, v in fig.items():
                w.writerow([name, k, v])
    (out / "optics-prescription.json").write_text(json.dumps({**rx.as_dict(), **{"derived": s}}, indent=2))
    print(f"wrote {out}/optics-*.csv, optics-*.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
