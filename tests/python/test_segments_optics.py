"""python/inchworm_segments: the closed-form checks of the segmented telescope's optics
(issue 33 item 3), on small grids so the file runs in seconds.

* A flat segmented wavefront through the perfect coronagraph: dark-zone contrast < 1e-10.
* One of N segments pistoned by δ (surface; the wavefront's piston is 2δ): the aperture RMS
  of that piston is σ = 2δ √((1/N)(1 − 1/N)) (the wavefront is 2δ on a fraction 1/N of the
  aperture and 0 elsewhere: its mean is 2δ/N, its variance (2δ)² (1/N)(1 − 1/N)); the
  Strehl ratio is Maréchal's exp(−(2πσ/λ)²) within 2 % (and exactly |1 − w + w e^{iφ}|²,
  φ = 4πδ/λ, w the segment's share of the aperture); the coronagraph's residual field is
  (e^{iφ} − 1)(segment − w aperture), so the dark-zone contrast is 4 sin²(φ/2) times a
  constant: ∝ δ² for small δ.
* Tilt θ of one segment (a surface slope, toward the light): reflection turns its beam by
  −2θ, so its light moves by −2θ f on the detector, −2θ D/λ in λ/D.
Then hcipy's own per-sample objects against the batched path, the frames in parallel
against serial (bit for bit), and the command on a synthetic run."""
import concurrent.futures
import csv
import math
import multiprocessing
import sys

import hcipy  # pinned by scripts/setup.sh: a venv without it fails here, it is not skipped
import numpy as np
import pytest

from conftest import ROOT
from inchworm_variables import InchwormMount as Mount

sys.path.insert(0, str(ROOT / "python" / "inchworm_segments"))
from inchworm_segments import __main__ as cli  # noqa: E402
from inchworm_segments import frames as F  # noqa: E402
from inchworm_segments.config import InputError, Telescope, rings_for  # noqa: E402
from inchworm_segments.poses import read_csv, synthetic, write_csv  # noqa: E402

#: One ring (7 segments) on a 48-pixel pupil: a segment is 15.5 pixels across.
SMALL = Telescope(pupil_px=48, supersampling=2, q=2, fov_lambda_d=12.0)
LAMBDA = SMALL.wavelength_m


@pytest.fixture(scope="module")
def optics():
    return F.optics_for(SMALL)


def one_segment(n, k, piston=0.0, tip=0.0, tilt=0.0):
    poses = np.zeros((1, n, 3))
    poses[0, k] = piston, tip, tilt
    return poses


@pytest.mark.parametrize("rings,centre,count", [(1, True, 7), (2, True, 19), (3, True, 37), (2, False, 18)])
def test_the_rings_give_hcipys_segments_inside_the_diameter(rings, centre, count):
    tel = Telescope(rings=rings, centre=centre, pupil_px=16 * (2 * rings + 1), supersampling=1)
    assert tel.segment_count == count and rings_for(count) == (rings, centre)
    o = F.optics_for(tel)
    assert len(o.segments) == count
    # Every lit pixel's centre lies within D/2 (plus half a pixel's diagonal), and the farthest
    # one within a pixel of it: D is the aperture's circumscribed circle.
    x, y, a = (np.asarray(v) for v in (o.pupil_grid.x, o.pupil_grid.y, o.aperture))
    pix = tel.diameter_m / tel.pupil_px
    r = np.hypot(x, y)[a > 0]
    assert r.max() <= tel.diameter_m / 2 + pix / math.sqrt(2), (r.max(), tel.diameter_m / 2)
    assert r.max() >= tel.diameter_m / 2 - pix, (r.max(), tel.diameter_m / 2)
    # The segments tile the aperture (no overlap) with nearly equal shares.
    assert np.allclose(sum(np.asarray(s) for s in o.segments), a)
    assert np.allclose(o.segment_weights, 1 / count, rtol=0.03), o.segment_weights


