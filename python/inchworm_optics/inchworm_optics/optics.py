"""The physical optics: the telescope's pupil and each 2 ms sample's wavefront through
poppy to the detector, and the figures of a detector frame.

poppy (STScI's physical-optics library) supplies the pupil (its `CircularAperture` and
`SecondaryObscuration` sampled on its `Wavefront` grid), the OPD-to-phasor convention
(a longer path lags: phasor exp(+2πi OPD/λ)) and the propagation: every PSF here is
`poppy.matrixDFT.matrix_dft`, the matrix Fourier transform poppy's own `OpticalSystem`
uses to reach a detector (Soummer et al. 2007), called once per sample and per plane. A
test compares a sample's image with `poppy.OpticalSystem.calc_psf` of the same pupil and
OPD. We do not call `calc_psf` per sample because it rebuilds the whole system each time
(≈ 0.1 s against a few ms), and a 10 s run has 5000 samples.

Units: intensities are fractions of the light entering the pupil, per detector pixel
(`image`) or per (λ/D)² (`density`); positions on the detector are pixels from the optical
axis (+x along the pupil's X, +y along its Y, the orientation poppy gives).
"""
import math

import numpy as np
import poppy
from poppy.matrixDFT import matrix_dft

from .inputs import check_pupil_grid
from .telescope import MAS_PER_RAD

# matrix_dft's numexpr path compiles and validates its expressions on every call, which
# on these small grids costs more than the transform; plain numpy gives the same numbers.
poppy.conf.use_numexpr = False
poppy.accel_math.update_math_settings()


class Instrument:
    """The telescope's pupil on an `npix_pupil` grid and a `fov_pixels` square detector
    centred on the optical axis (the axis on the corner between the four middle pixels)."""

    def __init__(self, rx, npix_pupil=64, fov_pixels=64):
        check_pupil_grid(rx, npix_pupil, fov_pixels)
        self.rx = rx
        self.npix_pupil = npix_pupil
        self.fov_pixels = fov_pixels
        wf = poppy.Wavefront(wavelength=rx.wavelength_m, npix=npix_pupil, diam=rx.aperture_m, oversample=1)
        optics = [poppy.CircularAperture(radius=rx.aperture_m / 2)]
        if rx.obscuration_m > 0:
            optics.append(poppy.SecondaryObscuration(secondary_radius=rx.obscuration_m / 2, n_supports=0))
        self.pupil_optic = poppy.CompoundAnalyticOptic(opticslist=optics, name="Cassegrain pupil")
        self.amplitude = np.asarray(self.pupil_optic.get_transmission(wf), dtype=float)
        self.Y, self.X = wf.coordinates()
        self.mask = self.amplitude > 0
        self.pupil_energy = float(np.sum(self.amplitude**2))
        #: Detector pixel in λ/D (D the pupil array's width, which is the aperture here).
        self.pixel_lambda_d = rx.pixel_scale_rad / rx.lambda_over_d_rad
        self.perfect_peak_density = self._perfect_peak()

    # ---- wavefronts ----
    def opd_m(self, piston_m, tip_rad, tilt_rad, los_rad=(0.0, 0.0)):
        """OPD (m) of samples (arrays of shape (n,)) of the mount pose, plus a line-of-sight
        drift of the whole telescope `los_rad` = (x, y) sky angle (a tilt of the incoming
        wavefront the mount's loops cannot see). Shape (n, N, N)."""
        p = np.asarray(piston_m, dtype=float).reshape(-1, 1, 1)
        tp = np.asarray(tip_rad, dtype=float).reshape(-1, 1, 1)
        tl = np.asarray(tilt_rad, dtype=float).reshape(-1, 1, 1)
        lx = np.asarray(los_rad[0], dtype=float).reshape(-1, 1, 1)
        ly = np.asarray(los_rad[1], dtype=float).reshape(-1, 1, 1)
        return self.rx.opd_m(self.X, self.Y, p, tp, tl) - (lx * self.X + ly * self.Y)

    def fields(self, opd_m):
        """The pupil fields of OPDs: amplitude × exp(+2πi OPD/λ) (poppy's phasor)."""
        return self.amplitude * np.exp(2j * np.pi / self.rx.wavelength_m * opd_m)

    def wfe_rms_m(self, opd_m):
        """RMS over the pupil of each OPD with piston, tip and tilt removed by a least-squares
        fit: the wavefront error that blurs the image (tilt only moves it). Each pupil pixel
        weighs by its transmission, the fraction of it inside the aperture (poppy grey-scales
        the edge pixels), which is also how it weighs in the PSF's peak."""
        x, y = self.X[self.mask], self.Y[self.mask]
        wt = self.amplitude[self.mask]
        sw = np.sqrt(wt)
        basis = np.stack([np.ones_like(x), x, y], axis=1)
        w = np.asarray(opd_m)[:, self.mask]
        coef, *_ = np.linalg.lstsq(basis * sw[:, None], (w * sw).T, rcond=None)
        resid = w - (basis @ coef).T
        return np.sqrt(np.sum(resid**2 * wt, axis=1) / np.sum(wt))

    # ---- propagation ----
    def _dft(self, field, npix, pitch_lambda_d, center_lambda_d=(0.0, 0.0)):
        """poppy's MFT of one pupil field onto `npix`² points `pitch_lambda_d` apart
        centred at `center_lambda_d` = (x, y) from the axis; returns density per (λ/D)²."""
        # ADJUSTABLE puts U = 0 at `offset` pixels from the array centre: the centre is at -offset.
        offset = (-center_lambda_d[1] / pitch_lambda_d, -center_lambda_d[0] / pitch_lambda_d)
        out = matrix_dft(field, npix * pitch_lambda_d, npix, offset=offset, centering="ADJUSTABLE")
        return np.abs(out) ** 2 / (self.pupil_energy * pitch_lambda_d**2)

    def images(self, fields):
        """Detector images (fraction of the pupil's light per pixel) of pupil fields."""
        px = self.pixel_lambda_d
        return np.stack([self._dft(f, self.fov_pixels, px) * px**2 for f in fields])

    def _perfect_peak(self):
        return float(self._dft(self.amplitude.astype(complex), 1, 0.01)[0, 0])

    def pixel_coordinates(self):
        """x, y of the detector pixel centres in pixels from the optical axis."""
        c = (np.arange(self.fov_pixels) - (self.fov_pixels - 1) / 2.0)
        return np.meshgrid(c, c)

    def peak_density(self, fields, around_px, levels=3):
        """Peak of the mean density of `fields` near `around_px` (pixels from the axis):
        9 × 9 points over ±1 λ/D, then zoomed by 8 around the best point, `levels` times."""
        center = np.asarray(around_px, dtype=float) * self.pixel_lambda_d
        pitch = 0.25
        for _ in range(levels):
            d = np.mean([self._dft(f, 9, pitch, center) for f in fields], axis=0)
            j, i = np.unravel_index(np.argmax(d), d.shape)
            center = center + (np.array([i, j]) - 4) * pitch
            pitch /= 8.0
        return float(d.max())

    def encircled_energy(self, fields, around_px, radius_lambda_d, pitch_lambda_d=0.05):
        """Fraction of the pupil's light within `radius_lambda_d` of `around_px`, from the
        mean density on a fine grid (midpoint rule on `pitch_lambda_d`)."""
        n = int(math.ceil(2 * radius_lambda_d / pitch_lambda_d)) + 1
        center = np.asarray(around_px, dtype=float) * self.pixel_lambda_d
        d = np.mean([self._dft(f, n, pitch_lambda_d, center) for f in fields], axis=0)
        c = (np.arange(n) - (n - 1) / 2.0) * pitch_lambda_d
        xx, yy = np.meshgrid(c, c)
        return float(np.sum(d[np.hypot(xx, yy) <= radius_lambda_d]) * pitch_lambda_d**2)


