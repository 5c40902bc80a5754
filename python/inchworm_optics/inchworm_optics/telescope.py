"""The telescope: a two-mirror Cassegrain whose secondary sits on the inchworm mount, and
the first-order optics that turn the secondary's rigid-body pose into a wavefront.

Geometry (paraxial, on axis; docs/optics.md draws it):

* primary of diameter D and focal length f1; the secondary, at separation d in front of
  it, intercepts the converging beam a distance p = f1 − d before the primary focus and
  re-images that focus at s' = m p behind itself, m being the secondary magnification;
* effective focal length f = m f1, final focal ratio N = f / D, back focal distance
  (primary vertex to focus) b = s' − d; the beam footprint on the secondary has diameter
  d2 = D p / f1 (= D s' / f), so a point (x2, y2) of the secondary sees the ray of entrance
  pupil point (X, Y) = (x2, y2) D / d2.

The mount moves the secondary by z(x2, y2) = piston + tip y2 + tilt x2 along the axis,
toward the primary (the `InchwormMount` FMU's convention: tip = dz/dy, tilt = dz/dx). A
reflecting surface moved by z along the axis shortens the path of a ray meeting it at
angles u_in, u_out to the axis by z (cos u_in + cos u_out):

* the tilt part doubles on reflection: the wavefront tilts by 2 θ over the secondary's
  footprint, i.e. by α = 2 θ d2 / D referred to the entrance pupil (the line of sight on
  the sky), and the image moves by α f = 2 θ s' (the optical lever `lever_m_per_rad`);
* the piston part is a despace: with u_in = ρ D / (2 f1) and u_out = ρ D / (2 f) at
  normalised pupil radius ρ, the varying path is −piston ρ² D² (1/f1² + 1/f²) / 8, i.e.
  a defocus W020 = piston (1 + m²) / (8 N²) and a focus shift at the image of
  (1 + m²) piston; its Zernike coefficient (Noll Z4, RMS-normalised on the full disc) is
  W020 / (2√3), and over an annulus of obscuration ratio ε the RMS is W020 (1 − ε²)/(2√3).

All lengths in metres, angles in radians, unless a name says otherwise.
"""
from dataclasses import asdict, dataclass, fields
import json
import math

from inchworm_inputs import read_bounded

from .inputs import MAX_PRESCRIPTION_BYTES, InputError, check_prescription

MAS_PER_RAD = 180.0 / math.pi * 3600e3


