"""`inchworm run` on hostile inputs: every crafted SSP, FMU or CSV is built here in tmp_path
from the project's own dist/ files, and each case runs target/release/inchworm in its own
subprocess with a timeout, so a crash, an abort or a hang fails the case. Each case asserts
the exit status and the message, and that no unpacked folder is left behind."""
import os
import pathlib
import shutil
import signal
import subprocess
import time
import zipfile

import pytest

from conftest import DIST, ROOT

# INCHWORM_BIN: another build to hold to the same cases (e.g. an older one, to see them fail).
BIN = pathlib.Path(os.environ.get("INCHWORM_BIN", ROOT / "target" / "release" / "inchworm"))
SSP = DIST / "InchwormSystemOpen.ssp"  # the system with a reference input
PLANT = DIST / "InchwormPlant.fmu"


@pytest.fixture(autouse=True)
def built():
    if not BIN.is_file():
        pytest.fail(f"{BIN} is missing: cargo build --release -p inchworm")
    if not SSP.is_file():
        pytest.fail(f"{SSP} is missing: run `cargo run --release -p fmu-build` first")


@pytest.fixture
def tmp(tmp_path):
    """The folder the binary unpacks into (its TMPDIR); checked empty after the case."""
    t = tmp_path / "tmpdir"
    t.mkdir()
    yield t
    assert sorted(p.name for p in t.iterdir()) == [], "an unpacked folder was left behind"


def inchworm(tmp, *args, env=None, timeout=60):
    e = dict(os.environ, TMPDIR=str(tmp))
    e.pop("RUST_BACKTRACE", None)
    e.update(env or {})
    return subprocess.run(
        [str(BIN), *map(str, args)], capture_output=True, text=True, timeout=timeout, env=e, errors="replace"
    )


def error_line(r):
    """The last stderr line, which must be the one `error: …` line and no backtrace."""
    assert "panicked" not in r.stderr and "stack backtrace" not in r.stderr, r.stderr[-2000:]
    lines = r.stderr.strip().splitlines()
    assert lines, "no message"
    return lines[-1]


