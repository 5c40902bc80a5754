"""The evidence each FMU carries (docs/platforms.md): reference results in
extra/org.fmi-standard.fmi-ls-ref/ that FMPy reproduces exactly from the FMU, a
documentation page with the model's figures, and the compatibility tree
dist/cross-check/, which FMPy's vendor-repository validation accepts."""
import csv
import pathlib
import sys
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.cross_check.validate_vendor_repo import validate_repo, validate_test_fmu

from conftest import DIST, REFERENCE, ROOT
from inchworm_variables import FMI2_FMUS, FMI3_FMUS, InchwormController as Controller, InchwormPlant as Plant

sys.path.insert(0, str(ROOT / "scripts"))
import reference_results  # noqa: E402

LS_REF = "extra/org.fmi-standard.fmi-ls-ref"
ALL_FMUS = [("", n) for n in FMI2_FMUS] + [("fmi3", n) for n in FMI3_FMUS]
TREE = DIST / "cross-check"


def fmu(sub, name):
    path = DIST / sub / f"{name}.fmu"
    if not path.exists():
        pytest.fail(f"{path} is missing: run `cargo run --release -p fmu-build` first")
    return path


def read(path):
    return np.genfromtxt(path, delimiter=",", names=True, deletechars="")


@pytest.mark.parametrize("sub,name", ALL_FMUS)
def test_extra_holds_the_committed_reference_results_and_a_manifest_of_them(sub, name):
    committed = ROOT / "fmu-build" / "reference" / name
    with zipfile.ZipFile(fmu(sub, name)) as z:
        files = {n[len(LS_REF) + 1:]: z.read(n) for n in z.namelist() if n.startswith(LS_REF + "/")}
    manifest = ET.fromstring(files.pop("fmi-ls-manifest.xml"))
    ns = "{http://fmi-standard.org/fmi-ls-manifest}"
    assert manifest.tag == "fmiReferences"
    assert manifest.get(f"{ns}fmi-ls-name") == "org.fmi-standard.fmi-ls-ref"
    related = {r.get("source"): r.get("role") for r in manifest.findall("Related")}
    expected = {f"{name}_ref.csv": "result", f"{name}_ref.opt": "options"}
    if (committed / f"{name}_in.csv").exists():
        expected[f"{name}_in.csv"] = "input"
    assert related == expected
    assert set(files) == set(expected)
    for f, data in files.items():
        assert data == (committed / f).read_bytes(), f


@pytest.mark.parametrize("sub,name", ALL_FMUS)
def test_fmpy_reproduces_the_reference_results_from_the_fmu_alone(sub, name, tmp_path):
    with zipfile.ZipFile(fmu(sub, name)) as z:
        for n in z.namelist():
            if n.startswith(LS_REF + "/"):
                z.extract(n, tmp_path)
    d = tmp_path / LS_REF
    ref = read(d / f"{name}_ref.csv")
    result = reference_results.simulate(fmu(sub, name), d, name)
    assert result.dtype.names == ref.dtype.names
    assert len(result) == len(ref) > 100
    for col in ref.dtype.names:
        got = result[col].astype(float)
        bad = np.flatnonzero(got != ref[col])
        assert bad.size == 0, f"{col} differs first at t = {ref['time'][bad[0]]}: {got[bad[0]]} vs {ref[col][bad[0]]}"
    if name == "InchwormReference":
        assert np.all(ref[Controller.REFERENCE] == 100e-6), "the default: the Fig. 5 step from t = 0"
    else:
        assert any(np.ptp(ref[c]) > 0 for c in ref.dtype.names[1:]), "the experiment moves the outputs"


def test_the_plant_reference_output_is_the_independent_check_trace_within_one_count():
    ref = read(ROOT / "fmu-build" / "reference" / "InchwormPlant" / "InchwormPlant_ref.csv")
    with open(REFERENCE, newline="") as f:
        independent = [int(float(r["encoder_counts_after"])) for r in csv.DictReader(f)]
    counts = ref[Plant.ENCODER_COUNTS][1:].astype(int)
    assert len(counts) == len(independent) == 500
    assert int(np.max(np.abs(counts - np.array(independent)))) <= 1


