"""The shared libraries inside the FMUs export only fmi2* symbols and need nothing beyond
the C runtime, so they load in any master on any Linux with glibc."""
import shutil
import subprocess
import zipfile

import pytest

from conftest import built_fmu

ALLOWED_NEEDED = {"libc.so.6", "libm.so.6", "libgcc_s.so.1", "ld-linux-x86-64.so.2"}


@pytest.mark.parametrize("name", ["InchwormPlant", "InchwormController"])
def test_only_fmi2_symbols_and_only_the_c_runtime(name, tmp_path):
    if not (shutil.which("nm") and shutil.which("readelf")):
        pytest.fail("nm and readelf (Debian binutils) are needed for this check")
    with zipfile.ZipFile(built_fmu(name)) as z:
        so = z.extract(f"binaries/linux64/{name}.so", tmp_path)
    symbols = subprocess.run(["nm", "-D", "--defined-only", so], capture_output=True, text=True, check=True).stdout.split("\n")
    names = [line.split()[-1] for line in symbols if line.strip()]
    # All 44 functions of FMI 2.0: the common ones, Model Exchange's and Co-Simulation's.
    assert len([n for n in names if n.startswith("fmi2")]) == 44
    assert [n for n in names if not n.startswith("fmi2")] == []
    dynamic = subprocess.run(["readelf", "-d", so], capture_output=True, text=True, check=True).stdout
    needed = {line.split("[")[1].rstrip("]") for line in dynamic.splitlines() if "(NEEDED)" in line}
    assert needed <= ALLOWED_NEEDED, needed - ALLOWED_NEEDED
