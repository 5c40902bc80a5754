"""`python -m inchworm_segments` (or `inchworm-segments`): every segment's pose at every 2 ms
sample, from a poses CSV (or the seeded synthetic co-phasing run), through the segmented
telescope and a perfect coronagraph; prints the numbers, writes the CSVs and PNGs."""
import argparse
import concurrent.futures
import json
import multiprocessing
import os
import pathlib
import sys
import time
from inchworm_inputs import command
from inchworm_output import OutputError, check, replacing

from .config import (FRAME_MS, RANGES, SAMPLE_S, SEED, SYNTHETIC_S, WORKERS, InputError, Range, Telescope,
                     check_memory, rings_for)

#: The telescope's fields the command takes as options (`--flat-to-flat-m`, ...).
GEOMETRY = ("flat_to_flat_m", "gap_m", "wavelength_m", "pupil_px", "supersampling", "q", "fov_lambda_d",
            "dark_inner_lambda_d", "dark_outer_lambda_d")

#: What the command writes into --out.
OUTPUTS = ("segments-samples.csv", "segments-frames.csv", "segments-timeseries.png", "segments-strip.png",
           "segments-strip.csv", "segments-piston-map.png", "segments-piston-map.csv", "segments-summary.csv",
           "segments-telescope.json")


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise InputError(f"{message} (see --help)")


def parse_args(argv):
    p = _Parser(prog="inchworm-segments", description=__doc__)
    src = p.add_mutually_exclusive_group()
    src.add_argument("--poses", help="poses CSV: time, then seg{k}_piston_m, seg{k}_tip_rad, seg{k}_tilt_rad "
                                     "for every segment, then optionally parked (0/1)")
    src.add_argument("--synthetic", type=float, metavar="SECONDS", default=None,
                     help="no CSV: the seeded synthetic co-phasing run of this many seconds (written to "
                          f"--out/segments-poses.csv), {SYNTHETIC_S}")
    p.add_argument("--rings", type=int, help="rings of segments round the centre with --synthetic (default 1: 7 "
                                             f"segments; 2: 19; 3: 37), {RANGES['rings']}")
    p.add_argument("--no-centre", action="store_true",
                   help="with --synthetic: leave the central segment out (with --poses the count of segments says)")
    p.add_argument("--seed", type=int, default=2026, help=f"the synthetic run's seed, {SEED}")
    p.add_argument("--out", default="out/segments", help="folder for the CSVs and PNGs")
    p.add_argument("--regulation-from", type=float, metavar="SECONDS", default=None,
                   help="also the regulation's numbers: every sample from this time on, its parked samples, and "
                        "the frames that start then or later; 0 ≤ value ≤ the run's last time, s")
    p.add_argument("--frame-ms", type=float, default=50.0,
                   help=f"frame exposure, {FRAME_MS} (a whole number of 2 ms samples)")
    p.add_argument("--workers", type=int, default=min(os.cpu_count() or 1, WORKERS.hi),
                   help=f"local processes for the frames (1: serial; the numbers are the same bit for bit), {WORKERS}")
    for name in GEOMETRY:
        default = getattr(Telescope, name)
        p.add_argument("--" + name.replace("_", "-"), type=type(default), default=default,
                       help=f"telescope: default {default:g}, accepted {RANGES[name]} ({RANGES[name].why})")
    return p.parse_args(argv)


def option(name):
    return "--" + name.replace("_", "-")


def _frame_samples(frame_ms):
    frame_ms = FRAME_MS.check("--frame-ms", frame_ms)
    n = frame_ms * 1e-3 / SAMPLE_S
    if abs(n - round(n)) >= 1e-9 or round(n) < 1:
        raise InputError(f"--frame-ms {frame_ms:g}: accepted a whole number of {SAMPLE_S * 1e3:g} ms samples, at "
                         f"least one ({FRAME_MS})")
    return int(round(n))