def test_a_flat_wavefront_through_the_perfect_coronagraph_is_dark(optics):
    fields = optics.fields(optics.opd_m(np.zeros((1, 7, 3))))
    img = optics.coronagraphic_images(fields)[0]
    assert optics.dark_zone.sum() > 500
    assert optics.dark_zone_contrast(img) < 1e-10 and img[optics.dark_zone].max() < 1e-10, img.max()
    # The same field unocculted: the flat PSF, whose axis pixel is the normalising peak.
    assert optics.unocculted_images(fields)[0][optics.axis_pixel] == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("delta_over_lambda", [1 / 200, 1 / 60, 1 / 24, 1 / 12])
def test_one_pistoned_segment_gives_marechals_strehl(optics, delta_over_lambda):
    n, k = 7, 3
    delta = delta_over_lambda * LAMBDA
    poses = one_segment(n, k, piston=delta)
    sigma = float(optics.cophasing_rms_m(poses)[0])
    closed = 2 * delta * math.sqrt((1 / n) * (1 - 1 / n))
    assert sigma == pytest.approx(closed, rel=0.01), (sigma, closed)  # pixelised shares, not exactly 1/N
    opd = optics.opd_m(poses)
    assert optics.wfe_rms_m(opd)[0] == pytest.approx(sigma, rel=1e-9)  # the piston is all of the WFE
    fields = optics.fields(opd)
    # The Strehl ratio from the propagated image's axis pixel and from the pupil sum agree.
    s_image = optics.unocculted_images(fields)[0][optics.axis_pixel]
    s = float(optics.strehl(fields)[0])
    assert s_image == pytest.approx(s, rel=1e-10)
    marechal = math.exp(-(2 * math.pi * sigma / LAMBDA) ** 2)
    assert abs(s / marechal - 1) < 0.02, (s, marechal)
    w, phi = optics.segment_weights[k], 4 * math.pi * delta / LAMBDA
    assert s == pytest.approx(abs(1 - w + w * np.exp(1j * phi)) ** 2, rel=1e-9)


def test_the_dark_zone_contrast_grows_with_the_square_of_the_piston(optics):
    n, k = 7, 5
    deltas = LAMBDA * np.array([1e-4, 3e-4, 1e-3, 3e-3])
    c = np.array([optics.dark_zone_contrast(optics.coronagraphic_images(optics.fields(optics.opd_m(
        one_segment(n, k, piston=d)))))[0] for d in deltas])
    slope = np.polyfit(np.log(deltas), np.log(c), 1)[0]
    assert abs(slope - 2) < 0.002, slope
    # Exactly 4 sin²(φ/2) × a constant, φ = 4πδ/λ, out to large pistons.
    big = LAMBDA * np.array([0.01, 0.05, 0.1, 0.2])
    cb = np.array([optics.dark_zone_contrast(optics.coronagraphic_images(optics.fields(optics.opd_m(
        one_segment(n, k, piston=d)))))[0] for d in big])
    ratio = cb / np.sin(2 * np.pi * big / LAMBDA) ** 2
    assert np.allclose(ratio, ratio[0], rtol=1e-8), ratio
    flat = optics.dark_zone_contrast(optics.coronagraphic_images(optics.fields(optics.opd_m(np.zeros((1, n, 3))))))
    assert c[0] > 1e6 * flat[0]  # δ = λ/10⁴ stands far above the flat's numerical floor


def segment_light(optics, k, grid, tip=0.0, tilt=0.0):
    """The image of segment k's light alone (its field, the others dark) on `grid`."""
    poses = one_segment(len(optics.segments), k, tip=tip, tilt=tilt)
    field = optics.fields(optics.opd_m(poses), only=[k])[0]
    prop = hcipy.FraunhoferPropagator(optics.pupil_grid, grid)
    return np.asarray(prop.forward(hcipy.Wavefront(field, LAMBDA)).power)


