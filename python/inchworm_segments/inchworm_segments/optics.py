"""The physical optics of the segmented telescope, through hcipy: the aperture and its
segments, the segmented mirror's piston/tip/tilt influence functions, a perfect
coronagraph and the propagation to the focal plane; and what one batch of 2 ms samples
gives: co-phasing error, wavefront error, Strehl ratio, the coronagraphic images and their
raw contrast in the dark zone.

Conventions (docs/segments.md):

* A segment's pose is (piston m, tip rad, tilt rad): its surface moves by
  z = piston + tip (y − y_k) + tilt (x − x_k) along the axis, toward the incoming light
  (tip = dz/dy, tilt = dz/dx, the `InchwormMount` FMU's convention), (x_k, y_k) the
  segment's centroid.
* Reflection doubles it into the optical path: OPD = −2 z (a surface that comes forward
  shortens the path). The field is amplitude × exp(+2πi OPD/λ), hcipy's phasor, with which
  its propagator puts a wavefront tilt dOPD/dx = a at +a (radians) on the sky: the image
  moves toward the side whose path is longer, as the reflected rays do.
* The segments' piston, tip and tilt are the modes of hcipy's `SegmentedDeformableMirror`
  (per segment: 1, and x and y about its centroid) on the segment's part of each pixel:
  a pixel's field sums its segments' pieces, each its coverage × its own phase. (hcipy's
  mirror scales a grey edge pixel's phase by its coverage instead; on a binary pupil the
  two are the same, and a test holds them to it.) Every sample of a batch at once.
* Contrast: a coronagraphic image's intensity divided by the peak of the unocculted PSF of
  the flat (co-phased) aperture, the star's peak without the coronagraph.
"""
import hcipy
import numpy as np
import scipy.sparse

from .config import InputError, Telescope
from .poses import check_pose_values


