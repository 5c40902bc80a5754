"""InchwormReference.fmu and InchwormMount.fmu in FMPy: validation, simulation with
defaults and with a table, and the same binary policy as the plant and the controller
(only fmi2* symbols, only the C runtime)."""
import shutil
import subprocess
import zipfile

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu

from conftest import built_fmu
from inchworm_variables import InchwormController as Controller, InchwormMount as Mount, InchwormReference as Reference

# glibc before 2.34 (the floor is 2.17) kept libdl and libpthread apart from libc; every
# glibc since still ships both names.
ALLOWED_NEEDED = {"libc.so.6", "libm.so.6", "libgcc_s.so.1", "ld-linux-x86-64.so.2", "libdl.so.2", "libpthread.so.0"}


@pytest.mark.parametrize("name", ["InchwormReference", "InchwormMount"])
def test_validates_and_exports_only_fmi2_symbols(name, tmp_path):
    fmu = built_fmu(name)
    assert validate_fmu(fmu) == []
    if not (shutil.which("nm") and shutil.which("readelf")):
        pytest.fail("nm and readelf (Debian binutils) are needed for this check")
    with zipfile.ZipFile(fmu) as z:
        so = z.extract(f"binaries/linux64/{name}.so", tmp_path)
    symbols = subprocess.run(["nm", "-D", "--defined-only", so], capture_output=True, text=True, check=True).stdout
    names = [line.split()[-1] for line in symbols.splitlines() if line.strip()]
    # The layer exports every FMI 2.0 function; a Co-Simulation-only FMU refuses the
    # Model Exchange ones (its fmi2Instantiate refuses fmi2ModelExchange).
    assert len([n for n in names if n.startswith("fmi2")]) == 44 and all(n.startswith("fmi2") for n in names)
    dynamic = subprocess.run(["readelf", "-d", so], capture_output=True, text=True, check=True).stdout
    needed = {line.split("[")[1].rstrip("]") for line in dynamic.splitlines() if "(NEEDED)" in line}
    assert needed <= ALLOWED_NEEDED, needed - ALLOWED_NEEDED


def test_reference_defaults_to_the_fig5_step_and_follows_a_ramped_table():
    fmu = built_fmu("InchwormReference")
    r = simulate_fmu(fmu, stop_time=1.0, output_interval=0.002, output=[Controller.REFERENCE])
    assert np.all(r[Controller.REFERENCE] == 100e-6)
    r = simulate_fmu(fmu, stop_time=1.0, output_interval=0.002, output=[Controller.REFERENCE],
                     start_values={Reference.N_POINTS: 2, Reference.TIMES_1: 0.1, Reference.POSITIONS_1: 20e-6,
                                   Reference.TIMES_2: 0.5, Reference.POSITIONS_2: -10e-6, Reference.RAMP_TIME: 0.1})
    t, x = r["time"], r[Controller.REFERENCE]
    assert np.all(x[t < 0.099] == 0.0)
    np.testing.assert_allclose(x[np.isclose(t, 0.15)], 10e-6, rtol=1e-9)
    assert np.all(x[(t > 0.201) & (t < 0.499)] == 20e-6)
    np.testing.assert_allclose(x[np.isclose(t, 0.55)], 5e-6, rtol=1e-9)
    assert np.all(x[t > 0.601] == -10e-6)


def test_mount_turns_three_positions_into_piston_tip_and_tilt():
    fmu = built_fmu("InchwormMount")
    r = simulate_fmu(fmu, stop_time=0.01, output_interval=0.002, output=[Mount.PISTON, Mount.TIP, Mount.TILT],
                     start_values={Mount.POSITION_A: 30.2e-6, Mount.POSITION_B: 29.9e-6, Mount.POSITION_C: 29.9e-6})
    np.testing.assert_allclose(r[Mount.PISTON][-1], 30e-6, rtol=1e-12)
    np.testing.assert_allclose(r[Mount.TIP][-1], 4e-6, rtol=1e-9)
    assert abs(r[Mount.TILT][-1]) < 1e-15
