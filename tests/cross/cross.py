"""Runs tests/cross/harness.c on an FMU's binary for one platform and reads what it prints:
shared by tests/python/test_platforms.py (Wine, qemu-user) and scripts/debian11.sh (a
Debian 11 root). Standard library only, so the Debian 11 proof needs no venv.

    python3 tests/cross/cross.py debian11 ROOT   # the comparison scripts/debian11.sh prints
    python3 tests/cross/cross.py native DIST     # this machine's platform, natively (the
                                                 # release workflow's test job)
"""
import os
import pathlib
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from inchworm_variables import InchwormController as Controller, InchwormPlant as Plant

ROOT = pathlib.Path(__file__).resolve().parents[2]
HARNESS = ROOT / "tests" / "cross" / "harness.c"
CHECK_TRACE = ROOT / "tests" / "data" / "plant-check-trace-fia20-passive.csv"
H = 0.002
Q_ENC = 1.2e-9  # encoder count (m), docs/model.md §2.6
FIG5_REFERENCE = 100e-6
FIG5_STEPS = 5000  # 10 s, as `inchworm scenario fig5`


def description(fmu):
    """(FMI major version, token, {variable name: value reference}) of an FMU."""
    with zipfile.ZipFile(fmu) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    major = int(root.get("fmiVersion")[0])
    token = root.get("guid") if major == 2 else root.get("instantiationToken")
    variables = root.find("ModelVariables")
    refs = {v.get("name"): v.get("valueReference") for v in variables}
    return major, token, refs


def extract(fmu, folder, name, ext, into):
    """The binary of one platform folder of an FMU, written into `into`."""
    out = pathlib.Path(into) / f"{name}.{ext}"
    with zipfile.ZipFile(fmu) as z:
        out.write_bytes(z.read(f"binaries/{folder}/{name}.{ext}"))
    return out


def check_args(fmu, lib):
    """Harness arguments of the check trace through the plant's library `lib`."""
    major, token, v = description(fmu)
    return [str(major), "check", str(lib), token, str(CHECK_TRACE)] + [
        v[n] for n in (Plant.DAC_EARTH, Plant.DAC_NONEARTH, Plant.DAC_EXTENSION, Plant.ENCODER_COUNTS)
    ]


def fig5_args(plant_fmu, plant_lib, ctrl_fmu, ctrl_lib, variant):
    """Harness arguments of the Fig. 5 loop (`full` or `feedback` control)."""
    major, ptoken, p = description(plant_fmu)
    _, ctoken, c = description(ctrl_fmu)
    dac = (Plant.DAC_EARTH, Plant.DAC_NONEARTH, Plant.DAC_EXTENSION)
    return (
        [str(major), "fig5", str(plant_lib), ptoken, str(ctrl_lib), ctoken, variant, str(FIG5_STEPS)]
        + [p[n] for n in dac + (Plant.ENCODER_COUNTS,)]
        + [c[n] for n in dac + (Plant.ENCODER_COUNTS, Controller.REFERENCE)]
        + [c[n] for n in (Controller.FEEDFORWARD, Controller.USE_SCALE_FACTOR_ESTIMATE, Controller.USE_DISTURBANCE_ESTIMATE)]
    )


def reference_counts():
    """The independent reference's encoder count after each of the 500 samples."""
    with open(CHECK_TRACE) as f:
        header = f.readline().strip().split(",")
        col = header.index("encoder_counts_after")
        return [int(float(line.split(",")[col])) for line in f if line.strip()]


def parse_check(stdout):
    return [int(line) for line in stdout.split()]


def parse_fig5(stdout):
    """[(counts, (dac_earth, dac_nonearth, dac_extension))] after each step."""
    rows = []
    for line in stdout.splitlines():
        c, *volts = line.split()
        rows.append((int(c), tuple(float(x) for x in volts)))
    return rows


def settle_time(rows):
    """First time after which every parked sample is within 1 µm of the reference, as
    `inchworm scenario fig5` reports it (src/closed_loop.rs): a sample is parked when the
    DAC outputs were zero for the 8 samples up to it. Sample i is the state at (i + 1) H,
    after the step whose volts were rows[i][1]."""
    parked = [i for i in range(8, len(rows)) if all(v == 0.0 for r in rows[i - 7:i + 1] for v in r[1])]
    bad = [j for j, i in enumerate(parked) if abs(FIG5_REFERENCE - rows[i][0] * Q_ENC) > 1e-6]
    if not bad:
        return round((parked[0] + 1) * H, 6) if parked else None
    j = bad[-1]
    return round((parked[j + 1] + 1) * H, 6) if j + 1 < len(parked) else None


