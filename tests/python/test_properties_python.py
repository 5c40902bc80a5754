"""Property-based tests (hypothesis) of every reader of untrusted bytes in the Python
packages: inchworm_segments' poses CSV and the run CSVs `compare` reads (summary, samples,
frames); inchworm_dask's sweep plan and what it reads back from the binary (a run's JSON
lines, the --show-split listing, the parts' CSVs it joins); inchworm_optics' prescription
JSON and the SSP it reads the FMUs' variables from for `--param` (and the `--param` values).

Two properties per package, each over at least 10 000 examples (derandomized, so CI runs
the same ones every time), each example fed to every reader of the package:

1. Hostile input: arbitrary bytes, bytes after a valid header, and a valid file mutated
   (truncated, a byte flipped, bytes inserted, a field replaced by NaN, 1e308, -0, a huge
   integer, a quote, a nesting; an XML attribute's or a JSON member's value replaced; a
   column added or dropped; a line dropped (the header too), duplicated or swapped; line
   endings changed, a byte-order mark) either parses to what the reader's contract calls
   valid, or raises the package's own error type: never another exception (KeyError,
   IndexError, UnicodeDecodeError, csv.Error, OverflowError, RecursionError, zlib.error,
   ...). Every reader bounds what it reads (the plain tests at the end feed them a file
   past the bound and /dev/zero), so none can hang.
2. Round trip: a valid input written with the package's own writer (or in the documented
   format, as the Rust binary writes it) parses back to the same values, bit for bit
   (signed zeros, subnormals and the largest floats included).

Why one drawn byte string per example: hypothesis costs about 0.35 ms an example for one
draw on this 2-core machine and 1.5-3 ms for the composite strategies these inputs would
need, so 60 000 examples fit in a minute only as one `st.binary` draw read as a `Program`
of choices (which mutation, where, which value). Hypothesis still explores and shrinks
those bytes, toward zeros: the simplest choice of every kind.

Every property counts the examples it ran and prints the count and its time (visible in
pytest's output); the test asserts the count. Each input found failing against the
packages before these tests is kept as a plain regression test below the properties, with
what it found.
"""
import collections
import csv
import decimal
import io
import json
import math
import os
import pathlib
import re
import struct
import sys
import time
import zipfile
from xml.sax.saxutils import quoteattr

import numpy as np
import pytest
from hypothesis import HealthCheck, given, note, settings, strategies as st

from conftest import ROOT

for package in ("inchworm_segments", "inchworm_dask", "inchworm_optics"):
    sys.path.insert(0, str(ROOT / "python" / package))  # this tree's packages, whatever the venv holds

from inchworm_dask import inputs as D  # noqa: E402
from inchworm_dask.system import join_parts  # noqa: E402
from inchworm_optics import cosim as OC  # noqa: E402
from inchworm_optics import inputs as OI  # noqa: E402
from inchworm_optics.telescope import Prescription  # noqa: E402
from inchworm_segments import compare as C  # noqa: E402
from inchworm_segments import figures as SF  # noqa: E402
from inchworm_segments import poses as P  # noqa: E402
from inchworm_segments.config import POSE_RANGES, SAMPLE_S, TIME_S, rings_for  # noqa: E402
from inchworm_segments.config import InputError as SegmentsError  # noqa: E402

EXAMPLES = 10_000
PROPERTY = settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))
PROGRAM = st.binary(max_size=1024)
#: Examples each property ran, by name.
RAN = collections.Counter()


def ran(name, prop, capsys):
    """Runs the hypothesis property `prop`, prints how many examples it ran and how long it
    took, and holds it to EXAMPLES."""
    RAN[name] = 0
    start = time.perf_counter()
    prop()
    took = time.perf_counter() - start
    with capsys.disabled():
        print(f"\nproperty {name}: {RAN[name]} examples in {took:.1f} s")
    assert RAN[name] >= EXAMPLES, f"{name}: {RAN[name]} examples"


def bits(a):
    """An array's (or a float's) bytes: equal only where every value is the same float,
    the sign of a zero included."""
    return np.asarray(a, dtype=float).tobytes()


#: Floats every float choice draws now and then: signed zeros, ±1, the smallest subnormal
#: and normal, the largest, and a few whose shortest text is long or has an exponent.
SPECIAL_FLOATS = (0.0, -0.0, 1.0, -1.0, 5e-324, -5e-324, 2.2250738585072014e-308, 1.7976931348623157e308,
                  -1.7976931348623157e308, 0.1, 1e-7, 1e22, 1.0000000000000002, 0.30000000000000004, 123456789.0,
                  1e300, -1e-300, 8.8, 3e7)
#: Characters a text choice draws besides any code point: CSV, JSON and XML syntax, line
#: breaks of every kind, white space the binary trims and Python strips, controls.
SPECIAL_CHARS = ',"\\\n\r\t {}[]<>&\';:=.+-0123456789eE_\x00\x0b\x0c\x1c\x1f\x7f\x85\xa0\u2028\u3000\ufeff\ufffd'


