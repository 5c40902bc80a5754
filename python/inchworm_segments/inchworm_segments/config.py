"""The segmented telescope's parameters, the accepted range of every input of the package
and its geometry's closed forms. Plain Python (no numpy, no hcipy): the CLI checks its
arguments before importing them.

Every range is stated once, here: the telescope's fields (`RANGES`), the command's options,
the poses' values, the synthetic run's parameters and the memory bound. A value outside its
range is an `InputError` whose message names the input, the value, the range and its unit
(`pupil_px 2000: accepted an integer, 16 ≤ value ≤ 1024 px (pixels across D)`). `Range`,
`InputError` and the format are `inchworm_inputs`' (python/inchworm_inputs), the one
implementation every package shares.

The aperture is hcipy's hexagonal segmented aperture: flat-topped hexagons (a vertex on
the x axis) of flat-to-flat width s, on a hexagonal lattice of pitch s + gap, in `rings`
rings round the centre (1: 7 segments, 2: 19, 3: 37, 3 R (R + 1) + 1 in general); with
`centre=False` the central segment is left out (where a secondary's shadow or a
Cassegrain hole would be: 6, 18, 36 segments). D, the diameter that λ/D refers to, is the
aperture's circumscribed circle, the distance across its two farthest vertices.
"""
from dataclasses import dataclass, fields
import math

from inchworm_inputs import InputError, Range, _g

#: The engine's communication step: one pose of every segment every 2 ms.
SAMPLE_S = 0.002

#: The telescope's fields, closed ranges; the reasons are in docs/segments.md.
RANGES = {
    "rings": Range(1, 6, integer=True, unit="rings",
                   why="rings of segments round the centre: 6 rings is 127 segments"),
    "flat_to_flat_m": Range(1e-3, 20.0, unit="m", why="a segment's width across its flats"),
    "gap_m": Range(0.0, 1.0, unit="m", why="between neighbouring segments"),
    "wavelength_m": Range(100e-9, 20e-6, unit="m", why="ultraviolet to thermal infrared"),
    "pupil_px": Range(16, 1024, integer=True, unit="px", why="pixels across D"),
    "supersampling": Range(1, 16, integer=True, unit="sub-pixels",
                           why="per pupil pixel and axis, for the grey edges"),
    "q": Range(1, 16, integer=True, unit="px per λ/D", why="the focal plane's sampling"),
    "fov_lambda_d": Range(2.0, 200.0, unit="λ/D", why="from the axis to the field's edge"),
    "dark_inner_lambda_d": Range(0.0, 200.0, unit="λ/D", why="the dark zone's inner radius"),
    "dark_outer_lambda_d": Range(0.5, 200.0, unit="λ/D", why="the dark zone's outer radius"),
}


def check_range(name, value):
    """`value` of the telescope's field `name` in its range (`RANGES`), or an InputError."""
    return RANGES[name].check(name, value)


# ---- the command's options, the poses and the synthetic run ----
#: The longest run, s: --synthetic, and the longest frame.
LONGEST_RUN_S = 3600.0
SYNTHETIC_S = Range(0.0, LONGEST_RUN_S, lo_open=True, unit="s",
                    why=f"an hour is {LONGEST_RUN_S / SAMPLE_S / 1e6:g} M samples")
FRAME_MS = Range(0.0, LONGEST_RUN_S * 1e3, lo_open=True, unit="ms",
                 why=f"a whole number of the {SAMPLE_S * 1e3:g} ms samples, at least one")
FRAME_SAMPLES = Range(1, round(LONGEST_RUN_S / SAMPLE_S), integer=True, unit="samples",
                      why="a frame of the longest run at most")
#: Frames each task of `frames.run` computes: one to a whole run's.
FRAMES_PER_TASK = Range(1, round(LONGEST_RUN_S / SAMPLE_S), integer=True, unit="frames")
WORKERS = Range(1, 256, integer=True, unit="processes",
                why="1 computes the frames serially; each process holds the telescope's optics")