def ref_csv(tmp_path, text="time,reference\n0,100e-6\n", name="ref.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def rezip(src, dst, replace=None, add=None, drop=()):
    """`src` copied to `dst`, entries replaced (name -> bytes), added (name -> bytes) or dropped."""
    replace, add = replace or {}, add or {}
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for info in zin.infolist():
            if info.filename in drop:
                continue
            zout.writestr(info.filename, replace.get(info.filename, zin.read(info.filename)))
        for name, data in add.items():
            zout.writestr(name, data)
    return dst


def ssd_text():
    with zipfile.ZipFile(SSP) as z:
        return z.read("SystemStructure.ssd").decode()


def ssp_with_ssd(tmp_path, ssd, name="hostile.ssp", **kw):
    return rezip(SSP, tmp_path / name, replace={"SystemStructure.ssd": ssd.encode()}, **kw)


def fmu_md(fmu=PLANT):
    with zipfile.ZipFile(fmu) as z:
        return z.read("modelDescription.xml").decode()


def run_ssp(tmp, tmp_path, ssp, *extra, **kw):
    return inchworm(tmp, "run", ssp, "--input", ref_csv(tmp_path), "--stop-time", "0.01",
                    "--out", tmp_path / "out.csv", *extra, **kw)


def line_of_end(text):
    return text.count("\n") + 1


# 3. The master streams; no preallocation, no failure at the last step.

def test_a_tiny_step_is_no_allocation_abort(tmp, tmp_path):
    r = inchworm(tmp, "run", SSP, "--input", ref_csv(tmp_path), "--step-size", "1e-9", "--out", tmp_path / "o.csv")
    assert r.returncode == 1, r.stderr[-2000:]
    assert "memory allocation" not in r.stderr
    assert "communicationStepSize 0.000000001 s is not a whole number of 2 ms samples" in r.stderr
    assert error_line(r).startswith("error: InchwormController: fmi2DoStep returned fmi2Error at t = 0 s")


def test_a_stop_time_past_the_countable_is_refused_before_the_run(tmp, tmp_path):
    r = inchworm(tmp, "run", SSP, "--input", ref_csv(tmp_path), "--stop-time", "1e300", "--out", tmp_path / "o.csv")
    assert r.returncode == 1
    assert error_line(r) == (
        "error: stop time 1e300 / step size 0.002 = 5e302 steps: more than the 2^53 this master can count exactly"
    )
    assert not (tmp_path / "o.csv").exists()


def test_a_stop_time_that_is_not_a_whole_number_of_steps_is_refused_before_the_run(tmp, tmp_path):
    r = inchworm(tmp, "run", SSP, "--input", ref_csv(tmp_path), "--stop-time", "0.011", "--out", tmp_path / "o.csv")
    assert r.returncode == 1
    assert error_line(r) == (
        "error: stop time 0.011 is not a whole number of steps of 0.002 (0.011 / 0.002 = 5.5): choose a stop time that is"
    )
    assert not (tmp_path / "o.csv").exists()


def rss_kib(pid):
    with open(f"/proc/{pid}/status") as f:
        return int(next(l for l in f if l.startswith("VmHWM:")).split()[1])


@pytest.mark.parametrize("sig,name", [(signal.SIGTERM, "SIGTERM"), (signal.SIGINT, "SIGINT")])
def test_a_long_run_streams_in_flat_memory_and_a_signal_cleans_up(tmp, tmp_path, sig, name):
    out = tmp_path / "long.csv"
    e = dict(os.environ, TMPDIR=str(tmp))
    p = subprocess.Popen([str(BIN), "run", SSP, "--input", ref_csv(tmp_path), "--stop-time", "1e9", "--out", out],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=e)
    try:
        deadline = time.time() + 60
        while time.time() < deadline and (not out.exists() or out.stat().st_size < 20_000_000):
            assert p.poll() is None, p.communicate()
            time.sleep(0.2)
        assert out.stat().st_size >= 20_000_000, "rows are written as they are computed"
        unpacked = sorted(p.name.split("-")[1] for p in tmp.iterdir())
        assert unpacked == ["fmu", "fmu", "ssp"], "the SSP and its two FMUs while running"
        assert rss_kib(p.pid) < 100_000, "the run's memory does not grow with its rows"
        p.send_signal(sig)
        _, err = p.communicate(timeout=30)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert p.returncode == 128 + sig, err[-2000:]
    last = err.strip().splitlines()[-1]
    assert last.startswith(f"error: interrupted by {name} ({out} holds the rows to t = "), last
    with open(out) as f:
        assert f.readline() == "time,encoder_position,runner_position,disturbance_estimate,servo_error\n"


# 4. Truncated XML is refused, not run as a smaller system.

def test_a_truncated_ssd_is_refused_with_line_and_expected_tag(tmp, tmp_path):
    ssd = ssd_text()
    cut = ssd[: ssd.index('<ssd:Connection startElement="plant" startConnector="encoder_counts"')]
    r = run_ssp(tmp, tmp_path, ssp_with_ssd(tmp_path, cut))
    assert r.returncode == 1
    assert error_line(r) == (
        f"error: {tmp_path / 'hostile.ssp'}: SystemStructure.ssd line {line_of_end(cut)}: the file ends inside "
        "<ssd:SystemStructureDescription> <ssd:System> <ssd:Connections>: expected </ssd:Connections> (a truncated file?)"
    )


def test_a_truncated_ssv_is_refused_with_line_and_expected_tag(tmp, tmp_path):
    with zipfile.ZipFile(SSP) as z:
        ssv = z.read("resources/plant.fia20.ssv").decode()
    cut = ssv[: ssv.rindex("<ssv:Parameter ")]
    ssp = rezip(SSP, tmp_path / "cut-ssv.ssp", replace={"resources/plant.fia20.ssv": cut.encode()})
    r = run_ssp(tmp, tmp_path, ssp, "--parameter-set", "fia20")
    assert r.returncode == 1
    assert error_line(r) == (
        f"error: resources/plant.fia20.ssv: line {line_of_end(cut)}: the file ends inside "
        "<ssv:ParameterSet> <ssv:Parameters>: expected </ssv:Parameters> (a truncated file?)"
    )


def test_a_truncated_model_description_is_refused_with_line_and_expected_tag(tmp, tmp_path):
    md = fmu_md()
    cut = md[: md.index("</ModelVariables>")]
    fmu = rezip(PLANT, tmp_path / "cut.fmu", replace={"modelDescription.xml": cut.encode()})
    r = inchworm(tmp, "run", fmu, "--stop-time", "0.01", "--out", tmp_path / "o.csv")
    assert r.returncode == 1
    line = error_line(r)
    assert line.startswith(f"error: {fmu}: ") and f"modelDescription.xml line {line_of_end(cut)}, column " in line, line
    assert line.endswith(
        "the file ends inside <fmiModelDescription> <ModelVariables>: expected </ModelVariables> (a truncated file?)"
    ), line


# 6. Caps on what an archive unpacks to (small bombs: the caps lowered by their variables).

def zeros_ssp(tmp_path, size, name="bomb.ssp"):
    return rezip(SSP, tmp_path / name, add={"resources/zeros.bin": b"\0" * size})


def unpacked_sizes(path):
    """(all entries together, the largest entry) of an archive, unpacked, in bytes: the
    caps below are set above what the real SSP needs (its FMUs carry every platform's
    binary, docs/platforms.md), so only the added zeros pass them."""
    with zipfile.ZipFile(path) as z:
        sizes = [i.file_size for i in z.infolist()]
    return sum(sizes), max(sizes)


def test_an_ssp_that_unpacks_past_the_total_cap_is_refused(tmp, tmp_path):
    total, _ = unpacked_sizes(SSP)
    cap = total + 3_000_000
    ssp = zeros_ssp(tmp_path, 4_000_000)
    assert ssp.stat().st_size < SSP.stat().st_size + 1_000_000, "4 MB of zeros pack small"
    r = run_ssp(tmp, tmp_path, ssp, env={"INCHWORM_MAX_UNPACKED_BYTES": str(cap)})
    assert r.returncode == 1
    assert error_line(r) == (
        f"error: {ssp}: cannot unpack: the archive unpacks to more than {cap} bytes "
        f"(limit {cap} bytes; raise it with INCHWORM_MAX_UNPACKED_BYTES): refused"
    )


def test_an_entry_past_the_entry_cap_is_refused(tmp, tmp_path):
    _, largest = unpacked_sizes(SSP)
    cap = largest + 1_000_000
    ssp = zeros_ssp(tmp_path, cap + 1_000_000)
    r = run_ssp(tmp, tmp_path, ssp, env={"INCHWORM_MAX_ENTRY_BYTES": str(cap)})
    assert r.returncode == 1
    assert error_line(r) == (
        f"error: {ssp}: cannot unpack: the archive entry `resources/zeros.bin` unpacks to more than {cap} bytes "
        f"(limit {cap} bytes; raise it with INCHWORM_MAX_ENTRY_BYTES): refused"
    )


def test_too_many_entries_are_refused(tmp, tmp_path):
    ssp = rezip(SSP, tmp_path / "many.ssp", add={f"resources/e{i}": b"" for i in range(20)})
    with zipfile.ZipFile(ssp) as z:
        entries = len(z.namelist())
    r = run_ssp(tmp, tmp_path, ssp, env={"INCHWORM_MAX_ENTRIES": "25"})
    assert r.returncode == 1
    assert error_line(r) == (
        f"error: {ssp}: cannot unpack: the archive has {entries} entries (limit 25; raise it with INCHWORM_MAX_ENTRIES): refused"
    )


def test_an_fmu_bomb_is_refused(tmp, tmp_path):
    fmu = rezip(PLANT, tmp_path / "bomb.fmu", add={"resources/zeros.bin": b"\0" * 4_000_000})
    r = inchworm(tmp, "run", fmu, "--stop-time", "0.01", "--out", tmp_path / "o.csv",
                 env={"INCHWORM_MAX_UNPACKED_BYTES": "3000000"})
    assert r.returncode == 1
    assert error_line(r) == (
        f"error: {fmu}: cannot import the FMU: the archive unpacks to more than 3000000 bytes "
        "(limit 3000000 bytes; raise it with INCHWORM_MAX_UNPACKED_BYTES): refused"
    )


def test_a_bad_cap_value_is_refused(tmp, tmp_path):
    r = run_ssp(tmp, tmp_path, SSP, env={"INCHWORM_MAX_ENTRIES": "lots"})
    assert r.returncode == 1
    assert error_line(r) == f"error: {SSP}: INCHWORM_MAX_ENTRIES=`lots` is not a positive whole number: refused"


def test_the_caps_let_the_real_system_through(tmp, tmp_path):
    r = run_ssp(tmp, tmp_path, SSP)
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines()[-1].endswith("4 variables, 6 rows")


# 7. Paths stay inside the archive.

def test_a_zip_slip_entry_in_an_ssp_is_refused(tmp, tmp_path):
    ssp = rezip(SSP, tmp_path / "slip.ssp", add={"../../slipped.txt": b"x"})
    r = run_ssp(tmp, tmp_path, ssp)
    assert r.returncode == 1
    assert error_line(r) == (
        f"error: {ssp}: cannot unpack: the archive entry `../../slipped.txt` points outside the archive "
        "(absolute or `..` path): refused"
    )
    assert not (tmp_path / "slipped.txt").exists() and not (tmp / "slipped.txt").exists()


@pytest.mark.parametrize("kind", ["absolute", "climbing", "uri"])
def test_a_source_outside_the_ssp_is_refused(tmp, tmp_path, kind):
    outside = tmp_path / "elsewhere" / "InchwormPlant.fmu"
    outside.parent.mkdir()
    shutil.copy(PLANT, outside)
    source = {"absolute": str(outside), "climbing": "../elsewhere/InchwormPlant.fmu",
              "uri": f"file://{outside}"}[kind]
    why = {"absolute": "is absolute or climbs out of the SSP with `..`",
           "climbing": "is absolute or climbs out of the SSP with `..`", "uri": "is a URI or a drive path"}[kind]
    ssd = ssd_text().replace('source="resources/InchwormPlant.fmu"', f'source="{source}"')
    ssp = ssp_with_ssd(tmp_path, ssd)
    r = run_ssp(tmp, tmp_path, ssp)
    assert r.returncode == 1
    assert error_line(r) == (
        f'error: {ssp}: component plant: source "{source}" {why}: refused '
        "(it must be a relative path inside the SSP, e.g. resources/Model.fmu)"
    )


def test_a_model_identifier_with_a_path_is_refused_before_dlopen(tmp, tmp_path):
    # The climb lands at tmp_path/x/evil.so from <TMPDIR>/<unpacked>/binaries/linux64/;
    # a real FMU binary waits there, so a loader that follows it would run.
    (tmp_path / "x").mkdir()
    with zipfile.ZipFile(PLANT) as z:
        (tmp_path / "x" / "evil.so").write_bytes(z.read("binaries/linux64/InchwormPlant.so"))
    evil = "../../../../x/evil"
    md = fmu_md().replace('modelIdentifier="InchwormPlant"', f'modelIdentifier="{evil}"')
    assert evil in md
    fmu = rezip(PLANT, tmp_path / "evil.fmu", replace={"modelDescription.xml": md.encode()})
    r = inchworm(tmp, "run", fmu, "--stop-time", "0.01", "--out", tmp_path / "o.csv")
    assert r.returncode == 1
    line = error_line(r)
    assert line.startswith(f"error: {fmu}: cannot import the FMU: modelDescription.xml line "), line
    assert line.endswith(
        f'<CoSimulation> modelIdentifier="{evil}" is not a plain file name (no `/`, `\\`, `:` or NUL; not `.` or `..`): refused'
    ), line


# 8. The smaller points.

def with_connection(extra):
    return ssd_text().replace("</ssd:Connections>", f"  {extra}\n    </ssd:Connections>")


def test_an_input_driven_twice_is_refused(tmp, tmp_path):
    ssd = with_connection('<ssd:Connection startElement="controller" startConnector="dac_nonearth" '
                          'endElement="plant" endConnector="dac_earth"/>')
    r = run_ssp(tmp, tmp_path, ssp_with_ssd(tmp_path, ssd))
    assert r.returncode == 1
    assert error_line(r) == (
        "error: input `plant.dac_earth` is driven by two connections, "
        "from `controller.dac_earth` and from `controller.dac_nonearth`"
    )


def test_a_connector_wired_to_itself_is_refused(tmp, tmp_path):
    ssd = with_connection('<ssd:Connection startElement="plant" startConnector="dac_earth" '
                          'endElement="plant" endConnector="dac_earth"/>')
    r = run_ssp(tmp, tmp_path, ssp_with_ssd(tmp_path, ssd))
    assert r.returncode == 1
    assert error_line(r) == "error: connection from `plant.dac_earth` to itself"


def test_two_components_of_one_name_are_refused(tmp, tmp_path):
    ssd = ssd_text().replace('<ssd:Component name="controller"', '<ssd:Component name="plant"')
    ssp = ssp_with_ssd(tmp_path, ssd)
    r = run_ssp(tmp, tmp_path, ssp)
    assert r.returncode == 1
    assert error_line(r) == f"error: {ssp}: two components are named `plant`"


@pytest.mark.parametrize("param,message", [
    ("plant.noise_seed=1e30", "plant.noise_seed = 1e30: out of the Integer range -2147483648..=2147483647"),
    ("plant.noise_seed=-3e9", "plant.noise_seed = -3e9: out of the Integer range -2147483648..=2147483647"),
    ("plant.noise_seed=1.5", "plant.noise_seed = 1.5: not an integer"),
    ("plant.k_p=abc", "plant.k_p = abc: not a number"),
    ("plant.k_p=inf", "plant.k_p = inf: not a finite number"),
    ("plant.k_p=NaN", "plant.k_p = NaN: not a finite number"),
    ("controller.prefilter=maybe", "controller.prefilter = maybe: not a Boolean (true/false)"),
])
def test_bad_parameter_values_are_refused(tmp, tmp_path, param, message):
    r = run_ssp(tmp, tmp_path, SSP, "--param", param)
    assert r.returncode == 1
    assert error_line(r) == f"error: {message}"


@pytest.mark.parametrize("param,log", [
    ("plant.k_p=1e100", "invalid parameter k_p: must be within [1e5, 1e10] N/m, got 1e100"),
    ("plant.C=5e-324", "invalid parameter C: must be within [1e-10, 1e-2] F, got 5e-324"),
    ("plant.m_p=5e-324", "invalid parameter m_p: must be within [1e-4, 1e1] kg, got 5e-324"),
])
def test_plant_parameters_out_of_range_are_refused_at_initialization(tmp, tmp_path, param, log):
    r = run_ssp(tmp, tmp_path, SSP, "--param", param)
    assert r.returncode == 1
    assert f"[ERROR] plant: logStatusError: fmi2ExitInitializationMode: {log}" in r.stderr
    assert error_line(r) == (
        "error: InchwormPlant: fmi2ExitInitializationMode returned fmi2Error at t = 0 s "
        "(the FMU's log messages above say why)"
    )


@pytest.mark.parametrize("args,message", [
    (["--stop-time", "nan"], "error: step size 0.002 and stop time NaN must be finite and > 0"),
    (["--stop-time=-1"], "error: step size 0.002 and stop time -1 must be finite and > 0"),
    (["--step-size", "0"], "error: step size 0 and stop time 10 must be finite and > 0"),
    (["--step-size", "inf"], "error: step size inf and stop time 10 must be finite and > 0"),
])
def test_bad_times_are_refused(tmp, tmp_path, args, message):
    r = inchworm(tmp, "run", SSP, "--input", ref_csv(tmp_path), *args, "--out", tmp_path / "o.csv")
    assert r.returncode == 1
    assert error_line(r) == message


def test_an_input_csv_starting_after_the_start_time_is_refused(tmp, tmp_path):
    csv = ref_csv(tmp_path, "time,reference\n5,100e-6\n", "late.csv")
    r = inchworm(tmp, "run", SSP, "--input", csv, "--stop-time", "0.01", "--out", tmp_path / "o.csv")
    assert r.returncode == 1
    assert error_line(r) == (
        "error: input CSV starts at t = 5, after the start time 0: its first row must be at t = 0 or earlier"
    )


def test_a_byte_order_mark_is_skipped(tmp, tmp_path):
    plain = inchworm(tmp, "run", SSP, "--input", ref_csv(tmp_path), "--stop-time", "0.1", "--out", tmp_path / "a.csv")
    bom = ref_csv(tmp_path, "\ufefftime,reference\n0,100e-6\n", "bom.csv")
    assert bom.read_bytes().startswith(b"\xef\xbb\xbftime")
    r = inchworm(tmp, "run", SSP, "--input", bom, "--stop-time", "0.1", "--out", tmp_path / "b.csv")
    assert (plain.returncode, r.returncode) == (0, 0), r.stderr
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()


def test_a_byte_order_mark_in_the_ssd_is_skipped(tmp, tmp_path):
    ssp = rezip(SSP, tmp_path / "bom.ssp", replace={"SystemStructure.ssd": b"\xef\xbb\xbf" + ssd_text().encode()})
    r = run_ssp(tmp, tmp_path, ssp)
    assert r.returncode == 0, r.stderr


def test_a_huge_line_is_cut_in_the_message(tmp, tmp_path):
    csv = tmp_path / "huge.csv"
    with open(csv, "w") as f:
        f.write("time,reference\n0,")
        f.write("9" * 100_000_000)
        f.write("x\n")
    r = inchworm(tmp, "run", SSP, "--input", csv, "--stop-time", "0.01", "--out", tmp_path / "o.csv")
    assert r.returncode == 1
    assert len(r.stderr) < 1000
    assert error_line(r) == f"error: {csv}: input CSV line 2: not all numbers: `0,{'9' * 198}…`"


def test_a_huge_header_is_cut_in_the_message(tmp, tmp_path):
    csv = ref_csv(tmp_path, "x" * 1_000_000 + "\n0,1\n", "header.csv")
    r = inchworm(tmp, "run", SSP, "--input", csv, "--stop-time", "0.01", "--out", tmp_path / "o.csv")
    assert r.returncode == 1
    assert error_line(r) == f"error: {csv}: input CSV header must be `time,<name>,…`, got `{'x' * 200}…`"


def test_a_parse_failure_leaves_no_folder(tmp, tmp_path):
    # The `tmp` fixture checks the folder is empty afterwards; the old master left
    # /tmp/inchworm-ssp-<pid>-<n>-<stem> behind on any error after unpacking.
    r = run_ssp(tmp, tmp_path, SSP, "--output", "plant.no_such_variable")
    assert r.returncode == 1
    assert "no_such_variable" in error_line(r)


def test_an_integer_input_out_of_range_is_refused_not_saturated(tmp, tmp_path):
    csv = ref_csv(tmp_path, "time,encoder_counts\n0,0\n0.004,3e9\n", "int.csv")
    out = tmp_path / "o.csv"
    r = inchworm(tmp, "run", DIST / "InchwormController.fmu", "--input", csv, "--stop-time", "0.01", "--out", out)
    assert r.returncode == 1
    assert error_line(r) == (
        "error: input CSV column `encoder_counts` = 3000000000 at t = 0.004: out of the Integer range "
        f"-2147483648..=2147483647 ({out} holds the rows to t = 0.004 s)"
    )


def test_an_input_csv_past_its_cap_is_refused(tmp, tmp_path):
    csv = ref_csv(tmp_path, "time,reference\n" + "0,1e-4\n" * 1000, "big.csv")
    r = inchworm(tmp, "run", SSP, "--input", csv, "--stop-time", "0.01", "--out", tmp_path / "o.csv",
                 env={"INCHWORM_MAX_INPUT_BYTES": "1000"})
    assert r.returncode == 1
    assert error_line(r) == (
        f"error: {csv}: the input CSV is larger than 1000 bytes "
        "(raise the limit with INCHWORM_MAX_INPUT_BYTES): refused"
    )
