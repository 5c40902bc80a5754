"""python/inchworm_dask on inputs out of their ranges: the command's options, the plan (the
binary's own plan rules, checked before a cluster is started or reached), the functions'
arguments, and what the binary prints back. The command's refusal is one line on stderr and
exit status 2 (an unreadable file or a failing binary, exit status 1), never a traceback;
the functions' an `InputError` (a ValueError) for an input, a `BinaryError` (a
RuntimeError) for the binary's output. A stub `distributed` proves no cluster is asked for."""
import re
import sys
import types

import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT / "python" / "inchworm_dask"))
import inchworm_dask  # noqa: E402
from inchworm_dask import __main__ as cli  # noqa: E402
from inchworm_dask import inputs as D  # noqa: E402
from inchworm_dask import system  # noqa: E402


@pytest.fixture
def no_cluster(monkeypatch):
    """A `distributed` whose every entry point fails the test: the refusals come first."""
    def never(*a, **k):
        raise AssertionError("a cluster was asked for before the inputs were checked")

    stub = types.ModuleType("distributed")
    stub.Client = stub.LocalCluster = stub.get_client = never
    monkeypatch.setitem(sys.modules, "distributed", stub)


def refused(capsys, argv, *words, status=2):
    assert cli.main(argv) == status
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") == 1 and err.startswith("inchworm-dask: error: "), err
    for w in words:
        assert w in err, f"{w!r} not in {err!r}"


@pytest.fixture
def plan(tmp_path):
    p = tmp_path / "plan.csv"
    p.write_text("run,sample,plant.T_em\n0,0,8.8\n1,1,9.1\n")
    return p


@pytest.mark.parametrize("args,words", [
    (["--parts", "0"], ["--parts 0: accepted an integer, 1 ≤ value ≤ 256 parts"]),
    (["--parts", "257"], ["--parts 257", "1 ≤ value ≤ 256 parts"]),
    (["--parts", "1.5"], ["argument --parts: invalid int value: '1.5'"]),
    (["--parts", "nan"], ["argument --parts: invalid int value: 'nan'"]),
    (["--parts", "2", "--rows-per-task", "0"], ["--rows-per-task 0: accepted an integer, 1 ≤ value ≤ 1000000 rows"]),
    (["--plan", "PLAN", "--rows-per-task", "-3"], ["--rows-per-task -3"]),
    (["--plan", "PLAN", "--rows-per-task", "1000001"], ["--rows-per-task 1000001"]),
    (["--plan", "PLAN", "--parts", "2"], ["not allowed with argument"]),
    ([], ["one of the arguments --plan --parts is required"]),
])
def test_an_option_out_of_its_range_is_refused_in_one_line(capsys, no_cluster, plan, tmp_path, args, words):
    args = [str(plan) if a == "PLAN" else a for a in args]
    refused(capsys, ["--system", "x.ssp", "--out", str(tmp_path / "r.csv"), *args], *words)


