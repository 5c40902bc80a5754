"""The runs: `MirrorMount.ssp`'s scenario (piston 30 µm from t = 0, the focus move; tip
4 µrad at 4 s; regulation) through the FMUs and the telescope, frame by frame.

Every 2 ms sample of the mount's pose becomes a pupil field and an image; a detector
frame is the mean of the images of every sample of its exposure, parked or moving (the
runners step every control iteration, and a detector integrates through the steps). The
image error is the centroid against where the commanded pose puts the star (the tip
command moves the target with it, as a guider's offset does): the centroid, by the same
estimator, of the image of the mount exactly at its command and in focus. So the
estimator's own small bias at a given spot position (about 1e-3 px at 3 px off axis) cancels
and the error is what the mount's pointing error does to the image.
"""
from dataclasses import dataclass, field
import math

import numpy as np

from .cosim import CHAINS, MountCosim, parked
from .guidance import FineGuider
from .inputs import REGULATION_S, STEP_S, sample_counts
from .optics import Frame, centroid_px
from .telescope import MAS_PER_RAD
from inchworm_variables import InchwormController as Controller


@dataclass
class RunConfig:
    """One run: the controllers' mode, the detector's frame time, a line-of-sight drift
    (sky angle per second, x and y, mas/s) and offset the mount cannot see, and the guider
    or none."""

    name: str
    analog: bool = False
    duration_s: float = 10.0
    frame_s: float = 0.05
    drift_mas_per_s: tuple = (0.0, 0.0)
    #: A constant line-of-sight offset (mas, x and y) from t = 0: a pointing disturbance.
    offset_mas: tuple = (0.0, 0.0)
    guide: bool = False
    guide_period_s: float = 0.1
    guide_gain: float = 0.2
    guide_photons: float = 2e5
    guide_read_noise_e: float = 5.0
    #: The guider does not integrate for this long after the mount's command changes (a
    #: commanded move is an offset the guider is told about, not an error to correct).
    guide_pause_s: float = 0.4
    seed: int = 2026
    #: Extra `component.variable` values for the SSP (as `inchworm run --param`).
    params: dict = field(default_factory=dict)


@dataclass
class RunResult:
    config: RunConfig
    t_s: np.ndarray
    pose: np.ndarray  # (n, 3): piston m, tip rad, tilt rad
    command: np.ndarray  # (n, 2): commanded tip, tilt rad (the references' tables)
    parked: np.ndarray
    sample_centroid_px: np.ndarray  # (n, 2)
    sample_target_px: np.ndarray  # (n, 2)
    frames: list
    frame_target_px: np.ndarray  # (frames, 2)
    guide_log: list = field(default_factory=list)

    def frame_error_mas(self, instrument):
        c = np.array([f.centroid_px for f in self.frames])
        return (c - self.frame_target_px) * instrument.rx.pixel_scale_mas

    def frame_mid_s(self):
        return np.array([(f.t_start_s + f.t_end_s) / 2 for f in self.frames])


def _command(cosim):
    """The commanded tip and tilt: the mount kinematics of the three references (the
    inverse of `MountCosim.set_tip_tilt_offset`), without the guider's offset."""
    z = [cosim.components[f"reference_{x}"].get(Controller.REFERENCE) for x in CHAINS]
    k = 2.0 / (3.0 * cosim.radius_m)
    tip = k * sum(zi * math.sin(p) for zi, p in zip(z, cosim.angles_rad))
    tilt = k * sum(zi * math.cos(p) for zi, p in zip(z, cosim.angles_rad))
    return tip, tilt


def ssp_params(cfg):
    """The SSP parameters of a run: analog mode's, if it is on, then the run's own."""
    return {**(MountCosim.analog_mode() if cfg.analog else {}), **cfg.params}


def run(ssp_path, instrument, cfg, progress=None):
    """Runs one configuration; returns its samples and frames."""
    rx = instrument.rx
    h = STEP_S
    n, per_frame = sample_counts(cfg.duration_s, cfg.frame_s)
    _, per_guide = sample_counts(cfg.duration_s, cfg.guide_period_s)
    targets = {}

    def target_px(command):
        key = (float(command[0]), float(command[1]))
        if key not in targets:
            opd = instrument.opd_m([rx.focus_piston_m], [key[0]], [key[1]])
            targets[key] = np.array(centroid_px(instrument.images(instrument.fields(opd))[0], xx, yy))
        return targets[key]

    guider = None
    if cfg.guide:
        guider = FineGuider(instrument, cfg.guide_period_s, cfg.guide_gain, cfg.guide_photons,
                            cfg.guide_read_noise_e, cfg.seed)
    drift_rad = np.array(cfg.drift_mas_per_s) / MAS_PER_RAD
    offset_rad = np.array(cfg.offset_mas) / MAS_PER_RAD
    xx, yy = instrument.pixel_coordinates()
    cosim = MountCosim(ssp_path, ssp_params(cfg))
    t, pose, cmd, enc, cen, tgt = [], [], [], [], [], []
    frames, frame_tgt = [], []
    images = []  # the current frame's sample images
    fields, opds = [], []
    guide_images = []
    last_move_s = -math.inf
    try:
        for k in range(n):
            tk = k * h
            p = cosim.pose()
            c = _command(cosim)
            los = offset_rad + drift_rad * tk
            opd = instrument.opd_m([p[0]], [p[1]], [p[2]], (los[0], los[1]))
            fld = instrument.fields(opd)
            img = instrument.images(fld)[0]
            t.append(tk)
            pose.append(p)
            cmd.append(c)
            enc.append(cosim.encoders())
            cen.append(centroid_px(img, xx, yy))
            tgt.append(target_px(c))
            images.append(img)
            fields.append(fld[0])
            opds.append(opd[0])
            guide_images.append(img)
            if len(images) == per_frame:
                fr = Frame(instrument, np.array(fields), np.array(opds), tk + h - per_frame * h, tk + h,
                           precomputed_images=np.array(images))
                frames.append(fr)
                frame_tgt.append(np.mean(tgt[-per_frame:], axis=0))
                images, fields, opds = [], [], []
                if progress:
                    progress(cfg.name, tk + h, cfg.duration_s)
            if c != cmd[-2 if len(cmd) > 1 else -1]:
                last_move_s = tk
            if len(guide_images) == per_guide:
                if guider is not None and tk + h - last_move_s > cfg.guide_pause_s:
                    off = guider.update(tk + h, np.mean(guide_images, axis=0), np.mean(tgt[-per_guide:], axis=0))
                    cosim.set_tip_tilt_offset(off[0], off[1])
                guide_images = []
            cosim.step()
    finally:
        cosim.close()
    return RunResult(
        config=cfg, t_s=np.array(t), pose=np.array(pose), command=np.array(cmd),
        parked=parked(enc), sample_centroid_px=np.array(cen), sample_target_px=np.array(tgt),
        frames=frames, frame_target_px=np.array(frame_tgt),
        guide_log=guider.log if guider else [],
    )


