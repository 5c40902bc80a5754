"""The shared libraries inside the FMUs export only fmi2* symbols and need nothing beyond
the C runtime, and every shipped Linux binary (the FMUs' libraries for x86-64 and aarch64,
and dist/bin/inchworm) needs no glibc symbol version above 2.17, so they load in any master
on any Linux with glibc 2.17 or newer."""
import shutil
import subprocess
import zipfile

import pytest

from conftest import DIST, built_fmu
from inchworm_variables import FMI2_FMUS, FMI3_FMUS

# glibc before 2.34 (the floor is 2.17) kept libdl and libpthread apart from libc; every
# glibc since still ships both names.
ALLOWED_NEEDED = {"libc.so.6", "libm.so.6", "libgcc_s.so.1", "ld-linux-x86-64.so.2", "libdl.so.2", "libpthread.so.0"}


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


# The glibc floor (docs/platforms.md): every Linux binary fmu-build ships is linked against
# glibc 2.17 symbol versions (cargo-zigbuild), so it loads on RHEL 7/8, Ubuntu 20.04,
# Debian 11 and everything newer, not only on the glibc of the machine that built it.
GLIBC_FLOOR = (2, 17)
ALL_FMUS = [("", n) for n in FMI2_FMUS] + [("fmi3", n) for n in FMI3_FMUS]


def glibc_versions(path):
    """The GLIBC_x.y versions an ELF file needs (readelf reads any architecture's ELF)."""
    out = subprocess.run(["readelf", "-V", "--wide", str(path)], capture_output=True, text=True, check=True).stdout
    found = set()
    for line in out.splitlines():
        if "Name: GLIBC_" in line:
            v = line.split("Name: GLIBC_")[1].split()[0]
            if v[0].isdigit():
                found.add(tuple(int(x) for x in v.split(".")))
    return found


def shipped_linux_binaries(tmp_path):
    """(label, path) of every Linux shared library in every FMU and the `inchworm` binary."""
    out = []
    for sub, name in ALL_FMUS:
        fmu = DIST / sub / f"{name}.fmu"
        assert fmu.exists(), f"{fmu} is missing: run `cargo run --release -p fmu-build` first"
        with zipfile.ZipFile(fmu) as z:
            for member in z.namelist():
                folder = member.split("/")[1] if member.startswith("binaries/") else ""
                if member.endswith(".so") and ("linux" in folder):
                    out.append((f"{sub or 'fmi2'}/{name}.fmu:{member}", z.extract(member, tmp_path / sub / name)))
    exe = DIST / "bin" / "inchworm"
    assert exe.exists(), f"{exe} is missing: run `cargo run --release -p fmu-build` first"
    out.append(("dist/bin/inchworm", exe))
    return out


def test_every_shipped_linux_binary_needs_at_most_glibc_2_17(tmp_path):
    if not shutil.which("readelf"):
        pytest.fail("readelf (Debian binutils) is needed for this check")
    binaries = shipped_linux_binaries(tmp_path)
    # Each FMI 2.0 FMU's linux64 + each FMI 3.0 FMU's x86_64-linux and aarch64-linux + the master.
    assert len(binaries) == len(FMI2_FMUS) + 2 * len(FMI3_FMUS) + 1, [b[0] for b in binaries]
    over = {}
    for label, path in binaries:
        versions = glibc_versions(path)
        assert versions, f"{label}: no GLIBC symbol versions read (not a dynamically linked glibc binary?)"
        above = sorted(v for v in versions if v > GLIBC_FLOOR)
        if above:
            over[label] = ".".join(map(str, above[-1]))
    assert over == {}, f"binaries above GLIBC_2.17: {over}"


def test_the_floor_check_sees_a_newer_glibc(tmp_path):
    """The reader above is not blind: a program built here with the system gcc against
    Debian 12's glibc needs versions above the floor (it calls a function of glibc 2.34)."""
    if not shutil.which("gcc"):
        pytest.fail("gcc is needed for this check")
    src = tmp_path / "new.c"
    src.write_text("#include <stdio.h>\n#include <pthread.h>\nint main(void){pthread_t t=pthread_self();"
                   "printf(\"%lu\\n\",(unsigned long)t);return 0;}\n")
    subprocess.run(["gcc", "-o", str(tmp_path / "new"), str(src)], check=True)
    assert max(glibc_versions(tmp_path / "new")) > GLIBC_FLOOR
