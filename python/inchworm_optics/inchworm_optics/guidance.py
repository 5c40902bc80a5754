"""The outer fine-guidance loop: the star's centroid on the simulated detector, read out
at the guide rate with photon and read noise, corrects the mount's tip/tilt reference.

Why it is needed: the mount's three inner loops hold the runners on their encoders, so
they hold the secondary's pose, not the image. Whatever moves the line of sight outside
the mount (a slow thermal or pointing drift of the telescope, a disturbance of the
structure) passes straight to the image. The guider sees it on the detector and moves
the secondary against it; the secondary steers the image at the lever 2 s' per radian.

The loop is an integrator on the centroid error, through the inverse of an interaction
matrix measured on the instrument model (poke tip, poke tilt, see where the image goes),
as a guider is calibrated on the sky.
"""
import numpy as np

from .optics import centroid_px


def interaction_matrix(instrument, poke_rad=1e-6):
    """2 × 2 matrix J with image shift (x, y) px = J @ (tip, tilt) rad, measured by poking
    the in-focus instrument with ±`poke_rad` of tip and of tilt."""
    rx = instrument.rx
    xx, yy = instrument.pixel_coordinates()
    cols = []
    for tip, tilt in ((poke_rad, 0.0), (0.0, poke_rad)):
        c = []
        for s in (1.0, -1.0):
            opd = instrument.opd_m([rx.focus_piston_m], [s * tip], [s * tilt])
            img = instrument.images(instrument.fields(opd))[0]
            c.append(np.array(centroid_px(img, xx, yy)))
        cols.append((c[0] - c[1]) / (2 * poke_rad))
    return np.stack(cols, axis=1)


class FineGuider:
    """An integrator at `period_s` on the centroid error against a target, with photon
    noise (`photons` per guide frame) and Gaussian read noise (`read_noise_e` per pixel),
    seeded. `update` returns the new tip/tilt offset for the mount's reference (rad)."""

    def __init__(self, instrument, period_s=0.1, gain=0.2, photons=2e5, read_noise_e=5.0, seed=2026):
        self.instrument = instrument
        self.period_s = period_s
        self.gain = gain
        self.photons = photons
        self.read_noise_e = read_noise_e
        self.rng = np.random.default_rng(seed)
        self.J = interaction_matrix(instrument)
        self.J_inv = np.linalg.inv(self.J)
        self.offset_rad = np.zeros(2)  # (tip, tilt)
        self.xx, self.yy = instrument.pixel_coordinates()
        self.log = []

    def read(self, image):
        """A noisy detector read of a mean image (fractions of the pupil's light per pixel),
        in electrons: Poisson photons plus Gaussian read noise; None photons = noiseless."""
        if self.photons is None:
            return image
        electrons = self.rng.poisson(np.clip(image, 0, None) * self.photons).astype(float)
        return electrons + self.rng.normal(0.0, self.read_noise_e, image.shape)

    def update(self, t_s, image, target_px):
        """One guide frame ending at `t_s`: measure, compare with `target_px`, integrate."""
        measured = np.array(centroid_px(self.read(image), self.xx, self.yy))
        error_px = measured - np.asarray(target_px)
        self.offset_rad = self.offset_rad - self.gain * (self.J_inv @ error_px)
        self.log.append((t_s, *measured, *error_px, *self.offset_rad))
        return self.offset_rad