def run(cmd, **kw):
    """`cmd`'s standard output; an error with the end of its standard error if it fails.
    Both are read from files, not pipes: under Wine the prefix's services (winedevice.exe)
    inherit them and outlive the harness, and a pipe would keep the call waiting for them."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        r = subprocess.run(cmd, stdin=subprocess.DEVNULL, stdout=out, stderr=err, text=True, **kw)
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read(), err.read()
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))} failed ({r.returncode}): {stderr[-2000:]}")
    return stdout


def debian11(root):
    """The check trace and the Fig. 5 loop through dist/'s FMI 2.0 FMUs on this machine
    and inside the Debian 11 root `root` (chroot), each with the harness built by that
    system's own gcc; prints the comparison and exits non-zero if it fails."""
    root = pathlib.Path(root)
    dist = ROOT / "dist"
    plant, ctrl = dist / "InchwormPlant.fmu", dist / "InchwormController.fmu"
    work = root / "inchworm"
    work.mkdir(exist_ok=True)
    for f in (HARNESS, CHECK_TRACE):
        (work / f.name).write_bytes(f.read_bytes())
    for fmu in (plant, ctrl):
        extract(fmu, "linux64", fmu.stem, "so", work)
    glibc_old = run(["chroot", str(root), "ldd", "--version"]).splitlines()[0]
    glibc_host = run(["ldd", "--version"]).splitlines()[0]
    run(["chroot", str(root), "gcc", "-std=c99", "-O2", "-o", "/inchworm/harness", "/inchworm/harness.c", "-ldl"])
    with tempfile.TemporaryDirectory() as tmp:
        host_harness = pathlib.Path(tmp) / "harness"
        run(["gcc", "-std=c99", "-O2", "-o", str(host_harness), str(HARNESS), "-ldl"])
        for fmu in (plant, ctrl):
            extract(fmu, "linux64", fmu.stem, "so", tmp)

        def both(args_of):
            inside = [a.replace(str(work), "/inchworm") for a in args_of(work)]
            old = run(["chroot", str(root), "/inchworm/harness"] + inside[0:])
            new = run([str(host_harness)] + args_of(pathlib.Path(tmp)))
            return old, new

        def check(d):
            args = check_args(plant, d / "InchwormPlant.so")
            # Inside the root, the copy of the trace beside the harness.
            return [a.replace(str(CHECK_TRACE), str(work / CHECK_TRACE.name)) for a in args] if d == work else args

        old, new = both(check)
        old_c, new_c, ref = parse_check(old), parse_check(new), reference_counts()
        worst = max(abs(a - b) for a, b in zip(old_c, new_c))
        worst_ref = max(abs(a - b) for a, b in zip(old_c, ref))
        print(f"Debian 11 root: {glibc_old}; host: {glibc_host}")
        print(f"check trace, {len(old_c)} samples: Debian 11 vs host max |diff| {worst} counts "
              f"({sum(a != b for a, b in zip(old_c, new_c))} samples differ); Debian 11 vs the "
              f"independent reference max |diff| {worst_ref} counts")
        ok = len(old_c) == len(new_c) == len(ref) == 500 and worst <= 1 and worst_ref <= 1
        for variant in ("full", "feedback"):
            old, new = both(lambda d, v=variant: fig5_args(plant, d / "InchwormPlant.so", ctrl, d / "InchwormController.so", v))
            o, n = parse_fig5(old), parse_fig5(new)
            ts_o, ts_n = settle_time(o), settle_time(n)
            same = sum(a[0] == b[0] for a, b in zip(o, n))
            print(f"Fig. 5 {variant} control: settles within 1 um at {ts_o} s on Debian 11, "
                  f"{ts_n} s on the host; encoder equal in {same} of {len(n)} samples")
            ok = ok and ts_o == ts_n and ts_o is not None and len(o) == len(n) == FIG5_STEPS
    print("Debian 11 comparison:", "PASS" if ok else "FAIL")
    return 0 if ok else 1


def host_folders():
    """(FMI 2.0 folder or None, FMI 3.0 tuple, library extension) of this machine."""
    import platform

    arch = {"amd64": "x86_64", "x86_64": "x86_64", "arm64": "aarch64", "aarch64": "aarch64"}[platform.machine().lower()]
    system = {"Linux": "linux", "Windows": "windows", "Darwin": "darwin"}[platform.system()]
    fmi2 = {("x86_64", "linux"): "linux64", ("x86_64", "windows"): "win64"}.get((arch, system))
    if system == "darwin":
        fmi2 = "darwin64"
    ext = {"linux": "so", "windows": "dll", "darwin": "dylib"}[system]
    return fmi2, f"{arch}-{system}", ext


def native(dist):
    """The check trace and the Fig. 5 loop through this machine's own binaries in every FMU
    that has them, with the harness built by the machine's C compiler."""
    dist = pathlib.Path(dist)
    fmi2, fmi3, ext = host_folders()
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        exe = tmp / ("harness.exe" if ext == "dll" else "harness")
        cc = os.environ.get("CC", "gcc" if ext == "dll" else "cc")
        run([cc, "-std=c99", "-O2", "-o", str(exe), str(HARNESS)] + ([] if ext == "dll" else ["-ldl"] if ext == "so" else []))
        traces = {}
        for sub, folder in (("", fmi2), ("fmi3", fmi3)):
            if folder is None:
                continue
            d = tmp / (sub or "fmi2")
            d.mkdir()
            plant, ctrl = dist / sub / "InchwormPlant.fmu", dist / sub / "InchwormController.fmu"
            pl, cl = extract(plant, folder, "InchwormPlant", ext, d), extract(ctrl, folder, "InchwormController", ext, d)
            counts = parse_check(run([str(exe)] + check_args(plant, pl)))
            worst = max(abs(a - b) for a, b in zip(counts, reference_counts()))
            rows = parse_fig5(run([str(exe)] + fig5_args(plant, pl, ctrl, cl, "full")))
            ts = settle_time(rows)
            print(f"{folder}: check trace within {worst} counts of the reference over {len(counts)} samples; "
                  f"Fig. 5 full control settles at {ts} s")
            ok = ok and len(counts) == 500 and worst <= 1 and ts == 0.788
            traces[folder] = (counts, rows)
        if len(traces) == 2:
            same = len({repr(v) for v in traces.values()}) == 1
            print(f"FMI 2.0 and FMI 3.0 traces identical: {same}")
            ok = ok and same
    print("native:", "PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "debian11":
        sys.exit(debian11(sys.argv[2]))
    if len(sys.argv) == 3 and sys.argv[1] == "native":
        sys.exit(native(sys.argv[2]))
    sys.exit(__doc__)