@pytest.mark.parametrize("axis", [Mount.TILT, Mount.TIP])
def test_a_segment_tilt_moves_its_light_by_twice_the_angle(optics, axis):
    k = 2
    lod = SMALL.lambda_over_d_rad
    # θ for a shift of exactly 1.5 λ/D = 3 focal pixels: the tilted image is the flat one moved.
    theta = -1.5 / 2 * lod
    shift = SMALL.tilt_shift_lambda_d(theta)
    assert shift == pytest.approx(1.5)
    grid = optics.focal_grid
    flat = segment_light(optics, k, grid).reshape(optics.focal_shape)
    moved = segment_light(optics, k, grid, **{axis: theta}).reshape(optics.focal_shape)
    # x follows tilt (dz/dx), y follows tip (dz/dy); image arrays are [y, x].
    if axis == Mount.TILT:
        assert np.allclose(moved[:, 3:], flat[:, :-3], atol=1e-12 * flat.max(), rtol=0)
    else:
        assert np.allclose(moved[3:, :], flat[:-3, :], atol=1e-12 * flat.max(), rtol=0)
    # The centroid of the segment's light at a shift that is no whole pixel, on a field
    # centred where the closed form puts it: the centroid sits on that centre (the hexagon's
    # PSF is centro-symmetric), and most of the light is in the field.
    theta = 0.37 * lod
    want = SMALL.tilt_shift_lambda_d(theta)  # −0.74 λ/D
    centre = np.array([want, 0.0] if axis == Mount.TILT else [0.0, want]) * lod
    # A field symmetric about its centre (hcipy's focal grids hold the origin, one pixel off symmetry).
    field = hcipy.make_uniform_grid([64, 64], 16 * lod).shifted(centre)
    img = segment_light(optics, k, field, **{axis: theta})
    cx = (img @ (np.asarray(field.x) - centre[0])) / img.sum() / lod
    cy = (img @ (np.asarray(field.y) - centre[1])) / img.sum() / lod
    assert abs(cx) < 1e-3 and abs(cy) < 1e-3, (cx, cy, want)
    axis_field = hcipy.make_uniform_grid([64, 64], 16 * lod)
    still = segment_light(optics, k, axis_field)  # untilted: its light sits on the axis
    assert abs(still @ np.asarray(axis_field.x)) / still.sum() / lod < 1e-3
    assert abs(still @ np.asarray(axis_field.y)) / still.sum() / lod < 1e-3
    # And the field on the axis does not hold the tilted light there: the closed form is what fits.
    off = segment_light(optics, k, axis_field, **{axis: theta})
    c_off = (off @ np.asarray(axis_field.x if axis == Mount.TILT else axis_field.y)) / off.sum() / lod
    assert c_off < 0.8 * want, c_off  # pulled toward the axis by the field's edge, but well off it


def test_the_batch_equals_hcipys_mirror_coronagraph_and_propagator():
    # On a binary pupil (no grey edges) a pixel is one piece and hcipy's segmented mirror
    # is the same model: its per-sample objects give the batch's images.
    optics = F.optics_for(Telescope(pupil_px=48, supersampling=1))
    rng = np.random.default_rng(7)
    poses = rng.normal(size=(3, 7, 3)) * np.array([20e-9, 50e-9, 50e-9])
    batch = optics.coronagraphic_images(optics.fields(optics.opd_m(poses)))
    for i in range(len(poses)):
        dm = hcipy.SegmentedDeformableMirror(optics.segments)
        # hcipy's mirror: path +2 × its surface; ours: −2 z, so its surface is −z (tilt = x-slope).
        for k, (p, tip, tilt) in enumerate(poses[i]):
            dm.set_segment_actuators(k, -p, -tilt, -tip)
        wf = optics.propagator(optics.coronagraph(dm(hcipy.Wavefront(optics.aperture, LAMBDA))))
        assert np.allclose(batch[i], np.asarray(wf.power) / optics.peak, rtol=1e-9, atol=1e-15)


