"""python/inchworm_optics: the mirror mount's secondary in a Cassegrain telescope, through
poppy. Closed forms (docs/optics.md): a secondary tilt θ moves the image by 2 θ s' (the
wavefront tilt 2 θ d2/D referred to the pupil, times f); a despace Δ is a focus of Noll Z4 =
(1 + m²) Δ / (16 √3 N²); a pure tilt keeps the Strehl ratio at 1; the perfect annular PSF's
encircled energy is Mahajan's. Then the FMPy coupling against `inchworm run`, and a short
run of the CLI on a small grid: the image motion equals the mount's pointing times the
lever, the guider holds the image that the unguided run leaves off, and the analog run's
parked figures (it has no parked sample) are empty, never NaN."""
import contextlib
import csv
import io
import json
import math
import re
import sys

import numpy as np
import pytest
from scipy import integrate, special

import ssp_masters as m
from conftest import DIST, ROOT
from test_mirror_mount import mirror_ssp  # noqa: F401  (the fixture: dist/MirrorMount.ssp)

sys.path.insert(0, str(ROOT / "python" / "inchworm_optics"))
from inchworm_optics import __main__ as cli  # noqa: E402
from inchworm_optics.cosim import CHAINS, MountCosim  # noqa: E402
from inchworm_optics.optics import Frame, Instrument  # noqa: E402
from inchworm_optics.telescope import Prescription  # noqa: E402

RX = Prescription()
RX_CLEAR = Prescription(obscuration_m=0.0)


@pytest.fixture(scope="module")
def inst():
    return Instrument(RX, npix_pupil=32, fov_pixels=32)


def frame_of(inst, piston, tip, tilt):
    opd = inst.opd_m([piston], [tip], [tilt])
    return Frame(inst, inst.fields(opd), opd, 0.0, 0.002)


def test_the_first_order_layout_of_the_default_telescope():
    # 0.5 m f/2 primary, m = 5, back focal distance 0.2 m: d = (m f1 - b)/(m + 1) = 0.8 m,
    # s' = 1 m, footprint d2 = D (f1 - d)/f1 = 0.1 m, lever 2 s' = 2 m/rad.
    for name, got, want in [("separation d (m)", RX.separation_m, 0.8), ("s' (m)", RX.secondary_to_focus_m, 1.0),
                            ("d2/D", RX.footprint_ratio, 0.2), ("lever (m/rad)", RX.lever_m_per_rad, 2.0),
                            ("f (m)", RX.focal_length_m, 5.0)]:
        assert abs(got - want) < 1e-12, f"{name} = {got}, expected {want} ± 1e-12"


@pytest.mark.parametrize("tip,tilt", [(4e-6, 0.0), (0.0, -2.5e-6), (1.5e-6, 3e-6)])
def test_a_tilt_moves_the_image_by_twice_the_tilt_times_the_distance_to_focus(inst, tip, tilt):
    f = frame_of(inst, RX.focus_piston_m, tip, tilt)
    # Image motion 2 θ s' = (2 θ d2/D) f: x follows tilt (dz/dx), y follows tip (dz/dy).
    want = np.array([tilt, tip]) * 2 * RX.secondary_to_focus_m
    also = np.array([tilt, tip]) * 2 * RX.footprint_ratio * RX.focal_length_m
    assert np.allclose(want, also, rtol=1e-12)
    got = np.array(f.centroid_px) * RX.pixel_m
    tol = 0.005 * np.hypot(*want)
    assert np.all(np.abs(got - want) <= tol), (
        f"image motion {got * 1e6} µm, expected 2θs' = {want * 1e6} µm ± {tol * 1e6:.4f} µm (0.5 %)")
    assert abs(f.strehl - 1.0) < 1e-4, f"Strehl of a pure tilt = {f.strehl}, expected 1 ± 1e-4"
    assert f.wfe_rms_m < 1e-15, f"WFE RMS of a pure tilt = {f.wfe_rms_m} m, expected 0 ± 1e-15 m"


