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
    """The folder the binary unpacks into (its TMPDIR; the FMU cache is off in these runs, so
    the FMUs are unpacked there too); checked empty after the case."""
    t = tmp_path / "tmpdir"
    t.mkdir()
    yield t
    assert sorted(p.name for p in t.iterdir()) == [], "an unpacked folder was left behind"


def inchworm(tmp, *args, env=None, timeout=60):
    e = dict(os.environ, TMPDIR=str(tmp), INCHWORM_FMU_CACHE="off")
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
    # The controller samples at every 2 ms instant its steps reach (docs/model.md §5), so a
    # 1 ns master step is a legal, long run: 1000 steps stream to the CSV row by row, with
    # nothing sized by the step count up front.
    out = tmp_path / "o.csv"
    r = inchworm(tmp, "run", SSP, "--input", ref_csv(tmp_path), "--step-size", "1e-9", "--stop-time", "1e-6", "--out", out)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "memory allocation" not in r.stderr
    rows = out.read_text().splitlines()
    assert len(rows) == 1 + 1001, len(rows)


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
    e = dict(os.environ, TMPDIR=str(tmp), INCHWORM_FMU_CACHE="off")
    p = subprocess.Popen([str(BIN), "run", SSP, "--input", ref_csv(tmp_path), "--stop-time", "1e9", "--out", out],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=e)
    try:
        # The rows stream into a uniquely named temporary beside --out, renamed over it at
        # the end (here: at the signal).
        def partial():
            found = list(tmp_path.glob(".long.*.partial.csv"))
            return found[0] if found else None
        deadline = time.time() + 60
        while time.time() < deadline and (partial() is None or partial().stat().st_size < 20_000_000):
            assert p.poll() is None, p.communicate()
            time.sleep(0.2)
        assert partial().stat().st_size >= 20_000_000, "rows are written as they are computed"
        assert not out.exists(), "--out appears only complete"
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
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == [], "no temporary left"


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
    # The plant FMU's <ModelExchange> (line 4) comes before its <CoSimulation>, and the
    # importer reads both: the first hostile identifier is the one refused.
    assert line.endswith(
        f'<ModelExchange> modelIdentifier="{evil}" is not a plain file name (no `/`, `\\`, `:` or NUL; not `.` or `..`): refused'
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


# 9. FMI 3.0 parity: every check of an FMI 2.0 import holds for an FMI 3.0 FMU, alone or
# inside an SSP, and its errors name the fmi3* call.

PLANT3 = DIST / "fmi3" / "InchwormPlant.fmu"
SSP3 = DIST / "fmi3" / "InchwormSystemOpen.ssp"
LIB3 = "binaries/x86_64-linux/InchwormPlant.so"


def fmu3_with_md(tmp_path, edit, name="hostile3.fmu", **kw):
    """The FMI 3.0 plant with its modelDescription.xml passed through `edit`."""
    md = fmu_md(PLANT3)
    new = edit(md)
    assert new != md, "the edit changed nothing"
    return rezip(PLANT3, tmp_path / name, replace={"modelDescription.xml": new.encode()}, **kw)


def ssp3_holding(tmp_path, fmu):
    """The FMI 3.0 system with `fmu` as its plant."""
    return rezip(SSP3, tmp_path / "hostile3.ssp", replace={"resources/InchwormPlant.fmu": fmu.read_bytes()})


def run_fmu3(tmp, tmp_path, fmu, **kw):
    return inchworm(tmp, "run", fmu, "--stop-time", "0.01", "--out", tmp_path / "o.csv", **kw)


def evil_library(tmp_path):
    """A working FMI 3.0 library outside any archive, where a climbing modelIdentifier lands
    (from <TMPDIR>/<unpacked>/binaries/x86_64-linux/)."""
    (tmp_path / "x").mkdir(exist_ok=True)
    with zipfile.ZipFile(PLANT3) as z:
        (tmp_path / "x" / "evil.so").write_bytes(z.read(LIB3))
    return tmp_path / "x" / "evil"


NOT_PLAIN = 'is not a plain file name (no `/`, `\\`, `:` or NUL; not `.` or `..`): refused'


@pytest.mark.parametrize("kind", ["climbing", "absolute"])
def test_an_fmi3_model_identifier_with_a_path_is_refused_before_dlopen(tmp, tmp_path, kind):
    evil = {"climbing": "../../../../x/evil", "absolute": str(evil_library(tmp_path))}[kind]
    evil_library(tmp_path)
    fmu = fmu3_with_md(tmp_path, lambda m: m.replace('modelIdentifier="InchwormPlant"', f'modelIdentifier="{evil}"'))
    r = run_fmu3(tmp, tmp_path, fmu)
    assert r.returncode == 1, r.stderr[-2000:]
    line = error_line(r)
    # Line 4: <ModelExchange>, before <CoSimulation>; the importer reads both interfaces'
    # identifiers (the master may integrate either), so the first is the one refused.
    assert line.startswith(f"error: {fmu}: cannot import the FMU: modelDescription.xml line 4, column 3: "), line
    assert line.endswith(f'<ModelExchange> modelIdentifier="{evil}" {NOT_PLAIN}'), line


def test_an_ssp_holding_an_fmi3_fmu_with_a_climbing_model_identifier_is_refused(tmp, tmp_path):
    evil_library(tmp_path)
    fmu = fmu3_with_md(tmp_path, lambda m: m.replace('modelIdentifier="InchwormPlant"', 'modelIdentifier="../../../../../x/evil"'))
    ssp = ssp3_holding(tmp_path, fmu)
    r = run_ssp(tmp, tmp_path, ssp)
    assert r.returncode == 1, r.stderr[-2000:]
    line = error_line(r)
    assert line.startswith("error: component plant: ") and "cannot import the FMU: modelDescription.xml line 4" in line, line
    assert line.endswith(f'<ModelExchange> modelIdentifier="../../../../../x/evil" {NOT_PLAIN}'), line


def test_a_truncated_fmi3_model_description_is_refused_with_line_and_expected_tag(tmp, tmp_path):
    md = fmu_md(PLANT3)
    cut = md[: md.index("</ModelVariables>")]
    fmu = fmu3_with_md(tmp_path, lambda m: cut)
    r = run_fmu3(tmp, tmp_path, fmu)
    assert r.returncode == 1, r.stderr[-2000:]
    line = error_line(r)
    assert f"modelDescription.xml line {line_of_end(cut)}, column " in line, line
    assert line.endswith(
        "the file ends inside <fmiModelDescription> <ModelVariables>: expected </ModelVariables> (a truncated file?)"
    ), line


def test_an_ssp_holding_a_truncated_fmi3_fmu_is_refused(tmp, tmp_path):
    md = fmu_md(PLANT3)
    fmu = fmu3_with_md(tmp_path, lambda m: m[: m.index("<ModelStructure>")])
    r = run_ssp(tmp, tmp_path, ssp3_holding(tmp_path, fmu))
    assert r.returncode == 1, r.stderr[-2000:]
    assert error_line(r).endswith("expected </fmiModelDescription> (a truncated file?)"), error_line(r)


def test_an_fmi3_name_taken_by_a_variable_of_another_type_is_refused(tmp, tmp_path):
    # A Float32 the master cannot address still shares the one namespace.
    extra = '<Float32 name="dac_earth" valueReference="900" causality="local"/>\n  </ModelVariables>'
    fmu = fmu3_with_md(tmp_path, lambda m: m.replace("</ModelVariables>", extra))
    r = run_fmu3(tmp, tmp_path, fmu)
    assert r.returncode == 1, r.stderr[-2000:]
    assert error_line(r).endswith("a second variable named `dac_earth`"), error_line(r)


@pytest.mark.parametrize("edit,message", [
    (lambda m: m.replace('name="dac_earth" valueReference="1"', 'name="dac_earth" valueReference="one"', 1),
     '<Float64 name="dac_earth"> valueReference="one" is not an unsigned 32-bit integer'),
    (lambda m: m.replace('unit="V" min="0" max="10" start="0"/>', 'unit="V" min="0" max="10" start="zero"/>', 1),
     '<Float64 name="dac_earth"> start="zero" is not a valid Float64'),
    (lambda m: m.replace("</ModelVariables>", '<UInt8 name="u8" valueReference="901" causality="local" start="256"/>\n  </ModelVariables>'),
     '<UInt8 name="u8"> start="256" is not a valid UInt8'),
    (lambda m: m.replace("</ModelVariables>", '<Int64 name="big" causality="local"/>\n  </ModelVariables>'),
     '<Int64 name="big"> lacks the required attribute valueReference'),
    (lambda m: m.replace("</ModelVariables>", '<Binary valueReference="902" causality="local"/>\n  </ModelVariables>'),
     "<Binary> lacks the required attribute name"),
    (lambda m: m.replace("</ModelVariables>", '<Clock name="tick" valueReference="903" causality="whenever"/>\n  </ModelVariables>'),
     '<Clock name="tick"> causality="whenever" is not one of'),
], ids=["valueReference", "start", "uint8-start", "no-valueReference", "no-name", "causality"])
def test_bad_numbers_and_missing_attributes_of_fmi3_variables_are_refused(tmp, tmp_path, edit, message):
    fmu = fmu3_with_md(tmp_path, edit)
    r = run_fmu3(tmp, tmp_path, fmu)
    assert r.returncode == 1, r.stderr[-2000:]
    line = error_line(r)
    assert line.startswith(f"error: {fmu}: cannot import the FMU: modelDescription.xml line "), line
    assert message in line, line


def test_an_oversize_fmi3_model_description_is_refused(tmp, tmp_path):
    r = run_fmu3(tmp, tmp_path, PLANT3, env={"INCHWORM_MAX_DESCRIPTION_BYTES": "4096"})
    assert r.returncode == 1, r.stderr[-2000:]
    size = len(fmu_md(PLANT3).encode())
    assert error_line(r) == (
        f"error: {PLANT3}: cannot import the FMU: modelDescription.xml has {size} bytes "
        "(limit 4096 bytes; raise it with INCHWORM_MAX_DESCRIPTION_BYTES): refused"
    )


def test_an_ssp_holding_an_oversize_fmi3_model_description_is_refused(tmp, tmp_path):
    # Past the default cap of 64 MiB: a comment that zips to almost nothing.
    fmu = fmu3_with_md(tmp_path, lambda m: m.replace("<ModelVariables>", "<!--" + " " * (65 << 20) + "--><ModelVariables>"))
    r = run_ssp(tmp, tmp_path, ssp3_holding(tmp_path, fmu), timeout=120)
    assert r.returncode == 1, r.stderr[-2000:]
    line = error_line(r)
    assert line.startswith("error: component plant: ") and "cannot import the FMU: modelDescription.xml has " in line, line
    assert line.endswith("(limit 67108864 bytes; raise it with INCHWORM_MAX_DESCRIPTION_BYTES): refused"), line


def test_an_fmi3_library_lacking_a_declared_state_function_is_refused(tmp, tmp_path):
    # The dynamic symbol renamed in place (same length): dlsym no longer finds it.
    with zipfile.ZipFile(PLANT3) as z:
        lib = z.read(LIB3)
    assert lib.count(b"fmi3GetFMUState\0") >= 1  # .dynstr, and .strtab if not stripped
    lib = lib.replace(b"fmi3GetFMUState\0", b"fmi3GetFMUStatX\0")
    fmu = rezip(PLANT3, tmp_path / "nostate.fmu", replace={LIB3: lib})
    r = run_fmu3(tmp, tmp_path, fmu)
    assert r.returncode == 1, r.stderr[-2000:]
    assert error_line(r) == (
        f'error: {fmu}: cannot import the FMU: modelDescription.xml declares canGetAndSetFMUState="true" '
        f"but the FMU's binary {LIB3} does not export fmi3GetFMUState"
    )


def test_an_fmi3_instantiation_refused_names_fmi3_instantiate(tmp, tmp_path):
    fmu = fmu3_with_md(tmp_path, lambda m: m.replace('instantiationToken="{', 'instantiationToken="{0', 1))
    r = run_fmu3(tmp, tmp_path, fmu)
    assert r.returncode == 1, r.stderr[-2000:]
    assert error_line(r) == (
        f"error: {fmu}: cannot import the FMU: fmi3InstantiateCoSimulation returned NULL for instance `fmu` "
        "(the FMU's log messages above say why)"
    )


def test_an_fmi3_parameter_refused_at_initialization_names_the_fmi3_call(tmp, tmp_path):
    r = run_ssp(tmp, tmp_path, SSP3, "--param", "plant.k_p=1e100")
    assert r.returncode == 1, r.stderr[-2000:]
    assert error_line(r) == (
        "error: InchwormPlant: fmi3ExitInitializationMode returned fmi3Error at t = 0 s "
        "(the FMU's log messages above say why)"
    )


# ---------------------------------------------------------------------------------------
# Sweeps, whole-system caps and types (docs/ssp.md, "Sweeps: caps and rules"). Each case
# failed on the binary before these rules (INCHWORM_BIN=<that build> shows it).

MIRROR = DIST / "MirrorMount.ssp"
CLOSED = DIST / "InchwormSystem.ssp"  # the system with bindings and a reference component


def sweep(tmp, tmp_path, *args, system=SSP, **kw):
    extra = ["--input", ref_csv(tmp_path)] if system == SSP else []
    return inchworm(tmp, "sweep", system, *extra, *args, **kw)


def refused(r, message):
    """Exit status 1 and `message` as the one error line."""
    assert r.returncode == 1, (r.returncode, r.stderr[-2000:])
    assert error_line(r) == message


def plan_file(tmp_path, text, name="plan.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_sweep_rows_on_the_mirror_mount_equal_inchworm_run(tmp, tmp_path):
    # A reset must restore what a fresh load applies: the SSD's first bindings (the
    # references' targets) were lost, so rows after the first differed from `run`.
    outs = ["reference_b.reference", "plant_b.encoder_position", "plant_c.runner_position"]
    run = inchworm(tmp, "run", MIRROR, "--stop-time", "0.2", "--param", "plant_b.T_em=8.8",
                   "--out", tmp_path / "run.csv", *[a for o in outs for a in ("--output", o)])
    assert run.returncode == 0, run.stderr[-2000:]
    last = (tmp_path / "run.csv").read_text().splitlines()[-1].split(",")
    expected = {o: float(v) for o, v in zip(outs, last[1:])}
    plan = plan_file(tmp_path, "run,sample,plant_b.T_em\n0,0,8.8\n1,0,8.8\n2,0,8.8\n")
    r = inchworm(tmp, "sweep", MIRROR, "--plan", plan, "--json", "--jobs", "1", "--stop-time", "0.2",
                 *[a for o in outs for a in ("--metric", f"final:{o}")])
    assert r.returncode == 0, r.stderr[-2000:]
    import json
    rows = [json.loads(l) for l in r.stdout.splitlines()]
    assert [row["run"] for row in rows] == [0, 1, 2]
    for row in rows:
        assert row["status"] == "ok", row
        assert {o: row["metrics"][f"final:{o}"] for o in outs} == expected, row["run"]


# 65536^4 = 2^64: unchecked, the count wrapped to 0 and the sweep "succeeded" with no runs.
OVERFLOWING = [a for n in ("plant.T_em", "plant.k_p", "plant.F_d0", "plant.T_ex") for a in ("--grid", f"{n}=1:2:65536")]


@pytest.mark.parametrize("args, message", [
    # Allocated unchecked: the process aborted (SIGABRT).
    (["--grid", "plant.T_em=1:2:10000000000000", "--plan-only"],
     "--grid plant.T_em=1:2:10000000000000: 10000000000000 points = 10000000000000 runs: "
     "more than the 1000000 a sweep may have"),
    (["--sample", "plant.T_em=normal(8.8,0.1)", "--samples", "1000000000000000", "--plan-only"],
     "1000000000000000 samples = 1000000000000000 runs: more than the 1000000 a sweep may have"),
    (OVERFLOWING + ["--plan-only"],
     "65536 × 65536 × 65536 × 65536 runs overflows a 64-bit count: more than the 1000000 a sweep may have"),
    # A comma in the name writes a header with one column more than each row has.
    (["--grid", "plant.T_em,x=1:2:2", "--plan-only"],
     "--grid plant.T_em,x=1:2:2: the parameter name `plant.T_em,x` holds a comma: refused (it names a CSV column)"),
    (["--grid", "plant.T_em=8.8;9", "--metric", "slips", "--metric", "slips", "--plan-only"],
     "--metric slips is given twice (it names one column of the results)"),
    (["--grid", "plant.T_em=8.8;9", "--jobs", "1000000", "--stop-time", "0.01", "--no-plots"],
     "--jobs 1000000: more than the 256 worker threads a sweep runs"),
    # Allocated after every run, unchecked: the sweep aborted once its runs were done.
    (["--grid", "plant.T_em=8.8;9", "--stop-time", "0.01", "--bins", "1000000000000"],
     "--bins 1000000000000: more than the 1000 bins a histogram draws"),
], ids=["grid-points", "samples", "grid-overflow", "grid-comma", "metric-twice", "jobs", "bins"])
def test_sweep_sizes_and_names_past_their_rules_are_refused(tmp, tmp_path, args, message):
    r = sweep(tmp, tmp_path, *args, "--out", tmp_path / "o")
    refused(r, f"error: {message}")
    assert not (tmp_path / "o" / "plan.csv").exists()


def test_a_plan_with_a_run_index_twice_is_refused(tmp, tmp_path):
    plan = plan_file(tmp_path, "run,sample,plant.T_em\n0,0,8.8\n1,1,8.9\n0,2,9.0\n")
    r = sweep(tmp, tmp_path, "--plan", plan, "--plan-only", "--out", tmp_path / "o")
    refused(r, f"error: {plan}: plan line 4: the run index 0 is given twice")


def test_a_plan_with_a_parameter_column_twice_is_refused(tmp, tmp_path):
    plan = plan_file(tmp_path, "run,sample,plant.T_em,plant.T_em\n0,0,8.8,9.0\n")
    r = sweep(tmp, tmp_path, "--plan", plan, "--plan-only", "--out", tmp_path / "o")
    refused(r, f"error: {plan}: plan header: the parameter `plant.T_em` is a column twice")


def test_a_plan_column_with_control_characters_is_refused(tmp, tmp_path):
    plan = plan_file(tmp_path, "run,sample,plant.T_em\x1b[2J\n0,0,8.8\n")
    r = sweep(tmp, tmp_path, "--plan", plan, "--plan-only", "--out", tmp_path / "o")
    assert r.returncode == 1
    line = error_line(r)
    assert "\x1b" not in r.stderr, "the control character reached the terminal"
    assert line == (
        f"error: {plan}: plan header: the parameter name `plant.T_em\\u{{1b}}[2J` holds the control "
        "character U+001B: refused (it names a CSV column)"
    )


def test_a_metric_name_with_control_characters_is_refused(tmp, tmp_path):
    r = sweep(tmp, tmp_path, "--grid", "plant.T_em=8.8;9", "--metric", "final:plant.mode\x07",
              "--plan-only", "--out", tmp_path / "o")
    assert "\x07" not in r.stderr
    refused(r, (
        "error: --metric final:plant.mode\\u{7}: the control character U+0007 is refused (it names a CSV column)"
    ))


def test_an_output_path_that_cannot_be_written_is_refused_before_the_first_run(tmp, tmp_path):
    out = tmp_path / "o"
    (out / "results.csv").mkdir(parents=True)
    r = sweep(tmp, tmp_path, "--grid", "plant.T_em=8.8;9", "--stop-time", "0.01", "--no-plots", "--out", out)
    refused(r, f"error: {out / 'results.csv'}: is a folder, cannot write the file there")
    assert "runs in" not in r.stdout and not (out / "plan.csv").exists(), "the runs were made first"


def test_plots_past_their_cap_are_refused_before_the_first_run(tmp, tmp_path):
    names = [f"plant.p{i}" for i in range(70)]
    plan = plan_file(tmp_path, "run,sample," + ",".join(names) + "\n0,0," + ",".join(["1"] * 70) + "\n")
    out = tmp_path / "o"
    r = sweep(tmp, tmp_path, "--plan", plan, "--stop-time", "0.01", "--out", out, timeout=300)
    refused(r, (
        "error: 4 metrics × (1 histogram + 70 parameters) = 284 plots: more than the 64 a sweep draws; "
        "give --no-plots, or fewer metrics or parameters"
    ))
    assert not out.exists() or not list(out.glob("*.png"))


def test_a_plan_line_past_its_cap_is_refused_and_not_echoed(tmp, tmp_path):
    plan = plan_file(tmp_path, "run,sample," + "x" * (20 << 20) + "\n0,0,1\n")
    r = sweep(tmp, tmp_path, "--plan", plan, "--row", "0")
    refused(r, f"error: {plan}: plan line 1: longer than 65536 bytes")
    assert len(r.stderr) < 1000


def test_a_row_asked_for_that_the_plan_gives_twice_is_refused(tmp, tmp_path):
    plan = plan_file(tmp_path, "run,sample,plant.T_em\n3,0,8.8\n4,1,8.9\n3,2,9.0\n")
    r = sweep(tmp, tmp_path, "--plan", plan, "--row", "3", "--stop-time", "0.01")
    refused(r, f"error: {plan}: plan line 4: the run index 3 is given twice")
    assert r.stdout == ""


def test_a_long_sweep_run_streams_and_stops_on_sigterm_keeping_its_rows(tmp, tmp_path):
    # 5e9 steps: the whole trace was reserved up front and the allocation aborted (SIGABRT).
    out = tmp_path / "o"
    e = dict(os.environ, TMPDIR=str(tmp), INCHWORM_FMU_CACHE="off")
    p = subprocess.Popen([str(BIN), "sweep", SSP, "--input", ref_csv(tmp_path), "--grid", "plant.T_em=8.8;9",
                          "--stop-time", "1e7", "--jobs", "1", "--no-plots", "--out", out],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=e)
    try:
        time.sleep(3)
        assert p.poll() is None, f"stopped with {p.returncode}: {p.stderr.read()[-2000:]}"
        rss_kb = int(next(l for l in open(f"/proc/{p.pid}/status") if l.startswith("VmRSS")).split()[1])
        assert rss_kb < 200_000, f"{rss_kb} kB resident: the run is not streamed"
        p.send_signal(signal.SIGTERM)
        _, err = p.communicate(timeout=30)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert p.returncode == 128 + signal.SIGTERM, err[-2000:]
    assert err.strip().splitlines()[-1] == f"error: interrupted by SIGTERM ({out / 'results.csv'} holds the runs done)"
    rows = (out / "results.csv").read_text().splitlines()
    assert len(rows) == 3 and rows[1].endswith('failed,"interrupted by SIGTERM"'), rows


def test_one_fmu_referenced_many_times_is_unpacked_once_within_one_budget(tmp, tmp_path):
    # Each archive alone fits the cap, so each was let through: 12 references unpacked 12
    # times. Now the FMU is unpacked once and instantiated 12 times from that folder, so a
    # budget with room for one copy (and not two) runs the system, and one for the SSP
    # alone refuses it before anything is unpacked.
    with zipfile.ZipFile(PLANT) as z:
        # What a run unpacks of it: the description, the resources and this host's library
        # (dist/ may hold other platforms' too).
        fmu_bytes = sum(i.file_size for i in z.infolist()
                        if i.filename == "modelDescription.xml" or i.filename.startswith("resources/")
                        or i.filename.startswith("binaries/linux64/"))
    with zipfile.ZipFile(SSP) as z:
        ssp_bytes = sum(i.file_size for i in z.infolist())
    comps = "".join(f'<ssd:Component name="p{i}" source="resources/InchwormPlant.fmu"/>' for i in range(12))
    ssd = ('<ssd:SystemStructureDescription xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" '
           f'version="1.0" name="S"><ssd:System name="S"><ssd:Elements>{comps}</ssd:Elements></ssd:System>'
           '</ssd:SystemStructureDescription>')
    ssp = ssp_with_ssd(tmp_path, ssd, "many.ssp")
    cap = ssp_bytes + fmu_bytes + fmu_bytes // 2
    r = inchworm(tmp, "run", ssp, "--stop-time", "0.01", "--step-size", "0.002", "--output", "p0.mode",
                 "--output", "p11.mode", "--out", tmp_path / "o.csv", env={"INCHWORM_MAX_UNPACKED_BYTES": str(cap)})
    assert r.returncode == 0, r.stderr[-2000:]
    rows = (tmp_path / "o.csv").read_text().splitlines()
    assert len(rows) == 1 + 6 and rows[0].endswith("p0.mode,p11.mode"), rows

    cap = ssp_bytes + fmu_bytes // 2
    r = inchworm(tmp, "run", ssp, "--stop-time", "0.01", "--step-size", "0.002", "--output", "p0.mode",
                 "--out", tmp_path / "o2.csv", env={"INCHWORM_MAX_UNPACKED_BYTES": str(cap)})
    assert r.returncode == 1, r.stderr[-2000:]
    line = error_line(r)
    assert line.startswith(f"error: {ssp}: the system unpacks to more than {cap} bytes in all (the SSP "), line
    assert line.endswith("component p0 (InchwormPlant.fmu) passes it): refused "
                         "(raise the cap with INCHWORM_MAX_UNPACKED_BYTES)"), line
    assert not (tmp_path / "o2.csv").exists()


def test_a_connection_between_connectors_of_different_types_is_refused(tmp, tmp_path):
    ssd = ssd_text()
    old = 'startElement="plant" startConnector="encoder_counts" endElement="controller"'
    assert old in ssd
    ssd = ssd.replace(old, 'startElement="plant" startConnector="encoder_position" endElement="controller"')
    r = run_ssp(tmp, tmp_path, ssp_with_ssd(tmp_path, ssd))
    refused(r, (
        "error: connection from `plant.encoder_position` (Real) to `controller.encoder_counts` (Integer): "
        "the connectors are of different types: refused"
    ))


@pytest.mark.parametrize("old, new, message", [
    # The system's input declared Integer, feeding a Real input.
    ('<ssd:Connector name="reference" kind="input"><ssc:Real unit="m"/>',
     '<ssd:Connector name="reference" kind="input"><ssc:Integer/>',
     "connector `reference` is declared ssc:Integer in the SSD, but `controller.reference` is of type Real"),
    # A component connector declared other than its FMU variable.
    ('<ssd:Connector name="encoder_counts" kind="output"><ssc:Integer/>',
     '<ssd:Connector name="encoder_counts" kind="output"><ssc:Real/>',
     "connector `plant.encoder_counts` is declared ssc:Real in the SSD, but `plant.encoder_counts` is of type "
     "Integer"),
], ids=["system-connector", "component-connector"])
def test_a_connector_declared_another_type_than_it_carries_is_refused(tmp, tmp_path, old, new, message):
    ssd = ssd_text()
    assert old in ssd
    r = run_ssp(tmp, tmp_path, ssp_with_ssd(tmp_path, ssd.replace(old, new, 1)))
    refused(r, f"error: {message}: refused")


@pytest.mark.parametrize("entry, name, old, new, given, declared", [
    ("resources/reference.default.ssv", "reference.n_points",
     '<ssv:Integer value="1"/>', '<ssv:Real value="1"/>', "Real", "Integer"),
    ("resources/controller.default.ssv", "controller.prefilter",
     '<ssv:Boolean value="false"/>', '<ssv:Integer value="0"/>', "Integer", "Boolean"),
], ids=["real-for-integer", "integer-for-boolean"])
def test_a_binding_of_another_type_than_its_variable_is_refused(tmp, tmp_path, entry, name, old, new, given,
                                                                 declared):
    with zipfile.ZipFile(CLOSED) as z:
        text = z.read(entry).decode()
    here = f'"{name.split(".", 1)[1]}">'
    assert here + old in text, text
    ssp = rezip(CLOSED, tmp_path / "bound.ssp", replace={entry: text.replace(here + old, here + new).encode()})
    r = inchworm(tmp, "run", ssp, "--stop-time", "0.01", "--out", tmp_path / "o.csv")
    refused(r, (
        f"error: parameter `{name}`: the parameter set gives it an ssv:{given} value, but the variable "
        f"is of type {declared}: refused (SSP 1.0: a value has its variable's type)"
    ))