class Program:
    """The bytes hypothesis draws, read as a program of choices: each read takes the next
    bytes, and zeros once they run out (so that hypothesis shrinks toward the first choice
    of every kind)."""

    def __init__(self, data):
        self.data, self.at = data, 0

    def take(self, n):
        b = self.data[self.at:self.at + n]
        self.at += n
        return b.ljust(n, b"\0")

    def int(self, n):
        """0 ≤ value < n."""
        return int.from_bytes(self.take(max(1, ((n - 1).bit_length() + 7) // 8)), "little") % n

    def choice(self, seq):
        return seq[self.int(len(seq))]

    def flag(self):
        return self.int(2) == 1

    def float_in(self, lo=-math.inf, hi=math.inf, lo_open=False, hi_open=False):
        """A float lo ≤ value ≤ hi (`<` where open), finite: now and then a special one,
        else the drawn bits where they are in the range, else a point between the bounds."""
        lo, hi = max(lo, -1.7976931348623157e308), min(hi, 1.7976931348623157e308)

        def inside(x):
            return math.isfinite(x) and (lo < x if lo_open else lo <= x) and (x < hi if hi_open else x <= hi)

        if self.int(8) == 0:
            x = self.choice(SPECIAL_FLOATS)
            if inside(x):
                return x
        raw = self.take(8)
        x = struct.unpack("<d", raw)[0]
        if inside(x):
            return x
        u = int.from_bytes(raw, "little") / 2**64
        x = lo * (1 - u) + hi * u
        x = min(max(x, lo), hi)
        if lo_open and x == lo:
            x = math.nextafter(lo, hi)
        if hi_open and x == hi:
            x = math.nextafter(hi, lo)
        return x

    def text(self, max_len, exclude=""):
        """A text of at most `max_len` characters: special ones or any code point but a
        surrogate, none of `exclude`."""
        out = []
        for _ in range(self.int(max_len + 1)):
            c = self.choice(SPECIAL_CHARS) if self.flag() else chr(self.int(0x110000))
            if "\ud800" <= c <= "\udfff" or c in exclude:
                continue
            out.append(c)
        return "".join(out)

    def rest(self):
        return self.data[self.at:]


# ---- hostile inputs: a valid file, mutated ----
#: Field values a mutation puts in: non-finite, out of range, signed zero, huge integers,
#: digit separators, non-ASCII digits, CSV, JSON and XML syntax, control and odd characters.
TOKENS = ("nan", "NaN", "-nan", "inf", "-inf", "Infinity", "-Infinity", "1e308", "-1e308", "1e309", "1e-400",
          "-0", "-0.0", "0", "1", "2", "-1", "+1", "1.", ".5", "1e", ".", "0x10", "1_0", "١", "²", "1e5000",
          "9" * 400, "1" * 5000, "18446744073709551615", "18446744073709551616", "", " ", '"', '"a,b"', "\x00",
          "\u2028", "\ufeff", "é", "\r", "\n", "\t", "{", "}", "[", "]", "[" * 3000, '{"a":' * 3000, "null",
          "true", "\\", "\\u", "\udcff", "\x85", "run", "sample", "time", "parked", "<a>", "&x;", "'")
OPS = ("truncate", "flip", "insert", "field", "extra column", "drop column", "drop line", "dup line", "swap lines",
       "crlf", "cr", "bom", "blank line", "attribute")
#: An XML attribute's value, or a JSON member's (what the "attribute" mutation replaces).
VALUE_SPAN = re.compile(rb'(?<==")[^"]*(?=")|(?<==\')[^\']*(?=\')|(?<=":)[^,}]*')


def mutate(data, ops):
    """`data` (bytes) with each of `ops` applied: (operation, where, token)."""
    for op, at, token in ops:
        tok = token.encode("utf-8", "surrogatepass")
        if op == "truncate":
            data = data[:at % (len(data) + 1)]
        elif op == "flip" and data:
            i = at % len(data)
            data = data[:i] + bytes([data[i] ^ (1 << (at >> 20) % 8)]) + data[i + 1:]
        elif op == "insert":
            i = at % (len(data) + 1)
            data = data[:i] + tok + data[i:]
        elif op == "crlf":
            data = data.replace(b"\n", b"\r\n")
        elif op == "cr":
            data = data.replace(b"\n", b"\r")
        elif op == "bom":
            data = b"\xef\xbb\xbf" + data
        elif op == "attribute":
            spans = [m.span() for m in VALUE_SPAN.finditer(data)]
            if spans:
                i, j = spans[at % len(spans)]
                data = data[:i] + tok + data[j:]
        else:
            lines = data.split(b"\n")
            i = at % len(lines)
            fields = lines[i].split(b",")
            j = (at >> 8) % len(fields)
            if op == "field":
                fields[j] = tok
                lines[i] = b",".join(fields)
            elif op == "extra column":
                lines[i] += b"," + tok
            elif op == "drop column":
                lines = [b",".join(f for k, f in enumerate(line.split(b",")) if k != j) for line in lines]
            elif op == "drop line":
                del lines[i]
            elif op == "dup line":
                lines.insert(i, lines[i])
            elif op == "swap lines":
                k = (at >> 12) % len(lines)
                lines[i], lines[k] = lines[k], lines[i]
            elif op == "blank line":
                lines.insert(i, b"")
            data = b"\n".join(lines)
    return data


def mutated(prog, valid):
    """One to three mutations of `valid`, as `prog` chooses them."""
    ops = []
    for _ in range(1 + prog.int(3)):
        token = prog.choice(TOKENS) if prog.int(4) else prog.text(6)
        ops.append((prog.choice(OPS), prog.int(2**24), token))
    return mutate(valid, ops)


def hostile(prog, valid_files, prefixes):
    """Arbitrary bytes (the rest of the program), bytes after one of `prefixes`, or one of
    `valid_files` mutated."""
    kind = prog.int(4)
    if kind == 0:
        return prog.rest()
    if kind == 1:
        return prog.choice(prefixes) + prog.rest()
    return mutated(prog, prog.choice(valid_files))


# ---- inchworm_segments: the poses CSV; compare's summary, samples and frames ----
def poses_file(segments, samples, parked, seed=1):
    t, p, k = P.synthetic(segments, samples * SAMPLE_S, seed=seed)
    f = io.StringIO()
    P.write_rows(f, t, p, k if parked else None)
    return f.getvalue().encode()


def summary_file(numbers):
    f = io.StringIO()
    SF.write_summary(f, numbers)
    return f.getvalue().encode()


def table_file(head, rows):
    f = io.StringIO()
    w = csv.writer(f)
    w.writerow(head)
    w.writerows(rows)
    return f.getvalue().encode()


SEGMENTS_FILES = [
    poses_file(7, 3, True), poses_file(6, 2, False), poses_file(7, 1, False, seed=2),
    summary_file({"segments": 7, "cophasing_rms_nm": 2.56, "cophasing_rms_parked_nm": None, "strehl_min": 0.9}),
    table_file(["t_s", "parked", "cophasing_rms_nm", "wfe_rms_nm", "strehl", "contrast"],
               [["0.0000", 0, 80.6, 81.0, 0.8, 3.3e-4], ["0.0020", 1, 2.5, 2.6, 0.99, 5.9e-7]]),
    table_file(["frame", "t_start_s", "t_end_s", "parked", "contrast", "strehl_mean", "cophasing_rms_nm"],
               [[0, "0.0000", "0.0500", 0, 3.3e-4, 0.8, 80.6]]),
]
SEGMENTS_PREFIXES = [SEGMENTS_FILES[0][:SEGMENTS_FILES[0].index(b"\n") + 1], b"name,value\n",
                     b"t_s,cophasing_rms_nm,contrast\n"]


def check_poses_reader(data):
    """`poses.parse_csv` of `data`: what `read_csv` promises (a ring count of segments,
    finite values in their ranges, the engine's step, parked 0/1), or its InputError."""
    try:
        t, p, k = P.parse_csv(data)
    except SegmentsError:
        return
    assert t.ndim == 1 and len(t) >= 1 and p.shape == (len(t), p.shape[1], 3)
    rings_for(p.shape[1])
    assert np.all((t >= TIME_S.lo) & (t <= TIME_S.hi))
    for j, rng in enumerate(POSE_RANGES):
        assert np.all((p[..., j] >= rng.lo) & (p[..., j] <= rng.hi))
    assert np.all(np.abs(np.diff(t) - SAMPLE_S) <= P.STEP_TOLERANCE_S)
    assert k is None or (k.dtype == bool and k.shape == t.shape)


def check_compare_readers(data):
    """`compare.parse_summary` (names → finite numbers or None) and `parse_columns` for
    the samples' and the frames' columns (each a finite number in its range, at least one
    row) of `data`, or their InputError."""
    try:
        numbers = C.parse_summary(data)
    except SegmentsError:
        pass
    else:
        assert all(isinstance(k, str) and k and (v is None or math.isfinite(v)) for k, v in numbers.items())
    for wanted in (C.SAMPLE_COLUMNS, C.FRAME_COLUMNS):
        try:
            columns = C.parse_columns(data, wanted, "run CSV")
        except SegmentsError:
            continue
        assert list(columns) == list(wanted)
        lengths = {len(v) for v in columns.values()}
        assert len(lengths) == 1 and lengths.pop() >= 1
        for c, rng in wanted.items():
            assert all(isinstance(x, float) and rng.lo <= x <= rng.hi for x in columns[c])


@PROPERTY
@given(PROGRAM)
def _segments_hostile(program):
    RAN["inchworm_segments readers, hostile"] += 1
    data = hostile(Program(program), SEGMENTS_FILES, SEGMENTS_PREFIXES)
    note(f"input: {data!r}")
    check_poses_reader(data)
    check_compare_readers(data)


def test_the_segments_readers_take_any_bytes(capsys):
    ran("inchworm_segments readers, hostile", _segments_hostile, capsys)


@PROPERTY
@given(PROGRAM)
def _segments_round_trip(program):
    """The poses CSV (`poses.write_rows`), the summary (`figures.write_summary`) and a
    samples CSV (csv's writer, as `figures.timeseries` writes it) read back bit for bit."""
    RAN["inchworm_segments readers, round trip"] += 1
    prog = Program(program)
    segments, samples = prog.choice([6, 7]), 1 + prog.int(4)
    t0 = prog.float_in(0.0, TIME_S.hi - 1.0)
    t = t0 + np.arange(samples) * SAMPLE_S
    p = np.array([[[prog.float_in(rng.lo, rng.hi) for rng in POSE_RANGES] for _ in range(segments)]
                  for _ in range(samples)])
    k = np.array([prog.flag() for _ in range(samples)]) if prog.flag() else None
    f = io.StringIO()
    P.write_rows(f, t, p, k)
    t2, p2, k2 = P.parse_csv(f.getvalue().encode())
    assert bits(t2) == bits(t) and bits(p2) == bits(p)
    assert (k2 is None) == (k is None) and (k is None or np.array_equal(k2, k))

    numbers = {}
    for _ in range(prog.int(5)):
        name = prog.text(10) or "x"
        kind = prog.int(3)
        numbers[name] = None if kind == 0 else prog.float_in() if kind == 1 else prog.int(2**54) - 2**53
    back = C.parse_summary(summary_file(numbers))
    assert list(back) == list(numbers)
    assert all((back[n] is None) == (v is None) and (v is None or bits(back[n]) == bits(float(v)))
               for n, v in numbers.items())

    order = ["t_s", "cophasing_rms_nm", "contrast", "extra"]
    order.insert(prog.int(4), order.pop(prog.int(4)))
    rows = [{"t_s": prog.float_in(TIME_S.lo, TIME_S.hi), "cophasing_rms_nm": prog.float_in(0.0),
             "contrast": prog.float_in(0.0), "extra": prog.text(4)} for _ in range(1 + prog.int(3))]
    columns = C.parse_columns(table_file(order, [[r[c] for c in order] for r in rows]), C.SAMPLE_COLUMNS, "t")
    for c in C.SAMPLE_COLUMNS:
        assert bits(columns[c]) == bits([r[c] for r in rows])


def test_the_segments_readers_round_trip(capsys):
    ran("inchworm_segments readers, round trip", _segments_round_trip, capsys)


# ---- inchworm_dask: the plan, a run's JSON lines, the --show-split listing, the parts ----
def rust_display(x):
    """An f64 as the binary's `{}` writes it: the shortest digits that read back, never
    an exponent (1e-7 is 0.0000001, 1e22 is 10000000000000000000000), -0 for minus zero."""
    return format(decimal.Decimal(repr(x)).normalize(), "f")


def json_string(s):
    """A string as the binary's `json_string` writes it."""
    out = []
    for c in s:
        esc = {'"': '\\"', "\\": "\\\\", "\n": "\\n", "\r": "\\r", "\t": "\\t"}.get(c)
        out.append(esc if esc else f"\\u{ord(c):04x}" if ord(c) < 0x20 else c)
    return '"' + "".join(out) + '"'


def json_line(run, sample, params, metrics, error):
    """One run as the binary's `json_line` writes it."""
    def number(v):
        return "null" if v is None else rust_display(v)

    return ("{" + f'"run":{run},"sample":{sample},"params":{{'
            + ",".join(f"{json_string(n)}:{number(v)}" for n, v in params.items()) + '},"metrics":{'
            + ",".join(f"{json_string(m)}:{number(v)}" for m, v in metrics.items())
            + f'}},"status":"{"ok" if error is None else "failed"}","error":'
            + ("null" if error is None else json_string(error)) + "}")


RECORD_NAMES = ["plant.T_em", "plant.k_p"]
#: The parts' texts as one input: separated by U+001D (group separator).
PART_SEPARATOR = "\x1d"
PARTS = ["time,a.x,a.y\n0,1,2\n0.002,1.5,2.5\n", "time,b.x\n0,3\n0.002,3.5\n"]
FALLBACK_SPLIT = [(1, "a.x"), (2, "b.x"), (1, "a.y")]
DASK_FILES = [
    b"run,sample,plant.T_em,plant.F_d0\n0,0,8.8,175\n1,1,9.1,1.6e2\n2,0,-0,0.0000001\n", b"run,sample\n0,0\n",
    b"\xef\xbb\xbfrun, sample ,a\r\n\r\n 7 ,3, 1e-3 \r\n",
    ("\n".join([json_line(0, 0, {"plant.T_em": 8.8, "plant.k_p": 3e7}, {"settle:1e-6": 0.788, "slips": 0.0}, None),
                json_line(17, 3, {"plant.T_em": -1.0, "plant.k_p": 3e7}, {"settle:1e-6": None, "slips": None},
                          "parameter plant.T_em = -1 is outside its range [0.001, 1000]"),
                "progress: 2 runs"]) + "\n").encode(),
    b"1\ta.x\n2\tb.x\n1\ta.y\n",
    PART_SEPARATOR.join(PARTS).encode(),
]
DASK_PREFIXES = [b"run,sample,a,b\n", b'{"run":0,"sample":0,"params":{', b"1\t", b"time,a.x\n"]


def check_plan_reader(data):
    """`inputs.parse_plan`: a header `run,sample,<names the binary takes>`, rows of its
    field count, whole run indices given once, finite values; or its InputError."""
    try:
        header, rows = D.parse_plan(data)
    except D.InputError:
        return
    cols = header.split(",")
    assert cols[:2] == ["run", "sample"] and len(cols) - 2 <= D.MAX_PARAMETERS
    for name in cols[2:]:
        D.check_name(name, "plan")
    values = D.plan_values(header, rows)
    assert all(len(r.split(",")) == len(cols) for r in rows)
    assert len({run for run, _, _ in values}) == len(values)
    assert all(0 <= run <= D.MAX_INDEX and 0 <= s <= D.MAX_INDEX for run, s, _ in values)
    assert all(math.isfinite(v) for _, _, vs in values for v in vs)


def check_records_decoder(text):
    """`inputs.parse_records`: each run's numbers whole or finite, the plan's parameters,
    the same metrics on every line; minus zero kept; or its BinaryError."""
    try:
        records = D.parse_records(text, RECORD_NAMES)
    except D.BinaryError:
        return
    metric_names = None
    for r in records:
        assert 0 <= r["run"] <= D.MAX_INDEX and 0 <= r["sample"] <= D.MAX_INDEX
        assert list(r["params"]) == RECORD_NAMES and all(math.isfinite(v) for v in r["params"].values())
        assert all(v is None or math.isfinite(v) for v in r["metrics"].values())
        metric_names = metric_names or list(r["metrics"])
        assert list(r["metrics"]) == metric_names
        assert r["status"] in ("ok", "failed") and (r["error"] is None or type(r["error"]) is str)
    if '"plant.T_em":-0,' in text and len(records) == 1:
        assert math.copysign(1.0, records[0]["params"]["plant.T_em"]) < 0


def check_system_decoders(text, parts):
    """`inputs.parse_split` (part numbers 1 to `parts`, names once) of `text`, or its
    BinaryError; then `system.join_parts` of that split (or a fixed one) and the parts'
    texts in `text`: a table of the split's columns, or its InputError."""
    try:
        split = D.parse_split(text, parts)
    except D.BinaryError:
        split = FALLBACK_SPLIT
    else:
        assert split and all(1 <= k <= parts and name and "\n" not in name for k, name in split)
        assert len({name for _, name in split}) == len(split)
    try:
        joined = join_parts(split, text.split(PART_SEPARATOR)[:3])
    except D.InputError:
        return
    lines = joined.split("\n")
    assert lines[-1] == "" and lines[0].split(",")[1:] == [name for _, name in split]
    assert all(len(line.split(",")) == len(split) + 1 for line in lines[:-1])


@PROPERTY
@given(PROGRAM)
def _dask_hostile(program):
    RAN["inchworm_dask readers, hostile"] += 1
    prog = Program(program)
    parts = 1 + prog.int(3)
    data = hostile(prog, DASK_FILES, DASK_PREFIXES)
    note(f"input: {data!r}, parts {parts}")
    check_plan_reader(data)
    text = data.decode("utf-8", "replace")  # the binary's output, decoded by run_rows and _run
    check_records_decoder(text)
    check_system_decoders(text, parts)


def test_the_dask_readers_take_any_bytes(capsys):
    ran("inchworm_dask readers, hostile", _dask_hostile, capsys)


def plan_name(prog):
    """A parameter name the binary takes (the package's own check), or None."""
    name = prog.text(8)
    try:
        D.check_name(name, "plan")
    except D.InputError:
        return None
    return name


@PROPERTY
@given(PROGRAM)
def _dask_round_trip(program):
    """A plan in the binary's `to_csv` format (and Python's), the binary's JSON lines, and a
    run split into parts (its --show-split listing and the parts' CSVs) read back bit for
    bit: the plan's values, the runs' numbers, the joined table's text."""
    RAN["inchworm_dask readers, round trip"] += 1
    prog = Program(program)
    names = list(dict.fromkeys(n for n in (plan_name(prog) for _ in range(prog.int(4))) if n))
    runs = list(dict.fromkeys(prog.choice([prog.int(10), prog.int(2**64)]) for _ in range(prog.int(5))))
    rows = [(run, prog.int(2**64), [prog.float_in() for _ in names]) for run in runs]
    fmt = rust_display if prog.flag() else repr
    end = "\r\n" if prog.flag() else "\n"
    text = end.join(["run,sample" + "".join("," + n for n in names)]
                    + [",".join([str(r), str(s), *map(fmt, vs)]) for r, s, vs in rows]) + end
    header, lines = D.parse_plan(text.encode())
    assert header == ",".join(["run", "sample", *names])
    back = D.plan_values(header, lines)
    assert [(r, s) for r, s, _ in back] == [(r, s) for r, s, _ in rows]
    assert all(bits(b) == bits(v) for (_, _, b), (_, _, v) in zip(back, rows))

    metric_names = list(dict.fromkeys(prog.text(6) for _ in range(prog.int(4))))
    outcomes = [(r, s, dict(zip(names, vs)), {m: None if prog.int(4) == 0 else prog.float_in() for m in metric_names},
                 prog.text(8) if prog.flag() else None) for r, s, vs in rows]
    records = D.parse_records("\n".join(json_line(*o) for o in outcomes) + "\n", names)
    assert len(records) == len(outcomes)
    for rec, (run, sample, params, metrics, error) in zip(records, outcomes):
        assert (rec["run"], rec["sample"], rec["error"]) == (run, sample, error)
        assert rec["status"] == ("ok" if error is None else "failed")
        assert bits(list(rec["params"].values())) == bits(list(params.values()))
        assert list(rec["metrics"]) == metric_names
        assert all((v is None) == (m is None) and (m is None or bits(v) == bits(m))
                   for v, m in zip(rec["metrics"].values(), metrics.values()))

    columns = {}
    for _ in range(1 + prog.int(5)):
        name = prog.text(6, exclude=",\n\r") or "c"
        if name != "time":
            columns.setdefault(name, 1 + prog.int(4))
    columns = list(columns.items())
    parts = max(k for _, k in columns)
    table = [(repr(prog.float_in()), [prog.text(5, exclude=",\n\r") for _ in columns]) for _ in range(prog.int(4))]
    listing = "".join(f"{k}\t{name}\n" for name, k in columns)
    whole = ["time," + ",".join(name for name, _ in columns)] + [",".join([t, *cells]) for t, cells in table]
    texts = []
    for part in range(1, parts + 1):
        mine = [i for i, (_, k) in enumerate(columns) if k == part]
        part_lines = ["time" + "".join("," + columns[i][0] for i in mine)]
        part_lines += [t + "".join("," + cells[i] for i in mine) for t, cells in table]
        texts.append("\n".join(part_lines) + "\n")
    split = D.parse_split(listing, parts)
    assert split == [(k, name) for name, k in columns]
    assert join_parts(split, texts) == "\n".join(whole) + "\n"


def test_the_dask_readers_round_trip(capsys):
    ran("inchworm_dask readers, round trip", _dask_round_trip, capsys)


# ---- inchworm_optics: the prescription; the SSP's variables and --param ----
SSD_NS = "http://ssp-standard.org/SSP1/SystemStructureDescription"


def model_description(variables):
    """A modelDescription.xml of `variables` [(name, type, min text or None, max text or None)]."""
    def var(name, kind, lo, hi):
        bounds = "".join(f" {a}={quoteattr(v)}" for a, v in (("min", lo), ("max", hi)) if v is not None)
        return f"<ScalarVariable name={quoteattr(name)}><{kind}{bounds}/></ScalarVariable>"

    return ("<?xml version='1.0' encoding='UTF-8'?><fmiModelDescription><ModelVariables>"
            + "".join(var(*v) for v in variables) + "</ModelVariables></fmiModelDescription>").encode()


def ssp_bytes(components, ssd=None, md=None):
    """An SSP of `components` [(name, variables)], each an FMU (deflated) holding only its
    model description (`md` replaces every one's bytes, `ssd` the SSD's)."""
    if ssd is None:
        ssd = (f"<?xml version='1.0' encoding='UTF-8'?><ssd:SystemStructureDescription xmlns:ssd='{SSD_NS}'>"
               "<ssd:System name='s'><ssd:Elements>"
               + "".join(f"<ssd:Component name={quoteattr(n)} source={quoteattr(f'resources/{i}.fmu')}/>"
                         for i, (n, _) in enumerate(components))
               + "</ssd:Elements></ssd:System></ssd:SystemStructureDescription>").encode()
    def member(name):  # a fixed time stamp: the same bytes on every run
        return zipfile.ZipInfo(name, date_time=(2026, 1, 1, 0, 0, 0))

    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as z:
        z.writestr(member("SystemStructure.ssd"), ssd)
        for i, (_, variables) in enumerate(components):
            fmu = io.BytesIO()
            with zipfile.ZipFile(fmu, "w") as f:
                f.writestr(member("modelDescription.xml"), md if md is not None else model_description(variables),
                           compress_type=zipfile.ZIP_DEFLATED)
            z.writestr(member(f"resources/{i}.fmu"), fmu.getvalue())
    return out.getvalue()


MOUNT = [("mount", [("radius", "Real", "0.0001", "10"), ("count", "Integer", None, None),
                    ("analog", "Boolean", None, None), ("name", "String", None, None)])]
SSD_TEXT = (f"<?xml version='1.0'?><ssd:SystemStructureDescription xmlns:ssd='{SSD_NS}'>"
            "<ssd:Component name='mount' source='resources/0.fmu'/></ssd:SystemStructureDescription>").encode()
MD_TEXT = model_description(MOUNT[0][1])
OPTICS_FILES = [json.dumps(Prescription().as_dict()).encode(), b'{"aperture_m": 0.5, "obscuration_m": 0.1}',
                ssp_bytes(MOUNT)]
OPTICS_PREFIXES = [b'{"aperture_m": ', b"PK\x03\x04"]
PARAM_NAMES = ("mount.radius", "mount.count", "mount.analog", "mount.name", "mount.none", "mount", "")
PRESCRIPTION_KEYS = sorted(Prescription().as_dict())


def optics_input(prog):
    """Hostile bytes, or a JSON object of drawn keys and values, or an SSP whose SSD or
    model description is a mutated one, or an SSP with bytes flipped, cut or inserted (in
    its headers, its central directory, an FMU's deflated stream)."""
    kind = prog.int(6)
    if kind == 2:
        ops = [(prog.choice(("flip", "flip", "truncate", "insert")), prog.int(2**24), prog.choice(TOKENS[:20]))
               for _ in range(1 + prog.int(2))]
        return mutate(OPTICS_FILES[2], ops)
    if kind == 0:
        value_kinds = (lambda: None, prog.flag, prog.float_in, lambda: prog.int(2**70) - 2**69,
                       lambda: prog.text(4), lambda: [prog.int(9)], lambda: struct.unpack("<d", prog.take(8))[0])
        obj = {(prog.choice(PRESCRIPTION_KEYS) if prog.int(4) else prog.text(4)): prog.choice(value_kinds)()
               for _ in range(prog.int(5))}
        return json.dumps(obj).encode()  # NaN and Infinity as Python's JSON writes them
    if kind == 1:
        return ssp_bytes(MOUNT, ssd=mutated(prog, SSD_TEXT)) if prog.flag() else ssp_bytes(MOUNT,
                                                                                            md=mutated(prog, MD_TEXT))
    return hostile(prog, OPTICS_FILES, OPTICS_PREFIXES)


def check_prescription_reader(data):
    """`Prescription.parse`: every field in its range (the check a prescription passes),
    or its InputError."""
    try:
        rx = Prescription.parse(data)
    except OI.InputError:
        return
    OI.check_prescription(rx)
    assert all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in rx.as_dict().values())


def check_ssp_reader(data, param):
    """`cosim.ssp_variables` ({component: {variable: (type, min, max)}}, bounds numbers or
    None), then `parse_params` of `param`: a value of the variable's type within its bounds;
    or their InputError."""
    try:
        variables = OC.ssp_variables(io.BytesIO(data))
    except OI.InputError:
        return
    for comp, vs in variables.items():
        assert isinstance(comp, str)
        for name, (kind, lo, hi) in vs.items():
            assert isinstance(name, str) and isinstance(kind, str)
            assert all(b is None or (isinstance(b, float) and not math.isnan(b)) for b in (lo, hi))
    try:
        params = OC.parse_params(io.BytesIO(data), [param])
    except OI.InputError:
        return
    ((key, v),) = params.items()
    comp, _, var = key.partition(".")
    kind, lo, hi = variables[comp][var]
    if kind == "Boolean":
        assert isinstance(v, bool)
    else:
        assert math.isfinite(v) and (lo is None or v >= lo) and (hi is None or v <= hi)


@PROPERTY
@given(PROGRAM)
def _optics_hostile(program):
    RAN["inchworm_optics readers, hostile"] += 1
    prog = Program(program)
    param = f"{prog.choice(PARAM_NAMES)}={prog.choice(TOKENS) if prog.flag() else prog.text(6)}"
    data = optics_input(prog)
    note(f"input: {data!r}, --param {param!r}")
    check_prescription_reader(data)
    check_ssp_reader(data, param)


def test_the_optics_readers_take_any_bytes(capsys):
    ran("inchworm_optics readers, hostile", _optics_hostile, capsys)


XML_EXCLUDED = "".join(map(chr, range(0x20))) + "\x7f\ufffe\uffff"


@PROPERTY
@given(PROGRAM)
def _optics_round_trip(program):
    """A prescription (Python's JSON of `as_dict`, some fields left to their defaults) and an
    SSP's FMU variables (types and declared bounds as shortest float text) read back bit for
    bit."""
    RAN["inchworm_optics readers, round trip"] += 1
    prog = Program(program)
    fields = {n: prog.float_in(r.lo, r.hi, r.lo_open, r.hi_open) for n, r in OI.PRESCRIPTION.items()}
    f1, m = fields["primary_focal_length_m"], fields["secondary_magnification"]
    fields["back_focal_distance_m"] = prog.float_in(-f1, m * f1, lo_open=True, hi_open=True)
    fields["obscuration_m"] = prog.float_in(0.0, fields["aperture_m"], hi_open=True)
    rx = Prescription(**fields)
    given_fields = {k: v for k, v in rx.as_dict().items() if prog.int(4)}
    defaults = Prescription().as_dict()
    try:
        back = Prescription.parse(json.dumps(given_fields).encode())
    except OI.InputError as e:  # a field left to its default that the others do not fit
        assert set(given_fields) != set(defaults), e
    else:
        for k, v in back.as_dict().items():
            assert bits(v) == bits(given_fields.get(k, defaults[k])), k

    components = []
    for _ in range(prog.int(3)):
        variables = [(prog.text(5, exclude=XML_EXCLUDED) or "v", prog.choice(["Real", "Integer", "Boolean", "String"]),
                      *(repr(prog.float_in()) if prog.flag() else None for _ in range(2))) for _ in range(prog.int(4))]
        components.append((prog.text(5, exclude=XML_EXCLUDED) or "c", variables))
    expected = {}
    for n, vs in components:
        expected[n] = {v: (k, None if lo is None else float(lo), None if hi is None else float(hi))
                       for v, k, lo, hi in vs}
    back = OC.ssp_variables(io.BytesIO(ssp_bytes(components)))
    assert back.keys() == expected.keys()
    for n, vs in expected.items():
        assert back[n].keys() == vs.keys()
        for v, (k, lo, hi) in vs.items():
            got = back[n][v]
            assert got[0] == k and all((g is None) == (w is None) and (w is None or bits(g) == bits(w))
                                       for g, w in zip(got[1:], (lo, hi)))


def test_the_optics_readers_round_trip(capsys):
    ran("inchworm_optics readers, round trip", _optics_round_trip, capsys)


# ---- what the properties found in the packages before these tests ----
# Each input below made a reader of the HEAD packages fail the property: an exception of
# another type than the package's, or a value its contract refuses accepted. Found by the
# properties above run against the packages as they were (or, where a comment says so, by
# reading the code and checked the same way). Each now raises the package's error, or
# reads back what was written.
POSES_HEADER = ",".join(P.header(7)).encode()
SEGMENTS_FOUND = [
    # UnicodeDecodeError: a byte that is not UTF-8 (every reader opened the file as text).
    ("poses", b"\xf8", "not UTF-8"), ("summary", b"\xf8", "not UTF-8"), ("samples", b"\xf8", "not UTF-8"),
    # Accepted: a piston of 1e308 m, which the optics' phase overflows (no range on a pose).
    ("poses", POSES_HEADER + b"\n0,1e308" + b",0" * 20 + b",1\n", "seg0_piston_m 1e+308: accepted -1 ≤ value ≤ 1 m"),
    # Reading the code: csv.Error, a quoted field past csv's 128 KiB limit.
    ("poses", b'"' + b"a\n" * 70000, "not CSV"),
    # KeyError: a summary without its `name` and `value` columns.
    ("summary", b"\nw", "accepted the header `name,value`"),
    # TypeError: a summary row of one cell (float(None)).
    ("summary", b"name,value\n\x1d", "row 2 has 1 columns"),
    # ValueError of float(), not the package's: a value that is not a number.
    ("summary", b"name,value\nsegments,'7\n", "segments \"'7\": accepted a finite number"),
    # Accepted: 1e309 read as infinity.
    ("summary", b"name,value\nsegments,1e309\n", "segments inf: accepted a finite number"),
    # IndexError: a frames CSV of no frame (frames[-1]); KeyError: no header.
    ("frames", b"", "no column t_start_s"), ("frames", b"\nw", "no column t_start_s"),
    # TypeError: a samples row short of its header; ValueError: a cell not a number.
    ("samples", b"t_s,cophasing_rms_nm,contrast\n0", "row 2 has 1 columns, the header 3"),
    ("samples", b"t_s,cophasing_rms_nm,contrast\nq,0,0\n", "t_s 'q': accepted 0 ≤ value ≤ 1e+06 s"),
]
SEGMENTS_READERS = {"poses": P.parse_csv, "summary": C.parse_summary,
                    "samples": lambda d: C.parse_columns(d, C.SAMPLE_COLUMNS, "samples"),
                    "frames": lambda d: C.parse_columns(d, C.FRAME_COLUMNS, "frames")}


@pytest.mark.parametrize("reader,data,match", SEGMENTS_FOUND)
def test_what_the_properties_found_in_the_segments_readers(reader, data, match):
    with pytest.raises(SegmentsError, match=re.escape(match)):
        SEGMENTS_READERS[reader](data)


DASK_FOUND = [
    # UnicodeDecodeError: a plan byte that is not UTF-8.
    ("plan", b"\xbe", "line 1: not UTF-8"), ("plan", b"run,sample,a\n0,0,\xff\n", "line 2: not UTF-8"),
    # Accepted, then refused by every task's binary on the cluster: a header that only
    # starts with `run,sample`, a row short of the header, an empty parameter name, a run
    # index twice, a value that is not a number.
    ("plan", b"run,sample[,a\n0,0,1\n", "not a sweep plan: header `run,sample[,a`"),
    ("plan", b"run,sample\n0", "1 fields: accepted 2"), ("plan", b"run,sample,\n0,0\n", "the parameter name is empty"),
    ("plan", b"run,sample,a\n2,0,1\n2,0,1\n", "the run index 2 is given twice"),
    ("plan", b"run,sample,a\n0,0,x\n", "line 2: a x: accepted a finite number"),
    # json.JSONDecodeError: a run's line cut short.
    ("records", "{", "not a JSON line"), ("records", '{"run":0,"sample":0,"params":', "not a JSON line"),
    # KeyError: a line without its status.
    ("records", '{"run":0,"sample":0,"params":{"plant.T_em":8.8,"plant.k_p":1},"metrics":{},"error":null}', "the keys"),
    # RecursionError: a nesting past the parser's depth.
    ("records", '{"run":0,"sample":0,"params":{},"metrics":{},"status":"ok","error":' + '{"a":' * 3000,
     "not a JSON line"),
    # Reading the code: ValueError from int(), a part number of non-ASCII digits
    # (str.isdigit() takes "²") or of more than 4300 digits.
    ("split", "\u00b2\ta.x\n", "K from 1 to 2"), ("split", "9" * 5000 + "\ta.x\n", "K from 1 to 2"),
]
DASK_READERS = {"plan": D.parse_plan, "records": lambda t: D.parse_records(t, RECORD_NAMES),
                "split": lambda t: D.parse_split(t, 2)}


@pytest.mark.parametrize("reader,data,match", DASK_FOUND)
def test_what_the_properties_found_in_the_dask_readers(reader, data, match):
    with pytest.raises(D.InputError if reader == "plan" else D.BinaryError, match=re.escape(match)):
        DASK_READERS[reader](data)


def test_what_the_properties_found_in_the_dask_joins_and_json():
    # Reading the code: IndexError, no part's CSV at all.
    with pytest.raises(D.InputError, match="0 parts"):
        join_parts(FALLBACK_SPLIT, [])
    # Round trip: a column name holding U+001C (or U+0085, U+2028: str.splitlines() cuts
    # lines there) made a valid part's row "differ from its header".
    part = "time,\x1c\u2028\x85\n0,1\n"
    assert join_parts([(1, "\x1c\u2028\x85")], [part]) == part
    # Round trip: minus zero, as the binary writes it (-0), read back as +0 (json's int()).
    ((r,),) = [D.parse_records(json_line(0, 0, {"plant.T_em": -0.0, "plant.k_p": 1.0}, {}, None), RECORD_NAMES)]
    assert bits(r["params"]["plant.T_em"]) == bits(-0.0)


def flip(data, i, bit):
    return data[:i] + bytes([data[i] ^ (1 << bit)]) + data[i + 1:]


SSP = OPTICS_FILES[2]
OPTICS_FOUND = [
    # RecursionError: a prescription nested past the parser's depth.
    ("prescription", b"[" * 100000, "maximum recursion depth"),
    # TypeError: an SSD component without a name (", ".join of None in the message).
    ("ssp", ssp_bytes(MOUNT, ssd=SSD_TEXT.replace(b"name='mount'", b"fame='mount'")), "a component without a name"),
    # LookupError: a model description in an encoding Python has not.
    ("ssp", ssp_bytes(MOUNT, md=MD_TEXT.replace(b"encoding='UTF-8'", b"encoding='x'")), "unknown encoding"),
    # ValueError: a declared min that is not a number (the property's was "\ufeff").
    ("ssp", ssp_bytes(MOUNT, md=MD_TEXT.replace(b'min="0.0001"', b'min="x"')), "could not convert"),
    # One bit flipped in the SSP: NotImplementedError (zip version 8.4) and ValueError (a
    # negative seek), found by the property; RuntimeError (the encryption flag), zlib.error
    # (the FMU's deflated stream) and EOFError (a name's length), by the sweep below.
    ("ssp", flip(SSP, 696, 6), "NotImplementedError"), ("ssp", flip(SSP, 698, 0), "RuntimeError"),
    ("ssp", flip(SSP, 700, 3), "zlib.error"), ("ssp", flip(SSP, 29, 1), "EOFError"), ("ssp", flip(SSP, 832, 0), "negative seek"),
]


@pytest.mark.parametrize("reader,data,match", OPTICS_FOUND)
def test_what_the_properties_found_in_the_optics_readers(reader, data, match):
    with pytest.raises(OI.InputError, match=re.escape(match)):
        if reader == "prescription":
            Prescription.parse(data)
        else:
            OC.parse_params(io.BytesIO(data), ["mount.radius=1"])


def test_every_single_bit_flip_of_an_ssp_is_read_or_refused():
    # 8 × len(SSP) inputs (about 7000, a second): each gives the variables or an InputError.
    for i in range(len(SSP)):
        for bit in range(8):
            check_ssp_reader(flip(SSP, i, bit), "mount.radius=1")


def test_a_prescription_field_of_more_digits_than_str_converts_is_refused_by_name():
    # Reading the code: ValueError from str(), which refuses an int of more than 4300 digits,
    # in the message of Range.check (a prescription made in Python).
    with pytest.raises(OI.InputError, match="aperture_m an integer of 5001 digits"):
        Prescription(aperture_m=10**5000)


# ---- the bounds: no reader reads past what it accepts ----
def test_a_poses_csv_past_the_bound_is_refused_unread(tmp_path):
    big = tmp_path / "big.csv"
    with open(big, "wb") as f:
        f.truncate(P.MAX_CSV_BYTES + 1)  # sparse: nothing written
    with pytest.raises(SegmentsError, match="bytes: accepted at most"):
        P.read_csv(big)


def test_a_plan_past_the_bound_is_refused_unread(tmp_path):
    big = tmp_path / "plan.csv"
    with open(big, "wb") as f:
        f.truncate(D.MAX_PLAN_BYTES + 1)
    with pytest.raises(D.InputError, match="bytes: accepted a plan of at most"):
        D.read_plan(big)


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero")
def test_an_endless_stream_is_refused_within_a_line():
    # /dev/zero has no size and no newline: each reader stops at its longest line (or its
    # whole bound, for the prescription's JSON).
    with pytest.raises(SegmentsError, match="longer than"):
        P.read_csv("/dev/zero")
    with pytest.raises(D.InputError, match="longer than"):
        D.read_plan("/dev/zero")
    with pytest.raises(OI.InputError, match="longer than"):
        Prescription.load("/dev/zero")


def test_an_ssp_member_past_the_bound_is_refused_unread(monkeypatch):
    monkeypatch.setattr(OC, "MAX_MEMBER_BYTES", 100)
    with pytest.raises(OI.InputError, match="more than 100"):
        OC.ssp_variables(io.BytesIO(OPTICS_FILES[2]))


def test_the_float_bits_helper_tells_signed_zeros_apart():
    assert bits(-0.0) != bits(0.0) and bits([1.0, math.pi]) == struct.pack("<2d", 1.0, math.pi)


def test_the_tree_packages_are_the_ones_tested():
    for module in (P, C, D, OC):
        assert pathlib.Path(module.__file__).resolve().is_relative_to(ROOT / "python")