@dataclass(frozen=True)
class Prescription:
    """A telescope prescription: the parameters a user swaps for their own (`--prescription
    FILE.json` with any of these keys). The default is a 0.5 m f/10 Cassegrain whose 100 mm
    secondary footprint matches the mount's 50 mm actuator radius."""

    aperture_m: float = 0.5
    primary_focal_length_m: float = 1.0
    secondary_magnification: float = 5.0
    back_focal_distance_m: float = 0.2
    #: Diameter of the central obscuration (secondary, its cell and the mount's baffle).
    obscuration_m: float = 0.12
    wavelength_m: float = 550e-9
    #: Detector pixel pitch: 2.5 µm samples a 550 nm f/10 PSF at Nyquist (λN/2 = 2.75 µm).
    pixel_m: float = 2.5e-6
    #: The mount piston at which the telescope is in focus: the scenario's 30 µm piston
    #: move is the focus adjustment, so frames before it are out of focus.
    focus_piston_m: float = 30e-6

    def __post_init__(self):
        check_prescription(self)  # every field in its range (inputs.py), or an InputError naming it

    @classmethod
    def load(cls, path):
        """A prescription from a JSON file of any of the fields (the rest default), read up
        to `inputs.MAX_PRESCRIPTION_BYTES` (`inchworm_inputs.read_bounded`: an
        `InputError` for a larger file, unread, or a stream past the bound); an
        `InputError` as `parse` says. (An unreadable file is the OSError of `open`.)"""
        return cls.parse(read_bounded(path, MAX_PRESCRIPTION_BYTES, "a JSON object of prescription fields"), path)

    @classmethod
    def parse(cls, data, name="prescription"):
        """A prescription from the bytes (or text) of a JSON object of any of the fields;
        an `InputError` naming `name` if it is longer than `inputs.MAX_PRESCRIPTION_BYTES`,
        not JSON (or nested past the parser's depth), not an object of known fields, or has
        a field out of its range."""
        if len(data) > MAX_PRESCRIPTION_BYTES:
            raise InputError(f"{name}: longer than {MAX_PRESCRIPTION_BYTES} bytes: accepted a JSON object of "
                             "prescription fields")
        try:
            obj = json.loads(data)
        except (ValueError, RecursionError) as e:  # JSONDecodeError, UnicodeDecodeError, a nesting too deep
            raise InputError(f"{name}: not a JSON object of prescription fields ({e})") from None
        known = {f.name for f in fields(cls)}
        if not isinstance(obj, dict):
            raise InputError(f"{name}: not a JSON object of prescription fields (known: {sorted(known)})")
        unknown = set(obj) - known
        if unknown:
            shown = sorted(unknown)[:5]
            raise InputError(f"{name}: unknown prescription keys {shown} (known: {sorted(known)})")
        try:
            return cls(**obj)
        except InputError as e:
            raise InputError(f"{name}: {e}") from None

    def as_dict(self):
        return asdict(self)

    # ---- first-order layout ----
    @property
    def focal_length_m(self):
        """Effective focal length f = m f1."""
        return self.secondary_magnification * self.primary_focal_length_m

    @property
    def f_number(self):
        return self.focal_length_m / self.aperture_m

    @property
    def separation_m(self):
        """Primary–secondary separation d from s' = m (f1 − d) and s' = d + b."""
        m, f1, b = self.secondary_magnification, self.primary_focal_length_m, self.back_focal_distance_m
        return (m * f1 - b) / (m + 1.0)

    @property
    def secondary_to_focus_m(self):
        """s', the distance from the secondary to the final focus."""
        return self.separation_m + self.back_focal_distance_m

    @property
    def footprint_ratio(self):
        """d2 / D, the secondary's beam footprint over the aperture (= p / f1 = s' / f)."""
        return (self.primary_focal_length_m - self.separation_m) / self.primary_focal_length_m

    @property
    def obscuration_ratio(self):
        return self.obscuration_m / self.aperture_m

    # ---- the mount's pose to the wavefront and the image ----
    @property
    def lever_m_per_rad(self):
        """Image motion on the detector per radian of secondary tilt: 2 s' (= 2 f d2/D)."""
        return 2.0 * self.secondary_to_focus_m

    @property
    def sky_per_tilt(self):
        """Line-of-sight angle on the sky per radian of secondary tilt: 2 d2 / D."""
        return 2.0 * self.footprint_ratio

    @property
    def focus_shift_per_despace(self):
        """Image focus shift per metre of despace: 1 + m²."""
        return 1.0 + self.secondary_magnification**2

    def defocus_w020_m(self, despace_m):
        """Peak defocus coefficient W020 (OPD at the pupil edge, m) of a despace."""
        return despace_m * self.focus_shift_per_despace / (8.0 * self.f_number**2)

    def focus_z4_m(self, despace_m):
        """Noll Z4 (RMS-normalised on the full disc) of a despace: W020 / (2√3)."""
        return self.defocus_w020_m(despace_m) / (2.0 * math.sqrt(3.0))

    def focus_rms_m(self, despace_m):
        """RMS wavefront error of a despace over the annular pupil: W020 (1 − ε²) / (2√3)."""
        return abs(self.defocus_w020_m(despace_m)) * (1.0 - self.obscuration_ratio**2) / (2.0 * math.sqrt(3.0))

    @property
    def pixel_scale_rad(self):
        return self.pixel_m / self.focal_length_m

    @property
    def pixel_scale_mas(self):
        return self.pixel_scale_rad * MAS_PER_RAD

    @property
    def lambda_over_d_rad(self):
        return self.wavelength_m / self.aperture_m

    def opd_m(self, X, Y, piston_m, tip_rad, tilt_rad):
        """The optical path difference (m) that the secondary's pose adds at entrance-pupil
        points (X, Y) (m from the axis), to first order in the ray angles: the path change
        −z (cos u_in + cos u_out) of a surface moved by z along the axis (u_in, u_out the
        ray's angles to the axis before and after the secondary), with cos u ≈ 1 − u²/2,
        the constant removed and the piston taken relative to the in-focus position
        (`focus_piston_m`):

            OPD = −2 (tip y2 + tilt x2) + despace (u_in² + u_out²) / 2,

        u_in = r / f1, u_out = r / f at pupil radius r. The tilt's u² terms (a coma of
        about 1 % of the tilt's path at f/2) and the spherical terms of a despace are the
        next order and are left out: the model is the secondary's first-order sensitivity,
        the same one the docs' closed forms state.

        Positive OPD is a longer path (poppy's convention: it lags). Broadcasts over a
        leading axis of samples when the pose values are arrays of shape (n, 1, 1).
        """
        k = self.footprint_ratio
        despace = piston_m - self.focus_piston_m
        r2 = X**2 + Y**2
        u2 = r2 / self.primary_focal_length_m**2 + r2 / self.focal_length_m**2
        return -2.0 * k * (tip_rad * Y + tilt_rad * X) + despace * u2 / 2.0

    def summary(self):
        """The first-order numbers the docs quote."""
        return {
            "aperture_m": self.aperture_m,
            "primary_f_number": self.primary_focal_length_m / self.aperture_m,
            "focal_length_m": self.focal_length_m,
            "f_number": self.f_number,
            "secondary_magnification": self.secondary_magnification,
            "separation_m": self.separation_m,
            "secondary_to_focus_m": self.secondary_to_focus_m,
            "back_focal_distance_m": self.back_focal_distance_m,
            "secondary_footprint_m": self.footprint_ratio * self.aperture_m,
            "obscuration_ratio": self.obscuration_ratio,
            "lever_m_per_rad": self.lever_m_per_rad,
            "sky_per_tilt": self.sky_per_tilt,
            "focus_shift_per_despace": self.focus_shift_per_despace,
            "pixel_scale_mas": self.pixel_scale_mas,
            "lambda_over_d_mas": self.lambda_over_d_rad * MAS_PER_RAD,
        }