def test_frames_in_parallel_are_bit_identical_to_serial():
    t, poses, parked = synthetic(7, duration_s=0.06, seed=3)
    serial = F.run(SMALL, t, poses, parked, frame_samples=5, frames_per_task=2)
    ctx = multiprocessing.get_context("fork")
    with concurrent.futures.ProcessPoolExecutor(2, mp_context=ctx) as pool:
        par = F.run(SMALL, t, poses, parked, frame_samples=5, executor=pool, frames_per_task=2)
    assert serial.frame_count == 6
    for name in ("cophasing_rms_m", "wfe_rms_m", "strehl", "contrast", "images", "frame_contrast"):
        a, b = getattr(serial, name), getattr(par, name)
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), name
    # A frame is the mean of its samples' images: its contrast the mean of theirs.
    assert np.allclose(serial.frame_contrast, serial.contrast.reshape(6, 5).mean(axis=1), rtol=1e-12)


def test_the_command_writes_every_figure_from_a_poses_csv(tmp_path, capsys):
    t, poses, parked = synthetic(7, duration_s=0.2, seed=5)
    src = tmp_path / "poses.csv"
    write_csv(src, t, poses, parked)
    t2, p2, k2 = read_csv(src)
    assert np.array_equal(t2, t) and np.array_equal(p2, poses) and np.array_equal(k2, parked)
    out = tmp_path / "out"
    assert cli.main(["--poses", str(src), "--out", str(out), "--pupil-px", "48", "--supersampling", "2",
                     "--frame-ms", "20", "--workers", "1"]) == 0
    for name in cli.OUTPUTS:
        assert (out / name).stat().st_size > 0, name
    with open(out / "segments-summary.csv", newline="") as f:
        numbers = {r["name"]: r["value"] for r in csv.DictReader(f)}
    with open(out / "segments-samples.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 100 and int(numbers["frames"]) == 10
    cp = np.array([float(r["cophasing_rms_nm"]) for r in rows])
    pk = np.array([r["parked"] == "1" for r in rows])
    assert pk.any() and not pk.all()
    assert float(numbers["cophasing_rms_parked_nm"]) == pytest.approx(math.sqrt(np.mean(cp[pk] ** 2)), rel=1e-9)
    assert "contrast_mean" in capsys.readouterr().out


@pytest.mark.parametrize("text,message", [
    ("time,seg0_piston_m\n0,1\n", "header"),
    ("time," + ",".join(f"seg{k}_{n}" for k in range(5) for n in ("piston_m", "tip_rad", "tilt_rad")) + "\n"
     + "0" + ",0" * 15 + "\n", "5 segments"),
    ("time,seg0_piston_m,seg0_tip_rad,seg0_tilt_rad\n0,nan,0,0\n", "finite"),
])
def test_a_bad_poses_csv_is_one_line_and_exit_2(tmp_path, capsys, text, message):
    src = tmp_path / "bad.csv"
    src.write_text(text)
    assert cli.main(["--poses", str(src), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    with pytest.raises(InputError):
        Telescope(rings=3, pupil_px=16)  # a segment under 4 pixels across


def test_the_optics_refuse_poses_outside_their_ranges(optics):
    from inchworm_segments.optics import SegmentedOptics

    with pytest.raises(InputError, match="poses: sample 0: seg0_piston_m nan: accepted a finite number"):
        optics.opd_m(np.full((1, 7, 3), np.nan))
    with pytest.raises(InputError, match="seg6_tilt_rad 2: accepted -1 ≤ value ≤ 1 rad"):
        optics.cophasing_rms_m(one_segment(7, 6, tilt=2.0))
    with pytest.raises(InputError, match=r"poses of shape \(1, 6, 3\): accepted \(samples, 7, 3\)"):
        optics.opd_m(np.zeros((1, 6, 3)))
    with pytest.raises(InputError, match="accepted a config.Telescope"):
        SegmentedOptics("7 segments")