def test_a_bad_plan_is_refused_before_the_cluster(capsys, no_cluster, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("run,sample,plant.T_em\n0,0,nan\n")
    refused(capsys, ["--system", "x.ssp", "--plan", str(bad)], str(bad), "line 2: plant.T_em nan: accepted a finite number")
    refused(capsys, ["--system", "x.ssp", "--plan", str(tmp_path / "none.csv")], "No such file", status=1)


def test_an_output_that_is_a_folder_is_refused_before_the_cluster(capsys, no_cluster, plan, tmp_path):
    refused(capsys, ["--system", "x.ssp", "--plan", str(plan), "--out", str(tmp_path)], "--out", "is a folder")
    refused(capsys, ["--system", "x.ssp", "--parts", "2", "--out", str(tmp_path)], "--out", "is a folder")


def test_the_functions_check_their_arguments_before_the_cluster(no_cluster, plan, tmp_path):
    with pytest.raises(D.InputError, match=re.escape("rows_per_task 0: accepted an integer, 1 ≤ value ≤ 1000000")):
        inchworm_dask.run_plan(plan, "x.ssp", rows_per_task=0)
    with pytest.raises(D.InputError, match="rows_per_task 2.5"):
        inchworm_dask.run_plan(plan, "x.ssp", rows_per_task=2.5)
    with pytest.raises(D.InputError, match="args: accepted a sequence of strings"):
        inchworm_dask.run_plan(plan, "x.ssp", args=["--stop-time", 1])
    with pytest.raises(D.InputError, match="parts 0: accepted an integer"):
        system.run_system("x.ssp", 0)
    with pytest.raises(D.InputError, match="parts True"):
        system.run_system("x.ssp", True)


@pytest.mark.parametrize("part,parts,words", [
    (0, 2, "part 0: accepted an integer, 1 ≤ value ≤ 2"),
    (3, 2, "part 3: accepted an integer, 1 ≤ value ≤ 2"),
    (1.5, 2, "part 1.5: accepted an integer"),
    (1, 0, "parts 0"),
    (1, 2.0 + 0.5, "parts 2.5"),
])
def test_a_part_out_of_its_range_is_refused_before_running(part, parts, words):
    with pytest.raises(D.InputError, match=re.escape(words)):
        system.run_part("/nonexistent/inchworm", "x.ssp", part, parts)


def test_plan_rows_are_checked_before_the_binary_runs():
    with pytest.raises(D.InputError, match="plan rows: line 2: plant.T_em inf"):
        inchworm_dask.run_rows("/nonexistent/inchworm", "x.ssp", "run,sample,plant.T_em", ["0,0,inf"])
    with pytest.raises(D.InputError, match="plan rows: accepted a sequence of strings"):
        inchworm_dask.run_rows("/nonexistent/inchworm", "x.ssp", "run,sample,plant.T_em", [[0, 0, 1.0]])


@pytest.mark.parametrize("split,texts,words", [
    ([("1", "a.x")], ["time,a.x\n0,1\n"], "split entry ('1', 'a.x'): accepted (part, column name)"),
    ([(True, "a.x")], ["time,a.x\n0,1\n"], "split entry (True, 'a.x')"),
    ([(1,)], ["time,a.x\n0,1\n"], "split entry (1,)"),
    ([(1, "a.x")], [b"time,a.x\n0,1\n"], "part 1: accepted its CSV as text, not bytes"),
    ([(1, "a.x")], [], "0 parts: accepted 1 to 256"),
    ([(1, "a.x")], ["time,a.x,a.x\n0,1,1\n"], "part 1: a column name is in its header twice"),
])
def test_parts_that_are_not_a_split_run_are_refused(split, texts, words):
    with pytest.raises(D.InputError, match=re.escape(words)):
        system.join_parts(split, texts)


NAME_256 = "p" * 257


@pytest.mark.parametrize("text,words", [
    (b"", "the plan is empty"),
    (b"\n \t\r\n", "the plan is empty"),
    (b"sample,run,a\n", "not a sweep plan: header `sample,run,a`"),
    (b"run\n", "not a sweep plan"),
    (b'run,sample,a"b\n', "the parameter name `a\"b` holds a quote"),
    (b"run,sample,a\x01b\n", "holds the control character U+0001"),
    (b"run,sample,a\xc2\x85b\n", "holds the control character U+0085"),
    (b"run,sample,run\n", "`run` names a plan column of its own"),
    (b"run,sample,a,a\n", "the parameter `a` is a column twice"),
    (b"run,sample," + NAME_256.encode() + b"\n", "is longer than 256 characters"),
    (b"run,sample," + b",".join(b"p%d" % i for i in range(257)) + b"\n", "257 parameters, more than the 256"),
    (b"run,sample,a\n0,0\n", "line 2: `0,0`: 2 fields: accepted 3"),
    (b"run,sample,a\n0,0,1,2\n", "4 fields: accepted 3"),
    (b"run,sample,a\n-1,0,1\n", "line 2: run -1: accepted an integer, 0 ≤ value ≤ 2^64 − 1"),
    (b"run,sample,a\n1.5,0,1\n", "line 2: run 1.5"),
    (b"run,sample,a\n18446744073709551616,0,1\n", "run 18446744073709551616"),
    (b"run,sample,a\n0,x,1\n", "line 2: sample x"),
    (b"run,sample,a\n0,0,nan\n", "line 2: a nan: accepted a finite number"),
    (b"run,sample,a\n0,0,-inf\n", "a -inf"),
    (b"run,sample,a\n0,0,1e400\n", "a 1e400"),
    (b"run,sample,a\n0,0,0x10\n", "a 0x10"),
    (b"run,sample,a\n0,0,1_0\n", "a 1_0"),
    (b"run,sample,a\n0,0,\n", "a (empty)"),
    (b"run,sample,a\n0,0,1\n0,1,2\n", "line 3: the run index 0 is given twice"),
    (b"run,sample,a\n0,0," + b"1" * (64 << 10) + b"\n", "line 2: longer than 65536 bytes"),
    (b"run,sample,a\n0,0,\xff\n", "line 2: not UTF-8 text"),
])
def test_a_plan_the_binary_would_refuse_is_refused(text, words):
    with pytest.raises(D.InputError, match=re.escape(words)):
        D.parse_plan(text)


def test_a_plan_past_the_binarys_row_and_value_bounds_is_refused(monkeypatch):
    monkeypatch.setattr(D, "MAX_RUNS", 2)
    with pytest.raises(D.InputError, match="line 4: more than the 2 runs"):
        D.parse_plan(b"run,sample,a\n0,0,1\n1,0,1\n2,0,1\n")
    monkeypatch.setattr(D, "MAX_RUNS", 100)
    monkeypatch.setattr(D, "MAX_VALUES", 3)
    with pytest.raises(D.InputError, match="line 3: more than the 100 runs or 3 values"):
        D.parse_plan(b"run,sample,a,b\n0,0,1,2\n1,0,1,2\n")


def test_a_plan_is_read_as_the_binary_reads_it():
    header, rows = D.parse_plan(b"\xef\xbb\xbfrun , sample,\tplant.T_em \r\n\r\n +7 ,003, 1e-3 \n\n")
    assert header == "run,sample,plant.T_em" and rows == ["+7,003,1e-3"]
    assert D.plan_values(header, rows) == [(7, 3, [1e-3])]


JSON_OK = '{"run":0,"sample":0,"params":{"a":1},"metrics":{"m":null},"status":"ok","error":null}'


@pytest.mark.parametrize("text,words", [
    ('{"run":0', "line 1: not a JSON line"),
    ('{"run":0,"sample":0,"params":{"a":1},"metrics":{},"status":"ok"}', "accepted the keys run, sample"),
    (JSON_OK.replace('"run":0', '"run":-1'), "run and sample: accepted whole numbers"),
    (JSON_OK.replace('"run":0', '"run":0.5'), "run and sample"),
    (JSON_OK.replace('"run":0', '"run":true'), "run and sample"),
    (JSON_OK.replace('"sample":0', '"sample":"0"'), "run and sample"),
    (JSON_OK.replace('{"a":1}', '{"b":1}'), "params: accepted the plan's parameters ['a']"),
    (JSON_OK.replace('{"a":1}', '{"a":NaN}'), "params: accepted finite numbers"),
    (JSON_OK.replace('{"a":1}', '{"a":1e400}'), "params: accepted finite numbers"),
    (JSON_OK.replace('{"a":1}', '{"a":"1"}'), "params: accepted finite numbers"),
    (JSON_OK.replace('{"m":null}', '{"m":Infinity}'), "metric m: accepted a finite number or null"),
    (JSON_OK.replace('{"m":null}', '[1]'), "metrics: accepted an object"),
    (JSON_OK + "\n" + JSON_OK.replace('{"m":null}', '{"n":null}'), "line 2: metrics ['n']: the lines before have ['m']"),
    (JSON_OK.replace('"ok"', '"done"'), "status: accepted ok or failed"),
    (JSON_OK.replace('"error":null', '"error":3'), "error null or text"),
    (JSON_OK.replace('"error":null', '"error":NaN'), "error null or text"),
])
def test_a_line_the_binary_should_not_print_is_refused(text, words):
    with pytest.raises(D.BinaryError, match=re.escape(words)):
        D.parse_records(text, ["a"])


@pytest.mark.parametrize("text,words", [
    ("", "listed no column"),
    ("0\ta.x\n", "line 1: accepted `K<TAB>NAME`, K from 1 to 2"),
    ("3\ta.x\n", "K from 1 to 2"),
    ("1 a.x\n", "K from 1 to 2"),
    ("1\t\n", "K from 1 to 2"),
    ("1\ta,x\n", "without a comma"),
    ("1\ta.x\n2\ta.x\n", "line 2:"),
    ("1\ta.x\n\n2\tb.x\n", "line 2:"),
])
def test_a_split_the_binary_should_not_print_is_refused(text, words):
    with pytest.raises(D.BinaryError, match=re.escape(words)):
        D.parse_split(text, 2)


def test_the_decoders_arguments_are_checked():
    with pytest.raises(D.InputError, match="parts 0: accepted an integer"):
        D.parse_split("1\ta.x\n", 0)
    with pytest.raises(D.InputError, match="names"):
        D.parse_records(JSON_OK, [1])