class SegmentedOptics:
    """hcipy's model of a `Telescope`: the pupil on a `pupil_px` grid across D (edge pixels
    grey, by `supersampling`), the focal plane at `q` pixels per λ/D out to `fov_lambda_d`,
    a perfect coronagraph (order 2) for this aperture and the dark zone's pixels."""

    def __init__(self, telescope: Telescope):
        if not isinstance(telescope, Telescope):
            raise InputError(f"telescope {telescope!r:.80}: accepted a config.Telescope")
        tel = self.telescope = telescope
        self.wavelength_m = tel.wavelength_m
        aperture, segments = hcipy.make_hexagonal_segmented_aperture(
            tel.rings, tel.flat_to_flat_m, tel.gap_m, starting_ring=0 if tel.centre else 1, return_segments=True)
        self.pupil_grid = hcipy.make_pupil_grid(tel.pupil_px, tel.diameter_m)
        self.aperture = hcipy.evaluate_supersampled(aperture, self.pupil_grid, tel.supersampling)
        self.segments = hcipy.evaluate_supersampled(segments, self.pupil_grid, tel.supersampling)
        n = tel.segment_count
        if len(self.segments) != n:
            raise AssertionError(f"hcipy made {len(self.segments)} segments, the telescope has {n}")
        seg = np.array([np.asarray(s) for s in self.segments])  # (N, pixels), each pixel's coverage
        amp = np.asarray(self.aperture)
        #: Each segment's share of the aperture's amplitude sum: the weight its field has in
        #: the on-axis (Strehl) field, and in the co-phasing RMS.
        self.segment_weights = seg.sum(axis=1) / amp.sum()
        x, y = np.asarray(self.pupil_grid.x), np.asarray(self.pupil_grid.y)
        self.segment_centres_m = np.stack([seg @ x, seg @ y], axis=1) / seg.sum(axis=1)[:, None]
        # The pieces: (segment, pixel) where the segment covers part of the pixel. A piece
        # carries its segment's surface at the pixel's centre and weighs by its coverage; a
        # pixel's field is the sum of its pieces' (one piece, except where a pixel spans a gap).
        self._piece_segment, piece_pixel = np.nonzero(seg)
        self._piece_cover = seg[self._piece_segment, piece_pixel]
        c = self.segment_centres_m[self._piece_segment]
        self._piece_dx, self._piece_dy = x[piece_pixel] - c[:, 0], y[piece_pixel] - c[:, 1]
        self._pieces_to_pixels = scipy.sparse.csr_matrix(
            (self._piece_cover, (piece_pixel, np.arange(len(piece_pixel)))), shape=(amp.size, len(piece_pixel)))
        self.focal_grid = hcipy.make_focal_grid(tel.q, tel.fov_lambda_d, spatial_resolution=tel.lambda_over_d_rad)
        self.propagator = hcipy.FraunhoferPropagator(self.pupil_grid, self.focal_grid)
        self.coronagraph = hcipy.PerfectCoronagraph(self.aperture, order=2)
        #: Focal-plane coordinates in λ/D.
        self.fx = np.asarray(self.focal_grid.x) / tel.lambda_over_d_rad
        self.fy = np.asarray(self.focal_grid.y) / tel.lambda_over_d_rad
        r = np.hypot(self.fx, self.fy)
        self.dark_zone = (r >= tel.dark_inner_lambda_d) & (r <= tel.dark_outer_lambda_d)
        flat = self.propagator.forward(hcipy.Wavefront(self.aperture, self.wavelength_m)).power
        #: The flat aperture's unocculted PSF peak (on the axis, a pixel of the focal grid).
        self.peak = float(flat[self.axis_pixel])
        self.focal_shape = tuple(self.focal_grid.shape)

    @property
    def axis_pixel(self):
        """The focal-grid pixel on the optical axis (hcipy's focal grids hold the origin)."""
        return int(np.argmin(np.hypot(self.fx, self.fy)))

    # ---- a batch of samples ----
    def _poses(self, poses):
        """`poses` (samples, N, 3) of this telescope's N, in the poses' ranges, or an
        InputError."""
        p = np.asarray(poses, dtype=float)
        n = self.telescope.segment_count
        if p.ndim != 3 or p.shape[1:] != (n, 3):
            raise InputError(f"poses of shape {p.shape}: accepted (samples, {n}, 3)")
        check_pose_values(p, lambda i: f"poses: sample {i}")
        return p

    def opd_m(self, poses):
        """OPD (samples, pieces) of poses (samples, N, 3): −2 × each piece's surface,
        z = piston + tip (y − y_k) + tilt (x − x_k)."""
        p = self._poses(poses)[:, self._piece_segment]  # (samples, pieces, 3)
        return -2.0 * (p[..., 0] + p[..., 1] * self._piece_dy + p[..., 2] * self._piece_dx)

    def fields(self, opd_m, only=None):
        """Pupil fields (samples, pixels) as one hcipy Field: each pixel the sum over its
        pieces of coverage × exp(+2πi OPD/λ) (hcipy's phasor); with `only` (segment
        numbers), the light of those segments alone."""
        k = 2.0 * np.pi / self.wavelength_m
        phasors = np.exp(1j * k * np.asarray(opd_m))
        if only is not None:
            phasors = phasors * np.isin(self._piece_segment, only)
        return hcipy.Field(np.asarray(self._pieces_to_pixels @ phasors.T).T, self.pupil_grid)

    def strehl(self, fields):
        """Strehl ratio on the axis (where the coronagraph's star is): |Σ field|² / |Σ amplitude|²,
        the on-axis intensity over the flat aperture's, from the pupil sum (the MFT at the
        origin is that sum; a test holds it to the propagated image's axis pixel)."""
        return np.abs(np.asarray(fields).sum(axis=-1)) ** 2 / float(np.sum(self.aperture)) ** 2

    def wfe_rms_m(self, opd_m):
        """RMS of each OPD over the aperture about its mean, pieces weighed by coverage."""
        w = self._piece_cover
        mean = opd_m @ w / w.sum()
        return np.sqrt(((opd_m - mean[:, None]) ** 2) @ w / w.sum())

    def cophasing_rms_m(self, poses):
        """Co-phasing error: RMS over the aperture of the segments' piston in the wavefront
        (OPD −2 piston_k on segment k), about its aperture mean, each segment weighed by its
        share of the aperture."""
        opd = -2.0 * self._poses(poses)[..., 0]
        w = self.segment_weights
        mean = opd @ w
        return np.sqrt(((opd - mean[..., None]) ** 2) @ w)

    def unocculted_images(self, fields):
        """Images without the coronagraph, in units of the flat PSF's peak."""
        return np.asarray(self.propagator.forward(hcipy.Wavefront(fields, self.wavelength_m)).power) / self.peak

    def coronagraphic_images(self, fields):
        """Images behind the perfect coronagraph, in units of the flat PSF's peak (contrast)."""
        wf = self.coronagraph.forward(hcipy.Wavefront(fields, self.wavelength_m))
        return np.asarray(self.propagator.forward(wf).power) / self.peak

    def dark_zone_contrast(self, images):
        """Mean raw contrast over the dark zone's pixels of each image (..., pixels)."""
        return np.asarray(images)[..., self.dark_zone].mean(axis=-1)