SEED = Range(0, integer=True, why="numpy's seed sequence takes non-negative integers")
#: The frames of the strip figure.
STRIP_FRAMES = Range(1, 64, integer=True, unit="frames", why="a strip of frames side by side")
#: A telescope's segment count (`poses.header`, `poses.synthetic`): 6 rings with the centre.
SEGMENTS = Range(1, 127, integer=True, unit="segments")
#: A sample's time: the step check holds the 2 ms step to 3 ns up to 1e6 s (11.6 days).
TIME_S = Range(0.0, 1e6, unit="s", why="a run from 0 s; the 2 ms step is held to 3 ns up to 11.6 days")
#: A segment's pose: the `InchwormMount` FMU's range of its offsets (its parameters
#: piston_offset, tip_offset and tilt_offset), so that no product of them overflows.
PISTON_M = Range(-1.0, 1.0, unit="m", why="the InchwormMount's range of its piston offset")
TIP_TILT_RAD = Range(-1.0, 1.0, unit="rad", why="the InchwormMount's range of its tip and tilt offsets")
POSE_RANGES = (PISTON_M, TIP_TILT_RAD, TIP_TILT_RAD)
#: The synthetic run's draws (RMS) and its settling: far inside the poses' ranges.
SYNTHETIC_PISTON_M = Range(0.0, 1e-3, unit="m", why="an RMS of the synthetic run, far inside ±1 m")
SYNTHETIC_TILT_RAD = Range(0.0, 1e-3, unit="rad", why="an RMS of the synthetic run, far inside ±1 rad")
SETTLE_S = Range(0.0, LONGEST_RUN_S, lo_open=True, unit="s", why="the mounts' time constant")

#: What one invocation's arrays may hold, bytes: a run the estimate (`memory_bytes`) puts
#: above it is refused before it starts instead of failing in an allocation part-way (or
#: swapping the machine). 4 GiB, a quarter of a 16 GB workstation, as inchworm_optics'.
MEMORY_BYTES = 4 << 30


def focal_px(q, fov_lambda_d):
    """Focal-plane pixels across: hcipy's `make_focal_grid` makes 2 q fov (rounded)."""
    return int(round(2 * q * fov_lambda_d))