def check_options(args):
    """Every numeric option in its range (`config`), before any file is read: (frame
    samples, {telescope field: value})."""
    frame_samples = _frame_samples(args.frame_ms)
    WORKERS.check("--workers", args.workers)
    geometry = {k: RANGES[k].check(option(k), getattr(args, k)) for k in GEOMETRY}
    if args.poses:
        if args.rings is not None or args.no_centre:
            raise InputError("--rings and --no-centre are for --synthetic; with --poses the CSV's segment count says")
    else:
        if args.synthetic is not None:
            SYNTHETIC_S.check("--synthetic", args.synthetic)
        if args.rings is not None:
            RANGES["rings"].check("--rings", args.rings)
    SEED.check("--seed", args.seed)
    if args.regulation_from is not None:
        Range(0.0, unit="s").check("--regulation-from", args.regulation_from)
    return frame_samples, geometry


def prepare(args):
    """(telescope, t, poses, parked, frame_samples) from the arguments, or an InputError:
    every option in its range, then the poses (read and checked, or drawn), then what
    depends on both (--regulation-from within the run, a frame, the memory bound)."""
    from . import poses as P

    frame_samples, geometry = check_options(args)
    if args.poses:
        t, poses, parked = P.read_csv(args.poses)
        rings, centre = rings_for(poses.shape[1])
        tel = Telescope(rings=rings, centre=centre, **geometry)
    else:
        duration = 2.0 if args.synthetic is None else args.synthetic
        rings, centre = (1 if args.rings is None else args.rings), not args.no_centre
        tel = Telescope(rings=rings, centre=centre, **geometry)
        check_memory(tel, max(1, int(round(duration / SAMPLE_S))), frame_samples, args.workers)
        t, poses, parked = P.synthetic(tel.segment_count, duration, seed=args.seed)
    if parked is None:
        import numpy as np

        parked = np.zeros(len(t), dtype=bool)
    if args.regulation_from is not None:
        Range(0.0, float(t[-1]), unit="s", why="the run's last time").check("--regulation-from", args.regulation_from)
    if len(t) < frame_samples:
        raise InputError(f"{len(t)} samples: accepted at least one frame ({frame_samples} samples of --frame-ms "
                         f"{args.frame_ms:g})")
    check_memory(tel, len(t), frame_samples, args.workers)
    return tel, t, poses, parked, frame_samples


def run(args):
    from . import figures
    from . import frames as F
    from . import poses as P

    tel, t, poses, parked, frame_samples = prepare(args)
    out = pathlib.Path(args.out)
    # Before any work: every file it writes in --out, none of them the --poses it reads.
    names = [*(() if args.poses else ("segments-poses.csv",)), *OUTPUTS]
    check({f"--out {out / n}": out / n for n in names}, [args.poses] if args.poses else [])
    if not args.poses:
        P.write_csv(out / "segments-poses.csv", t, poses, parked)
    start = time.time()
    optics = F.optics_for(tel)  # built before the workers fork, so they inherit it
    if args.workers > 1:
        ctx = multiprocessing.get_context("fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn")
        with concurrent.futures.ProcessPoolExecutor(args.workers, mp_context=ctx) as pool:
            result = F.run(tel, t, poses, parked, frame_samples, executor=pool)
    else:
        result = F.run(tel, t, poses, parked, frame_samples)
    elapsed = time.time() - start
    numbers = figures.summary(result, args.regulation_from)
    figures.timeseries(out / "segments-timeseries.png", out / "segments-samples.csv", out / "segments-frames.csv", result)
    figures.strip(out / "segments-strip.png", out / "segments-strip.csv", result, optics)
    figures.piston_map(out / "segments-piston-map.png", out / "segments-piston-map.csv", result, optics)
    figures.write_summary_csv(out / "segments-summary.csv", numbers)
    with replacing(out / "segments-telescope.json") as f:
        f.write(json.dumps({**tel.as_dict(), "diameter_m": tel.diameter_m,
                            "segment_count": tel.segment_count}, indent=1) + "\n")
    for k, v in numbers.items():
        print(f"{k:28s} {'—' if v is None else format(v, '.4g') if isinstance(v, float) else v}")
    print(f"{'optics_s':28s} {elapsed:.3g} ({args.workers} worker{'s' if args.workers > 1 else ''})")
    return 0


def main(argv=None):
    return command("inchworm-segments", lambda: run(parse_args(sys.argv[1:] if argv is None else argv)),
                   refused=(InputError, OutputError))


if __name__ == "__main__":
    sys.exit(main())