def centroid_px(image, xx, yy, box_px=8.0, iterations=6):
    """Centre of light of an image (pixels from the axis): the whole frame first, then a
    box of ±`box_px` around the last estimate, `iterations` times (the box keeps the
    detector's edges and noise far from the star out of the estimate). The box's edge
    pixels count by the fraction of them inside it, so the box is symmetric about the
    estimate at any sub-pixel position and the estimate has no pull toward pixel centres.
    `xx`, `yy` are the pixel-centre grids of `Instrument.pixel_coordinates`."""
    w = np.clip(image, 0.0, None)
    x, y = xx[0], yy[:, 0]
    total = w.sum()
    cx, cy = float(w.sum(axis=0) @ x / total), float(w.sum(axis=1) @ y / total)
    for _ in range(iterations):
        bx = np.clip(box_px + 0.5 - np.abs(x - cx), 0, 1)
        by = np.clip(box_px + 0.5 - np.abs(y - cy), 0, 1)
        row = by @ w  # the box's column sums
        s = row @ bx
        cx, cy = float(row @ (bx * x) / s), float(by * y @ w @ bx / s)
    return cx, cy


class Frame:
    """The figures of one detector frame: the mean over its samples (every 2 ms sample of
    the exposure, parked or moving) of their images."""

    def __init__(self, instrument, fields, opd_m, t_start_s, t_end_s, ee_radius_lambda_d=1.22,
                 precomputed_images=None):
        inst = instrument
        self.t_start_s, self.t_end_s = t_start_s, t_end_s
        imgs = inst.images(fields) if precomputed_images is None else precomputed_images
        self.image = np.mean(imgs, axis=0)
        xx, yy = inst.pixel_coordinates()
        self.centroid_px = centroid_px(self.image, xx, yy)
        self.strehl = inst.peak_density(fields, self.centroid_px) / inst.perfect_peak_density
        self.ee = inst.encircled_energy(fields, self.centroid_px, ee_radius_lambda_d)
        rms = inst.wfe_rms_m(opd_m)
        self.wfe_rms_m = float(np.sqrt(np.mean(rms**2)))
        self.wfe_rms_max_m = float(rms.max())
        scale = inst.rx.pixel_scale_rad * MAS_PER_RAD
        self.centroid_mas = (self.centroid_px[0] * scale, self.centroid_px[1] * scale)