def test_a_despace_is_the_expected_focus(inst):
    import poppy

    despace = 0.5e-6
    clear = Instrument(RX_CLEAR, npix_pupil=64, fov_pixels=16)
    opd = clear.opd_m([RX_CLEAR.focus_piston_m + despace], [0.0], [0.0])[0]
    # Noll Z1..Z11 from poppy on the pupil's own radius, fitted by least squares.
    rho = np.hypot(clear.X, clear.Y) / (RX.aperture_m / 2)
    theta = np.arctan2(clear.Y, clear.X)
    inside = (clear.amplitude > 0.999) & (rho <= 1)
    basis = np.stack([poppy.zernike.zernike1(j, rho=rho, theta=theta, outside=0.0)[inside] for j in range(1, 12)], axis=1)
    coeffs, *_ = np.linalg.lstsq(basis, opd[inside], rcond=None)
    z4 = coeffs[3]
    want = (1 + RX.secondary_magnification**2) * despace / (16 * math.sqrt(3) * RX.f_number**2)
    assert abs(z4 - want) <= 0.01 * abs(want), f"Z4 = {z4 * 1e9:.4f} nm, expected {want * 1e9:.4f} nm ± 1 %"
    others = np.delete(coeffs, [0, 3])
    assert np.max(np.abs(others)) < 0.01 * abs(want), f"non-focus Zernikes {others}, expected < 1 % of Z4"
    # Over the annular pupil: RMS W020 (1 − ε²)/(2√3), and the Strehl ratio Maréchal's.
    f = frame_of(inst, RX.focus_piston_m + despace, 0.0, 0.0)
    rms = RX.focus_rms_m(despace)
    assert abs(f.wfe_rms_m - rms) <= 0.01 * rms, f"WFE RMS {f.wfe_rms_m * 1e9:.4f} nm, expected {rms * 1e9:.4f} nm ± 1 %"
    marechal = math.exp(-(2 * math.pi * rms / RX.wavelength_m) ** 2)
    assert abs(f.strehl - marechal) < 1e-4, f"Strehl {f.strehl:.6f}, expected exp(-(2πσ/λ)²) = {marechal:.6f} ± 1e-4"


def test_a_sample_image_is_poppys_calc_psf(inst):
    import astropy.units as u
    import poppy

    opd = inst.opd_m([RX.focus_piston_m + 0.3e-6], [1.5e-6], [-0.7e-6])[0]
    ours = inst.images(inst.fields(opd[None]))[0]
    osys = poppy.OpticalSystem(npix=inst.npix_pupil, pupil_diameter=RX.aperture_m * u.m, oversample=1)
    osys.add_pupil(inst.pupil_optic)
    osys.add_pupil(poppy.ArrayOpticalElement(opd=opd, transmission=np.ones_like(opd),
                                             pixelscale=RX.aperture_m / inst.npix_pupil * u.m / u.pixel))
    osys.add_detector(pixelscale=math.degrees(RX.pixel_scale_rad) * 3600, fov_pixels=inst.fov_pixels, oversample=1)
    theirs = osys.calc_psf(RX.wavelength_m, normalize="first")[0].data
    diff = np.max(np.abs(ours - theirs)) / theirs.max()
    assert diff < 1e-9, f"image against poppy calc_psf: largest difference {diff:.2e} of the peak, expected < 1e-9"


def test_the_encircled_energy_of_the_perfect_annular_psf_is_mahajans(inst):
    f = frame_of(inst, RX.focus_piston_m, 0.0, 0.0)
    eps, v = RX.obscuration_ratio, math.pi * 1.22
    cross, _ = integrate.quad(lambda t: special.j1(t) * special.j1(eps * t) / t, 0, v)
    want = (1 - special.j0(v) ** 2 - special.j1(v) ** 2 + eps**2 * (1 - special.j0(eps * v) ** 2 - special.j1(eps * v) ** 2)
            - 4 * eps * cross) / (1 - eps**2)
    assert abs(f.ee - want) < 0.005, f"EE(1.22 λ/D) = {f.ee:.4f}, expected Mahajan's {want:.4f} ± 0.005"


def test_the_fmpy_coupling_is_inchworm_run_bit_for_bit(mirror_ssp):
    names = ["mount.piston", "mount.tip", "mount.tilt"]
    _, ref = m.inchworm(mirror_ssp, 0.6, names)
    sim = MountCosim(mirror_ssp)
    try:
        rows = [sim.pose()]
        for _ in range(300):
            sim.step()
            rows.append(sim.pose())
    finally:
        sim.close()
    rows = np.array(rows)
    for i, n in enumerate(names):
        diff = np.nonzero(rows[:, i] != ref[n])[0]
        assert diff.size == 0, f"{n}: FMPy coupling differs from inchworm run first at sample {diff[0]}"