def test_the_controller_reference_output_is_the_fig5_loop():
    """Its input is the encoder of the FMU loop; its output drives the runner to 100 µm
    (the encoder within 1 µm over the last 50 ms, after the last correcting gait)."""
    d = ROOT / "fmu-build" / "reference" / "InchwormController"
    inp = read(d / "InchwormController_in.csv")
    late = inp[Plant.ENCODER_COUNTS][inp["time"] >= 1.95] * 1.2e-3
    assert late.size > 0 and np.all(np.abs(late - 100.0) < 1.0)
    out = read(d / "InchwormController_ref.csv")
    assert np.any(out[Plant.DAC_EXTENSION] != 0) and np.all(out[Plant.DAC_EXTENSION][out["time"] > 1.95] == 0)


@pytest.mark.parametrize("sub,name", ALL_FMUS)
def test_documentation_shows_the_figures_and_the_attributes_stay_explicit(sub, name):
    with zipfile.ZipFile(fmu(sub, name)) as z:
        html = z.read("documentation/index.html").decode()
        images = [n for n in z.namelist() if n.startswith("documentation/") and n.endswith(".png")]
        md = z.read("modelDescription.xml").decode()
    assert images, "figures"
    for img in images:
        assert f'<img src="{img.split("/", 1)[1]}"' in html
    assert f"<code>{name}_ref.csv</code>" in html
    # Stated, not left to the defaults (which are the same): importers that check for
    # them find them.
    assert 'canBeInstantiatedOnlyOncePerProcess="false"' in md
    assert 'needsExecutionTool="false"' in md


def tree_folder(version, platform, name):
    return TREE / "fmus" / version / "cs" / platform / "inchworm" / "0.1.0" / name


def test_the_compatibility_tree_passes_fmpys_vendor_repository_validation():
    assert TREE.is_dir(), "run `cargo run --release -p fmu-build` first"
    fmu_count, result_count, problems = validate_repo(str(TREE))
    assert problems == []
    assert fmu_count == len(ALL_FMUS) and result_count == 0
    # validate_repo checks only FMI 1.0 and 2.0 folders: the FMI 3.0 ones directly.
    for sub, name in ALL_FMUS:
        version, platform = ("3.0", "x86_64-linux") if sub else ("2.0", "linux64")
        d = tree_folder(version, platform, name)
        assert validate_test_fmu(str(d)) == [], d
        assert read_model_description(str(d / f"{name}.fmu")).fmiVersion == version
        files = sorted(p.name for p in d.iterdir())
        expected = {f"{name}.fmu", f"{name}_ref.csv", f"{name}_ref.opt", "ReadMe.md"}
        assert expected <= set(files) <= expected | {f"{name}_in.csv"}


def test_the_validation_finds_a_broken_folder(tmp_path):
    """validate_test_fmu is not blind: a reference naming an unknown variable fails."""
    import shutil
    d = tmp_path / "fmus" / "2.0" / "cs" / "linux64" / "inchworm" / "0.1.0" / "InchwormReference"
    shutil.copytree(tree_folder("2.0", "linux64", "InchwormReference"), d)
    (d / "InchwormReference_ref.csv").write_text("time,no_such_variable\n0,1\n1,2\n")
    _, _, problems = validate_repo(str(tmp_path))
    assert len(problems) == 1 and "no_such_variable" in problems[0]


@pytest.mark.parametrize("sub,name", ALL_FMUS)
def test_each_simulates_in_fmpy_against_its_tree_reference(sub, name):
    version, platform = ("3.0", "x86_64-linux") if sub else ("2.0", "linux64")
    d = tree_folder(version, platform, name)
    ref = read(d / f"{name}_ref.csv")
    result = reference_results.simulate(d / f"{name}.fmu", d, name)
    for col in ref.dtype.names:
        assert np.array_equal(result[col].astype(float), ref[col]), col
