"""Shared fixtures of the FMPy cross-tool tests: the built FMUs and the SPEC reference data."""
import csv
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
DIST = ROOT / "dist"
REFERENCE = ROOT.parent / "shared" / "reference" / "plant-check-trace-fia20.csv"

# SPEC 2.9 check values (µm), gaits +1, +1, -1, +0.3, -0.3.
CHECK_EXT_MOVED = [18.210, 19.383, -19.342, 6.633, -6.690]
CHECK_BD = [4.685, 4.853, 3.902, 4.687, 4.244]
CHECK_S7 = [22.895, 47.130, 31.691, 43.010, 40.565]
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
    names = ["dac_earth", "dac_nonearth", "dac_extension"]
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
    """SPEC 3.3 raw measurements of 100-sample gaits from encoder counts (sample k = counts[k-1])."""
    out = []
    for g in range(len(counts) // 100):
        enc = [c * 1.2e-3 for c in counts[g * 100:(g + 1) * 100]]
        s = [sum(enc[a - 1:b]) / (b - a + 1) for a, b in WINDOWS]
        moved = s[3] - s[2] if FORWARD[g] else s[4] - s[3]
        out.append((moved, (s[6] - s[0]) - moved, s[6]))
    return out


def assert_check_values(counts):
    failures = []
    for g, (moved, bd, s7) in enumerate(raw_measurements(counts)):
        for name, got, want in [("EXT_moved", moved, CHECK_EXT_MOVED[g]), ("BD", bd, CHECK_BD[g]), ("s7", s7, CHECK_S7[g])]:
            if abs(got - want) > 0.010:
                failures.append(f"gait {g + 1}: {name} = {got:.4f} µm, expected {want} ± 0.010 µm")
    assert not failures, "\n".join(failures)
