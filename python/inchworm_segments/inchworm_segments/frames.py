"""Frames: the detector integrates every 2 ms sample of its exposure. The run's samples are
cut into frames of `frame_samples` consecutive samples (a tail shorter than a frame makes
no frame); each frame is computed from its samples alone, as one batch, by `frame_batch`.

The frames are independent, so they run in parallel: `run` hands chunks of frames to any
`concurrent.futures.Executor` (a `ProcessPoolExecutor`, or a dask.distributed client's
`get_executor()`), and each worker builds the telescope's optics once and keeps them.
Serial and parallel runs call the same function on the same frame batches, so their
numbers are bit-identical (a test holds them to it).
"""
from dataclasses import dataclass

import numpy as np

from .config import FRAME_SAMPLES, FRAMES_PER_TASK, SAMPLE_S, InputError, Telescope, check_memory
from .poses import check_pose_values, check_poses

#: One optics per process and telescope: a worker builds it at its first chunk.
_OPTICS = {}


def optics_for(telescope: Telescope):
    if not isinstance(telescope, Telescope):
        raise InputError(f"telescope {telescope!r:.80}: accepted a config.Telescope")
    from .optics import SegmentedOptics  # hcipy is imported by the process that computes

    if telescope not in _OPTICS:
        _OPTICS[telescope] = SegmentedOptics(telescope)
    return _OPTICS[telescope]


def frame_batch(optics, poses):
    """One frame from its samples' poses (samples, N, 3): per sample the Strehl ratio and
    dark-zone contrast and the wavefront's RMS; the frame's image (the mean of its samples'
    coronagraphic images, in contrast units) and its dark-zone contrast. The poses are
    checked first: finite and in their ranges, one per segment of the telescope."""
    poses = np.asarray(poses, dtype=float)
    n = optics.telescope.segment_count
    if poses.ndim != 3 or poses.shape[0] < 1 or poses.shape[1:] != (n, 3):
        raise InputError(f"a frame's poses of shape {poses.shape}: accepted (samples ≥ 1, {n}, 3)")
    check_pose_values(poses, lambda i: f"a frame's sample {i}")
    opd = optics.opd_m(poses)
    fields = optics.fields(opd)
    images = optics.coronagraphic_images(fields)
    image = images.mean(axis=0)
    return {
        "strehl": optics.strehl(fields),
        "contrast": optics.dark_zone_contrast(images),
        "wfe_rms_m": optics.wfe_rms_m(opd),
        "image": image,
        "frame_contrast": float(optics.dark_zone_contrast(image)),
    }


def _chunk(telescope, poses, frame_samples):
    """A chunk of whole frames, in order (what a worker runs)."""
    optics = optics_for(telescope)
    return [frame_batch(optics, poses[i:i + frame_samples]) for i in range(0, len(poses), frame_samples)]


@dataclass
class Result:
    """Every figure of a run: per sample (the framed ones) and per frame."""

    telescope: Telescope
    t_s: np.ndarray             # (samples,) time of each framed sample
    poses: np.ndarray           # (samples, N, 3)
    parked: np.ndarray          # (samples,) bool
    frame_samples: int
    cophasing_rms_m: np.ndarray  # (samples,)
    wfe_rms_m: np.ndarray       # (samples,)
    strehl: np.ndarray          # (samples,)
    contrast: np.ndarray        # (samples,)
    images: np.ndarray          # (frames, focal pixels), contrast units
    frame_contrast: np.ndarray  # (frames,)

    @property
    def frame_count(self):
        return len(self.frame_contrast)

    def frame_start_s(self):
        return self.t_s[::self.frame_samples]

    def frame_end_s(self):
        return self.frame_start_s() + self.frame_samples * SAMPLE_S

    def frame_parked(self):
        """Frames all of whose samples are parked."""
        return self.parked.reshape(self.frame_count, self.frame_samples).all(axis=1)


def run(telescope, t_s, poses, parked, frame_samples, executor=None, frames_per_task=4):
    """The figures of every whole frame of `poses` (samples, N, 3), serially or on
    `executor`; `parked` (samples,) marks the samples whose segments are all parked (None:
    none is). Every argument is checked before any optics: the poses as `poses.check_poses`
    does, one per segment of `telescope`, the frame and task sizes in their ranges, at least
    one frame, the run's arrays within the memory bound (as one process computes them)."""
    if not isinstance(telescope, Telescope):
        raise InputError(f"telescope {telescope!r:.80}: accepted a config.Telescope")
    t_s, poses, parked = check_poses(t_s, poses, parked)
    if poses.shape[1] != telescope.segment_count:
        raise InputError(f"poses of {poses.shape[1]} segments: the telescope has {telescope.segment_count}")
    parked = np.zeros(len(t_s), dtype=bool) if parked is None else parked
    frame_samples = FRAME_SAMPLES.check("frame_samples", frame_samples)
    frames_per_task = FRAMES_PER_TASK.check("frames_per_task", frames_per_task)
    frames = len(poses) // frame_samples
    if frames == 0:
        raise InputError(f"{len(poses)} samples: accepted at least one frame of {frame_samples}")
    check_memory(telescope, len(poses), frame_samples)
    n = frames * frame_samples
    poses, t_s, parked = poses[:n], t_s[:n], parked[:n]
    step = frames_per_task * frame_samples
    chunks = [poses[i:i + step] for i in range(0, n, step)]
    if executor is None:
        parts = [_chunk(telescope, c, frame_samples) for c in chunks]
    else:
        parts = list(executor.map(_chunk, [telescope] * len(chunks), chunks, [frame_samples] * len(chunks)))
    out = [f for part in parts for f in part]
    cophasing = optics_for(telescope).cophasing_rms_m(poses)
    return Result(telescope=telescope, t_s=t_s, poses=poses, parked=parked, frame_samples=frame_samples,
                  cophasing_rms_m=cophasing,
                  wfe_rms_m=np.concatenate([f["wfe_rms_m"] for f in out]),
                  strehl=np.concatenate([f["strehl"] for f in out]),
                  contrast=np.concatenate([f["contrast"] for f in out]),
                  images=np.stack([f["image"] for f in out]),
                  frame_contrast=np.array([f["frame_contrast"] for f in out]))
