"""The segmented telescope's parameters, their accepted ranges and its geometry's closed
forms. Plain Python (no numpy, no hcipy): the CLI checks its arguments before importing them.

The aperture is hcipy's hexagonal segmented aperture: flat-topped hexagons (a vertex on
the x axis) of flat-to-flat width s, on a hexagonal lattice of pitch s + gap, in `rings`
rings round the centre (1: 7 segments, 2: 19, 3: 37, 3 R (R + 1) + 1 in general); with
`centre=False` the central segment is left out (where a secondary's shadow or a
Cassegrain hole would be: 6, 18, 36 segments). D, the diameter that λ/D refers to, is the
aperture's circumscribed circle, the distance across its two farthest vertices.
"""
from dataclasses import dataclass, fields
import math

#: The engine's communication step: one pose of every segment every 2 ms.
SAMPLE_S = 0.002


class InputError(ValueError):
    """An input the optics cannot use; the message names it and what is accepted."""


#: name: (lo, hi, integer, unit). Closed ranges; the reasons are in docs/segments.md.
RANGES = {
    "rings": (1, 6, True, "rings of segments round the centre"),
    "flat_to_flat_m": (1e-3, 20.0, False, "m"),
    "gap_m": (0.0, 1.0, False, "m"),
    "wavelength_m": (100e-9, 20e-6, False, "m"),
    "pupil_px": (16, 1024, True, "pixels across D"),
    "supersampling": (1, 16, True, "sub-pixels per pupil pixel and axis for the grey edges"),
    "q": (1, 16, True, "focal-plane pixels per λ/D"),
    "fov_lambda_d": (2.0, 200.0, False, "λ/D from the axis to the field's edge"),
    "dark_inner_lambda_d": (0.0, 200.0, False, "λ/D"),
    "dark_outer_lambda_d": (0.5, 200.0, False, "λ/D"),
}


def check_range(name, value):
    lo, hi, integer, unit = RANGES[name]
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    ok = number and math.isfinite(value) and lo <= value <= hi and (not integer or float(value).is_integer())
    if not ok:
        kind = "an integer" if integer else "a number"
        raise InputError(f"{name} {value!r}: accepted {kind} {lo:g} ≤ value ≤ {hi:g} ({unit})")
    return value


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
        for f in fields(self):
            if f.name in RANGES:
                check_range(f.name, getattr(self, f.name))
        if not isinstance(self.centre, bool):
            raise InputError(f"centre {self.centre!r}: accepted true or false")
        if self.gap_m >= self.flat_to_flat_m:
            raise InputError(f"gap_m {self.gap_m:g}: accepted below flat_to_flat_m ({self.flat_to_flat_m:g} m)")
        if not self.dark_inner_lambda_d < self.dark_outer_lambda_d <= self.fov_lambda_d:
            raise InputError(f"dark zone {self.dark_inner_lambda_d:g}-{self.dark_outer_lambda_d:g} λ/D: accepted "
                             f"inner < outer ≤ fov_lambda_d ({self.fov_lambda_d:g})")
        if self.segment_px < 4:
            raise InputError(f"pupil_px {self.pupil_px}: a segment is {self.segment_px:.1f} pixels across; "
                             f"accepted at least 4 (pupil_px ≥ {math.ceil(4 * self.diameter_m / self.flat_to_flat_m)})")

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
        detector, −2 θ D / λ in λ/D."""
        return -2.0 * tilt_rad / self.lambda_over_d_rad

    def as_dict(self):
        return {f.name: getattr(self, f.name) for f in fields(self)}


def rings_for(segment_count):
    """(rings, centre) of a segment count, or an InputError: 3 R (R + 1) + 1 with the centre,
    3 R (R + 1) without it."""
    for r in range(1, RANGES["rings"][1] + 1):
        full = 3 * r * (r + 1)
        if segment_count == full + 1:
            return r, True
        if segment_count == full:
            return r, False
    raise InputError(f"{segment_count} segments: accepted 3 R (R + 1) + 1 (7, 19, 37, ...) with the centre or "
                     f"3 R (R + 1) (6, 18, 36, ...) without it, R ≤ {RANGES['rings'][1]}")