def memory_bytes(tel, samples, frame_samples, workers=1):
    """An upper estimate of the bytes a run holds at once (`frames.run`, `figures`).
    The optics, once per process (`optics.SegmentedOptics`): the segments' coverage, dense
    (N × pupil², 8 bytes each), hcipy's sparse copy and the pieces' arrays (about 8 arrays of
    up to 2 pupil² pieces), the focal plane's coordinates, flat PSF and dark zone (8 arrays of
    focal²) and the propagator's matrices (the workers fork with it). A frame being computed,
    in each process: each of its
    samples' OPD, phasors and fields (8 + 16 + 16 bytes a piece), the coronagraph's and the
    propagator's fields (3 × 16 pupil²) and the images (4 × 16 focal²). Kept for the figures:
    every sample's poses (twice: the input and its framed view, 24 N bytes) and numbers
    (64 bytes) and every frame's image (8 focal²), and the strip's."""
    n, p2 = tel.segment_count, tel.pupil_px**2
    f2 = focal_px(tel.q, tel.fov_lambda_d) ** 2
    optics = 8 * n * p2 + 8 * 8 * 2 * p2 + 8 * 8 * f2 + 2 * 16 * tel.pupil_px * math.isqrt(f2)
    frame = frame_samples * (2 * p2 * (8 + 16 + 16) + 3 * 16 * p2 + 4 * 16 * f2)
    kept = samples * (2 * 24 * n + 64) + (samples // frame_samples + 6) * 8 * f2
    return optics + workers * frame + kept


def check_memory(tel, samples, frame_samples, workers=1):
    """The run within `MEMORY_BYTES`, or an InputError naming what sets its size."""
    need = memory_bytes(tel, samples, frame_samples, workers)
    if need > MEMORY_BYTES:
        raise InputError(
            f"--pupil-px {tel.pupil_px} --q {tel.q} --fov-lambda-d {tel.fov_lambda_d:g}, {tel.segment_count} "
            f"segments, {frame_samples}-sample frames, {samples} samples, --workers {workers}: about "
            f"{need / 2**30:.1f} GiB of arrays, above the {MEMORY_BYTES / 2**30:g} GiB bound; use a smaller pupil "
            "or focal plane, shorter frames, fewer samples or fewer workers")


@dataclass(frozen=True)
class Telescope:
    """A segmented telescope and the sampling of its optics. The defaults: one ring of
    seven 150 mm segments (each on an inchworm mount whose actuators sit 50 mm from the
    segment's centre) with 3 mm gaps, 550 nm, a 96-pixel pupil, a focal plane at 2 pixels
    per λ/D out to 12 λ/D and the dark zone 3-10 λ/D."""

    rings: int = 1
    centre: bool = True
    flat_to_flat_m: float = 0.15
    gap_m: float = 0.003
    wavelength_m: float = 550e-9
    pupil_px: int = 96
    supersampling: int = 4
    q: int = 2
    fov_lambda_d: float = 12.0
    dark_inner_lambda_d: float = 3.0
    dark_outer_lambda_d: float = 10.0

    def __post_init__(self):
        # Each field in its range, stored as the checked number (an int where the range is
        # of integers, so that 48.0 and numpy's int64 are the 48 hcipy's grids take).
        for f in fields(self):
            if f.name in RANGES:
                object.__setattr__(self, f.name, check_range(f.name, getattr(self, f.name)))
        if not isinstance(self.centre, bool):
            raise InputError(f"centre {self.centre!r}: accepted true or false")
        Range(0.0, self.flat_to_flat_m, hi_open=True, unit="m",
              why=f"below flat_to_flat_m, {self.flat_to_flat_m:g} m: the segments do not overlap").check(
            "gap_m", self.gap_m)
        Range(self.dark_inner_lambda_d, self.fov_lambda_d, lo_open=True, unit="λ/D",
              why=f"the dark zone from its inner radius, {self.dark_inner_lambda_d:g} λ/D, to at most the field's "
                  f"edge, fov_lambda_d {self.fov_lambda_d:g} λ/D").check("dark_outer_lambda_d", self.dark_outer_lambda_d)
        if self.segment_px < 4:
            least = math.ceil(4 * self.diameter_m / self.flat_to_flat_m)
            Range(least, RANGES["pupil_px"].hi, integer=True, unit="px",
                  why=f"a segment at least 4 pixels across; it is {self.segment_px:.1f} at {self.pupil_px}").check(
                "pupil_px", self.pupil_px)

    # ---- geometry ----
    @property
    def segment_count(self):
        """3 R (R + 1) + 1 segments, one fewer without the centre."""
        return 3 * self.rings * (self.rings + 1) + (1 if self.centre else 0)

    @property
    def pitch_m(self):
        return self.flat_to_flat_m + self.gap_m

    @property
    def diameter_m(self):
        """D: twice the farthest vertex from the axis. The outermost ring's corner segment
        sits at R pitches along a lattice direction (30° from x for these flat-topped
        segments); its farthest vertex is then √(R² p² + R p c √3 + c²) from the axis,
        c = s / √3 the segment's circumradius (law of cosines, the vertex 30° off the
        centre's direction)."""
        r, p, c = self.rings, self.pitch_m, self.flat_to_flat_m / math.sqrt(3.0)
        return 2.0 * math.sqrt((r * p) ** 2 + r * p * c * math.sqrt(3.0) + c**2)

    @property
    def segment_px(self):
        """Pupil pixels across a segment, flat to flat."""
        return self.flat_to_flat_m / self.diameter_m * self.pupil_px

    @property
    def lambda_over_d_rad(self):
        return self.wavelength_m / self.diameter_m

    def tilt_shift_lambda_d(self, tilt_rad):
        """Where a segment's light moves when the segment tilts by `tilt_rad` (a slope of its
        surface, toward the incoming light): reflection doubles it, the reflected beam turns
        by −2 θ (away from the side that came forward) and its image moves by −2 θ f on the
        detector, −2 θ D / λ in λ/D. `tilt_rad` in the poses' range (`TIP_TILT_RAD`)."""
        return -2.0 * TIP_TILT_RAD.check("tilt_rad", tilt_rad) / self.lambda_over_d_rad

    def as_dict(self):
        return {f.name: getattr(self, f.name) for f in fields(self)}


def rings_for(segment_count):
    """(rings, centre) of a segment count, or an InputError: 3 R (R + 1) + 1 with the centre,
    3 R (R + 1) without it."""
    for r in range(1, RANGES["rings"].hi + 1):
        full = 3 * r * (r + 1)
        if segment_count == full + 1:
            return r, True
        if segment_count == full:
            return r, False
    raise InputError(f"{_g(segment_count)} segments: accepted 3 R (R + 1) + 1 (7, 19, 37, ...) with the centre or "
                     f"3 R (R + 1) (6, 18, 36, ...) without it, R ≤ {RANGES['rings'].hi}")
