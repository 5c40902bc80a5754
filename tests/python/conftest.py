"""Shared fixtures of the FMPy cross-tool tests: the built FMUs and the check data of
tests/data (docs/model.md §2.9)."""
import csv
import pathlib

import pytest
from inchworm_variables import InchwormPlant as Plant

ROOT = pathlib.Path(__file__).resolve().parents[2]
DIST = ROOT / "dist"
DATA = ROOT / "tests" / "data"
REFERENCE = DATA / "plant-check-trace-fia20-passive.csv"


def check_values(device):
    """[(EXT_moved, BD, position after)] in µm of the five check gaits of `device`."""
    with open(DATA / "plant-check-values.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["device"] == device]
    assert len(rows) == 5, f"{device}: five check-value rows"
    return [(float(r["ext_moved_um"]), float(r["bd_um"]), float(r["position_after_um"])) for r in rows]


FORWARD = [True, True, False, True, False]
WINDOWS = [(9, 13), (24, 28), (38, 42), (53, 57), (66, 70), (81, 85), (95, 99)]


def built_fmu(name):
    path = DIST / f"{name}.fmu"
    if not path.exists():
        pytest.fail(f"{path} is missing: run `cargo run --release -p fmu-build` first")
    return str(path)


@pytest.fixture(scope="session")
def plant_fmu():
    return built_fmu("InchwormPlant")


@pytest.fixture(scope="session")
def controller_fmu():
    return built_fmu("InchwormController")


@pytest.fixture(scope="session")
def reference_rows():
    with open(REFERENCE, newline="") as f:
        return [
            {k: float(v) for k, v in row.items()}
            for row in csv.DictReader(f)
        ]


def write_gait_input(rows, path):
    """FMPy input file of the reference DAC sequence: a repeated time row at every change,
    so FMPy holds the volts piecewise constant (it takes the value after the event)."""
    names = [Plant.DAC_EARTH, Plant.DAC_NONEARTH, Plant.DAC_EXTENSION]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time"] + names)
        prev = None
        for r in rows:
            cur = [r[n] for n in names]
            if prev is not None and cur != prev:
                w.writerow([repr(r["time"])] + prev)
            if cur != prev:
                w.writerow([repr(r["time"])] + cur)
            prev = cur
        w.writerow([repr(rows[-1]["time"] + 0.002)] + prev)


def raw_measurements(counts):
    """docs/model.md §3.3 raw measurements of 100-sample gaits from encoder counts (sample k = counts[k-1])."""
    out = []
    for g in range(len(counts) // 100):
        enc = [c * 1.2e-3 for c in counts[g * 100:(g + 1) * 100]]
        s = [sum(enc[a - 1:b]) / (b - a + 1) for a, b in WINDOWS]
        moved = s[3] - s[2] if FORWARD[g] else s[4] - s[3]
        out.append((moved, (s[6] - s[0]) - moved, s[6]))
    return out


def assert_check_values(counts, device="fia20"):
    failures = []
    expect = check_values(device)
    for g, (moved, bd, s7) in enumerate(raw_measurements(counts)):
        ext_ref, bd_ref, s7_ref = expect[g]
        for name, got, want in [("EXT_moved", moved, ext_ref), ("BD", bd, bd_ref), ("s7", s7, s7_ref)]:
            if abs(got - want) > 0.010:
                failures.append(f"{device} gait {g + 1}: {name} = {got:.4f} µm, expected {want} ± 0.010 µm")
    assert not failures, "\n".join(failures)