def rms(x, scale=1.0):
    """RMS of `x` times `scale`; None for no values (an empty window has no RMS)."""
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(x**2))) * scale if x.size else None


def _stat(fn, values, scale=1.0):
    values = np.asarray(values, dtype=float)
    return float(fn(values)) * scale if values.size else None


def figures(result, instrument, regulation_s=REGULATION_S):
    """The numbers of a run: the mount's pointing and piston (as `inchworm scenario
    mirror` measures them, parked samples from `regulation_s`, and over every sample), the
    image motion per sample and per frame, and the frames' wavefront error, Strehl and
    encircled energy in regulation. A figure over a window with no samples (no parked
    sample in analog mode, no frame after `regulation_s`) is None, with the window's
    counts `n_parked_samples`, `n_samples`, `n_frames` saying why."""
    rx = instrument.rx
    r = result
    reg = r.t_s >= regulation_s
    pk = reg & r.parked
    pointing = np.hypot(r.pose[:, 1] - r.command[:, 0], r.pose[:, 2] - r.command[:, 1])
    piston = r.pose[:, 0] - rx.focus_piston_m
    img_err_m = np.hypot(*(r.sample_centroid_px - r.sample_target_px).T) * rx.pixel_m
    fmid = r.frame_mid_s()
    freg = fmid >= regulation_s
    ferr = np.hypot(*r.frame_error_mas(instrument).T)
    in_reg = [f for f, keep in zip(r.frames, freg) if keep]
    out = {
        "pointing_rms_parked_nrad": rms(pointing[pk], 1e9),
        "pointing_rms_every_nrad": rms(pointing[reg], 1e9),
        "piston_rms_parked_nm": rms(piston[pk], 1e9),
        "piston_rms_every_nm": rms(piston[reg], 1e9),
        "piston_peak_every_nm": _stat(np.max, np.abs(piston[reg]), 1e9),
        "image_rms_parked_nm": rms(img_err_m[pk], 1e9),
        "image_rms_every_nm": rms(img_err_m[reg], 1e9),
        "lever_m_per_rad": rx.lever_m_per_rad,
        "frame_image_rms_mas": rms(ferr[freg]),
        "frame_image_max_mas": _stat(np.max, ferr[freg]),
        "frame_image_rms_px": rms(ferr[freg], 1.0 / rx.pixel_scale_mas),
        "frame_wfe_rms_nm": rms([f.wfe_rms_m for f in in_reg], 1e9),
        "frame_wfe_max_nm": _stat(np.max, [f.wfe_rms_max_m for f in in_reg], 1e9),
        "frame_strehl_mean": _stat(np.mean, [f.strehl for f in in_reg]),
        "frame_strehl_min": _stat(np.min, [f.strehl for f in in_reg]),
        "frame_ee_mean": _stat(np.mean, [f.ee for f in in_reg]),
        "n_parked_samples": int(pk.sum()),
        "n_samples": int(reg.sum()),
        "n_frames": int(freg.sum()),
    }
    for which in ("parked", "every"):
        # The ratio of image motion to lever × pointing: none without pointing to compare.
        pointing_rms, image_rms = out[f"pointing_rms_{which}_nrad"], out[f"image_rms_{which}_nm"]
        out[f"image_over_lever_pointing_{which}"] = (
            image_rms / (pointing_rms * rx.lever_m_per_rad) if pointing_rms else None)
    return out


def held(result, instrument, from_s):
    """Largest and RMS frame image error (mas) from `from_s` on: how well the image is held
    (None, None if no frame's middle is at or after `from_s`)."""
    fmid = result.frame_mid_s()
    sel = fmid >= from_s
    e = np.hypot(*result.frame_error_mas(instrument).T)[sel]
    return _stat(np.max, e), rms(e)
