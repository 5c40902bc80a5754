"""The accepted range of every input, each stated once: the CLI's arguments (`__main__`)
and the prescription's fields (`telescope.Prescription`) are checked against these before
the first run, and `docs/optics.md` ("Accepted inputs") lists them. A value outside its
range is an `InputError` whose message names the input and the range. `Range` and
`InputError` are `inchworm_inputs`' (python/inchworm_inputs), the one implementation the
packages share.

No numpy, poppy or FMPy here: the CLI refuses a bad argument before importing them.
"""
from inchworm_inputs import InputError, Range  # noqa: F401 (InputError: this package's, for its callers)

#: The SSP's communication step: one sample of the mount's pose every 2 ms.
STEP_S = 0.002
#: Regulation: from this time on, as `inchworm scenario mirror` measures it.
REGULATION_S = 8.0


# ---- the command line ----
DURATION = Range(0.0, 3600.0, lo_open=True, unit="s",
                 why="an hour is 1.8 M samples a run, about 1.7 h of CPU each")
RATE = Range(0.0, 1.0 / STEP_S, lo_open=True, unit="Hz",
             why=f"a frame integrates a whole number of the {STEP_S * 1e3:g} ms samples, at least one")
GRID = Range(8, 1024, unit="px", integer=True,
             why="8 px resolve the annular pupil and the PSF's core; the run's arrays must also fit the memory bound")
ANGLE = Range(unit="mas", why="each of X,Y")
RATE_OF_ANGLE = Range(unit="mas/s", why="each of X,Y")
GAIN = Range(0.0, 2.0, lo_open=True, hi_open=True,
             why="an integrator on the calibrated centroid: it converges only for 0 < gain < 2")
SECONDS = Range(0.0, unit="s")
PHOTONS = Range(0.0, 1e15, unit="e-",
                why="0 is noiseless; numpy's Poisson draw overflows near 1e19 and at 1e15 the noise is 3e-8 of the signal")
READ_NOISE = Range(0.0, unit="e-")
SEED = Range(0, integer=True)
BOUND = Range(0.0, lo_open=True, unit="mas")

#: What one invocation's arrays may hold, bytes: a run the estimate (`memory_bytes`) puts
#: above it is refused before it starts instead of failing in an allocation part-way
#: (or swapping the machine). 4 GiB: a quarter of a 16 GB workstation.
MEMORY_BYTES = 4 << 30
#: What one 2 ms sample keeps until the run's results are written: its Python records
#: (time, pose, command, encoders, centroid: 576 bytes measured with tracemalloc) and
#: their arrays (105), rounded up.
SAMPLE_BYTES = 1000


def sample_counts(duration_s, period_s):
    """(samples in the run, samples in a frame of `period_s`), as `scenario.run` counts them."""
    return int(round(duration_s / STEP_S)), max(1, int(round(period_s / STEP_S)))


def last_frame(duration_s, frame_s):
    """(start, end) of a run's last frame, in `scenario.run`'s arithmetic; None if the run
    is shorter than a frame."""
    n, per = sample_counts(duration_s, frame_s)
    if n < per:
        return None
    end = (n // per * per - 1) * STEP_S + STEP_S  # the sample k closing it, k h + h
    return end - per * STEP_S, end


def window_end_s(duration_s, frame_s, every_sample=True):
    """The latest start of a window (regulation, hold) that still holds a frame (by its
    middle) and, with `every_sample`, a sample; None if the run has no frame."""
    frame = last_frame(duration_s, frame_s)
    if frame is None:
        return None
    mid = (frame[0] + frame[1]) / 2
    n, _ = sample_counts(duration_s, frame_s)
    return min(mid, (n - 1) * STEP_S) if every_sample else mid


def memory_bytes(runs, samples, per_frame, per_guide, pupil, fov):
    """An upper estimate of the bytes the runs hold at once (`scenario.run`): every run's
    per-sample records and frame images (kept for the figures and CSVs); the frame being
    integrated, each of its samples' pupil field (complex), OPD and image twice (the lists
    and the `Frame`'s stacked copies) and the WFE fit's three OPD-sized temporaries; the
    guide frame's images; one transform's matrices."""
    n2, f2 = pupil**2, fov**2
    kept = runs * (samples * SAMPLE_BYTES + samples // per_frame * 8 * f2)
    frame = per_frame * (2 * (16 * n2 + 8 * n2 + 8 * f2) + 3 * 8 * n2)
    return kept + frame + per_guide * 8 * f2 + 16 * (2 * pupil * fov + 2 * f2)


# ---- the prescription ----
#: The largest prescription file read, bytes: its eight fields take a few hundred.
MAX_PRESCRIPTION_BYTES = 1 << 20
#: The prescription's fields with a range of their own; `back_focal_distance_m` and
#: `obscuration_m` depend on the others (`back_focal_range`, `obscuration_range`).
#: Each bounded to what a telescope can be, so that no product of them overflows a float
#: (a focal length of 1e308 m would): from a finder to past an ELT's 39 m, from the far
#: ultraviolet to the submillimetre.
PRESCRIPTION = {
    "aperture_m": Range(1e-3, 100.0, unit="m", why="a finder to past an ELT's 39 m"),
    "primary_focal_length_m": Range(1e-3, 1e3, unit="m"),
    "secondary_magnification": Range(0.0, 1e3, lo_open=True,
                                     why="the secondary sits before the primary focus and images it beyond"),
    "wavelength_m": Range(1e-8, 1e-3, unit="m", why="far ultraviolet to submillimetre"),
    "pixel_m": Range(1e-7, 1e-2, unit="m"),
    "focus_piston_m": Range(-1.0, 1.0, unit="m"),
}


def back_focal_range(primary_focal_length_m, magnification):
    """−f1 < b < m f1: the secondary between the primary and its focus (0 < d < f1)."""
    f1, m = primary_focal_length_m, magnification
    return Range(-f1, m * f1, lo_open=True, hi_open=True, unit="m",
                 why="−f1 < b < m f1 puts the secondary between the primary and its focus")


def obscuration_range(aperture_m):
    """0 ≤ obscuration < D: some of the aperture passes light."""
    return Range(0.0, aperture_m, hi_open=True, unit="m", why="0 ≤ obscuration < aperture: some light passes")


def check_prescription(rx):
    """Every field of a prescription in its range, or an `InputError` naming the first not."""
    for name, rng in PRESCRIPTION.items():
        rng.check(name, getattr(rx, name))
    back_focal_range(rx.primary_focal_length_m, rx.secondary_magnification).check(
        "back_focal_distance_m", rx.back_focal_distance_m)
    obscuration_range(rx.aperture_m).check("obscuration_m", rx.obscuration_m)


def check_pupil_grid(rx, pupil, fov):
    """The grids in `GRID`, and the pupil grid resolving the annulus: at least one grid
    pixel (D / pupil) of light from the obscuration to the rim, obscuration ≤ D (1 − 2 /
    pupil). A thinner annulus is poppy's grey edge pixels only, not the pupil."""
    GRID.check("--pupil", pupil)
    GRID.check("--fov", fov)
    Range(0.0, rx.aperture_m * (1.0 - 2.0 / pupil), unit="m",
          why=f"with --pupil {pupil}: one grid pixel of light across the annulus, "
              "obscuration ≤ aperture × (1 − 2 / pupil)").check("obscuration_m", rx.obscuration_m)