def tip_only(tip, at_s):
    """SSP parameters: no piston move (the prescription in focus at 0), a tip at `at_s`; each
    actuator's share R tip sin φ on the mount's default geometry (R = 50 mm, a at 90°)."""
    phi = [math.radians(90 + 120 * i) for i in range(3)]
    params = []
    for x, p in zip(CHAINS, phi):
        params += [f"reference_{x}.positions[1]=0", f"reference_{x}.times[2]={at_s}",
                   f"reference_{x}.positions[2]={0.05 * tip * math.sin(p)!r}"]
    return params


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("optics")
    rx = out / "rx.json"
    rx.write_text(json.dumps({"focus_piston_m": 0.0}))
    args = ["--dist", str(DIST), "--out", str(out), "--prescription", str(rx),
            "--duration", "1.2", "--pupil", "16", "--fov", "24", "--runs", "stepping,drift,guided-analog",
            "--regulation", "0.4", "--drift", "0,0", "--offset", "150,-100", "--held-from", "0.9", "--bound", "5",
            "--guide-pause", "0"]
    for p in tip_only(2e-6, 0.1):
        args += ["--param", p]
    # The CLI's own entry point, in this process (poppy is imported once for the module).
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        rc = cli.main(args)
    assert rc == 0, stderr.getvalue()
    summary = {}
    with open(out / "optics-summary.csv", newline="") as f:
        for r in csv.DictReader(f):
            summary[(r["run"], r["figure"])] = float(r["value"]) if r["value"] else None  # empty: no samples
    return out, summary, stdout.getvalue()


def test_the_cli_writes_its_csvs_and_pngs(short_run):
    out, _, stdout = short_run
    for name in ["timeseries.csv", "samples.csv", "psf-strip.csv", "guidance.csv", "summary.csv",
                 "timeseries.png", "psf-strip.png", "guidance.png"]:
        path = out / f"optics-{name}"
        assert path.exists() and path.stat().st_size > 0, f"{path} missing or empty; stdout:\n{stdout}"


def test_the_image_moves_by_the_pointing_times_the_lever(short_run):
    _, s, _ = short_run
    for which in ("parked", "every"):
        pointing = s[("stepping", f"pointing_rms_{which}_nrad")]
        assert pointing > 0.5, f"pointing RMS ({which}) {pointing} nrad: the run must have a pointing error to compare"
        ratio = s[("stepping", f"image_over_lever_pointing_{which}")]
        assert abs(ratio - 1) <= 0.05, (
            f"image motion RMS / (lever × pointing RMS) over {which} samples = {ratio:.4f}, expected 1 ± 0.05")


def test_the_guider_holds_what_the_unguided_run_leaves(short_run):
    _, s, _ = short_run
    unguided, guided = s[("drift", "held_max_mas")], s[("guided-analog", "held_max_mas")]
    # A 180 mas line-of-sight offset (150, -100) from t = 0: unguided it stays; the guider
    # (10 Hz, gain 0.5, the mount in analog mode) takes it out within 0.9 s.
    assert unguided > 150, f"unguided image error {unguided:.1f} mas, expected the 180 mas offset (> 150)"
    assert guided < 5, f"guided image error {guided:.2f} mas from t = 0.9 s, expected < 5 mas"


def test_an_empty_window_is_reported_empty_not_nan(short_run):
    _, s, stdout = short_run
    # Analog mode dithers each encoder between two counts: no sample is parked for 8.
    assert s[("guided-analog", "n_parked_samples")] == 0, "the case needs a run with no parked sample"
    for figure in ("pointing_rms_parked_nrad", "piston_rms_parked_nm", "image_rms_parked_nm",
                   "image_over_lever_pointing_parked"):
        assert s[("guided-analog", figure)] is None, f"guided-analog {figure} = {s[('guided-analog', figure)]}, expected empty"
    nan = sorted(k for k, v in s.items() if v is not None and math.isnan(v))
    assert not nan, f"NaN figures in optics-summary.csv: {nan}"
    assert not re.search(r"\bnan\b", stdout, re.IGNORECASE), stdout
