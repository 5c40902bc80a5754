"""What the package reads, checked before any work: the accepted range of every numeric
argument, the sweep plan (the rules of the binary's own plan reader, `Plan::read` in
crates/cosim/src/sweep/plan.rs, so that a plan the binary would refuse is refused before a
cluster starts), and what the binary prints or writes back (a run's JSON line, the
`--show-split` listing, a part's CSV), decoded strictly.

Two errors, both with one-line messages: `InputError` (a ValueError) for an input the
caller gave, naming it, its value and what is accepted (`--parts 0: accepted an integer,
1 ≤ value ≤ 256 parts (…)`); `BinaryError` (a RuntimeError) for a binary that failed or
printed what the package cannot read. No exception of another type leaves a decoder,
whatever the bytes, and no file is read past its bound. `InputError`, `Range` and the
bounded reading (`open_bounded`, `read_bounded`, `bounded_lines`) are `inchworm_inputs`'
(python/inchworm_inputs), the one implementation every package shares.

No dask, distributed or pandas here: the command checks its arguments before importing
them.
"""
from __future__ import annotations

import io
import json
import math
import re

from inchworm_inputs import InputError, Range, bounded_lines, open_bounded, read_bounded


class BinaryError(RuntimeError):
    """The `inchworm` binary failed, or printed or wrote what the package cannot read."""


# ---- the binary's limits (crates/cosim/src/sweep/plan.rs) ----
#: The most runs a plan may have.
MAX_RUNS = 1_000_000
#: The most swept parameters (columns) a plan may have.
MAX_PARAMETERS = 256
#: The most values (runs × parameters) a plan may hold.
MAX_VALUES = 1 << 24
#: The longest plan line read, bytes.
MAX_LINE_BYTES = 64 << 10
#: The longest parameter name, characters.
MAX_NAME_CHARS = 256
#: A split the binary accepts (`--part K/N`, `--jobs N`).
MAX_PARTS = 256
#: A run's index or sample, as the binary's `usize` reads it.
MAX_INDEX = 2**64 - 1

# ---- this package's ----
#: The largest plan file read, bytes: far above the binary's 16 Mi values of 25 characters.
MAX_PLAN_BYTES = 1 << 30
#: The largest part's CSV read back from a worker's run, bytes: every part's text is
#: gathered into one process and joined in memory.
MAX_PART_BYTES = 1 << 30

PARTS = Range(1, MAX_PARTS, integer=True, unit="parts",
              why="the splits the binary accepts: --part K/N, --jobs N")
ROWS_PER_TASK = Range(1, MAX_RUNS, integer=True, unit="rows",
                      why=f"a task's slice of the plan, at most the {MAX_RUNS} runs a plan may have")


#: A plan's run and sample (text: Range's integers are shown in full, 2^64 − 1 is long).
INDEX = "an integer, 0 ≤ value ≤ 2^64 − 1 (the binary's usize)"
#: A plan's value: the binary checks each against its FMU's declared range, row by row
#: (a row out of it is a failed row, as in a local sweep).
VALUE = Range(why="in the FMU's declared range, which the binary checks row by row: a row out of it fails")


def check_parts(parts, part=None, name="parts"):
    """`parts` (and `part` of them, 1 to `parts`) in range, or an InputError."""
    parts = PARTS.check(name, parts)
    if part is not None:
        Range(1, parts, integer=True, why=f"one of the {parts} parts").check("part", part)
    return parts


# ---- the plan ----
#: Rust's `char::is_whitespace` (Unicode White_Space), what `str::trim` strips: Python's
#: `str.strip()` strips U+001C-U+001F too, which the binary keeps.
_WHITE_SPACE = ("\t\n\x0b\x0c\r \x85\xa0\u1680\u2000\u2001\u2002\u2003\u2004\u2005\u2006\u2007\u2008\u2009"
                "\u200a\u2028\u2029\u202f\u205f\u3000")
#: A line the binary skips: ASCII white space only (`u8::is_ascii_whitespace`).
_BLANK = re.compile(rb"[ \t\n\x0c\r]*")
#: A run index or sample as Rust's `usize::from_str` takes it.
_INDEX = re.compile(r"\+?[0-9]+")
#: A finite number as Rust's `f64::from_str` takes it (inf and NaN are not finite).
_DECIMAL = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def _trim(text):
    return text.strip(_WHITE_SPACE)


def _cut(text, n=200):
    shown = text.encode("unicode_escape").decode("ascii")
    return shown if len(shown) <= n else shown[:n] + "…"


def check_name(name, what):
    """A parameter name the binary takes as a plan column (its `check_name`), or an
    InputError."""
    shown = _cut(name, 80)
    if not name:
        raise InputError(f"{what}: the parameter name is empty")
    if len(name) > MAX_NAME_CHARS:
        raise InputError(f"{what}: the parameter name `{shown}` is longer than {MAX_NAME_CHARS} characters")
    for c in name:
        # Rust's char::is_control: the Unicode category Cc (U+0000-U+001F, U+007F-U+009F).
        if c in ',"' or ord(c) < 0x20 or 0x7F <= ord(c) <= 0x9F:
            what_c = {",": "a comma", '"': "a quote"}.get(c, f"the control character U+{ord(c):04X}")
            raise InputError(f"{what}: the parameter name `{shown}` holds {what_c}: refused (it names a CSV column)")
    if name != _trim(name):
        raise InputError(f"{what}: the parameter name `{shown}` starts or ends with white space")
    if name in ("run", "sample"):
        raise InputError(f"{what}: `{name}` names a plan column of its own, not a parameter")


def _index(text):
    """A run index or sample as the binary reads it, or None."""
    if not _INDEX.fullmatch(text):
        return None
    digits = text.lstrip("+").lstrip("0") or "0"
    if len(digits) > 20:
        return None
    value = int(digits)
    return value if value <= MAX_INDEX else None


def _finite(text):
    """A finite number as the binary reads it, or None."""
    if not _DECIMAL.fullmatch(text):
        return None
    x = float(text)
    return x if math.isfinite(x) else None


def _text(line, number, name):
    try:
        return line.decode("utf-8").rstrip("\n\r")
    except UnicodeDecodeError:
        raise InputError(f"{name}: line {number}: not UTF-8 text") from None


def parse_plan(data, name="plan"):
    """(header, rows) of a sweep plan's bytes (or binary stream): its header line
    `run,sample,<parameter>,…` and its row lines, each field trimmed and the text of every
    value kept as written (so values stay exact). Refused, as the binary refuses them, with
    an InputError naming `name` and the line: text that is not UTF-8, a line longer than
    64 KiB, a header that is not `run,sample,<parameter>,…`, a parameter name the binary
    refuses or given twice, more than 256 parameters, a row of another field count, a run or
    sample that is not a whole number from 0 to 2^64 − 1, a value that is not a finite
    number, a run index twice, more than 1 000 000 rows or 2^24 values; and a file of more
    than MAX_PLAN_BYTES."""
    stream = io.BytesIO(data) if isinstance(data, (bytes, bytearray, memoryview)) else data
    # Each line cut at b"\n", at most MAX_LINE_BYTES besides it, as the binary's reader cuts them.
    lines = ((i, line) for i, line in bounded_lines(stream, name, MAX_PLAN_BYTES, MAX_LINE_BYTES)
             if not _BLANK.fullmatch(line))
    first = next(lines, None)
    if first is None:
        raise InputError(f"{name}: the plan is empty; accepted a header `run,sample,<parameter>,…` and its rows")
    head = _text(first[1], first[0], name)
    head = head[1:] if head.startswith("\ufeff") else head
    cols = [_trim(c) for c in head.split(",")]
    if len(cols) < 2 or cols[:2] != ["run", "sample"]:
        raise InputError(f"{name}: not a sweep plan: header `{_cut(head)}`: accepted `run,sample,<parameter>,…`")
    names = cols[2:]
    for i, c in enumerate(names):
        check_name(c, f"{name}: plan header")
        if c in names[:i]:
            raise InputError(f"{name}: plan header: the parameter `{c}` is a column twice")
    if len(names) > MAX_PARAMETERS:
        raise InputError(f"{name}: plan header: {len(names)} parameters, more than the {MAX_PARAMETERS} a plan "
                         "may have")
    rows, seen = [], set()
    for i, line in lines:
        text = _text(line, i, name)
        fields = [_trim(f) for f in text.split(",")]
        if len(rows) + 1 > MAX_RUNS or (len(rows) + 1) * len(names) > MAX_VALUES:
            raise InputError(f"{name}: line {i}: more than the {MAX_RUNS} runs or {MAX_VALUES} values a plan may "
                             "hold")
        if len(fields) != len(cols):
            raise InputError(f"{name}: line {i}: `{_cut(text)}`: {len(fields)} fields: accepted {len(cols)}, as "
                             "the header")
        for col, v in zip(cols[:2], fields[:2]):
            if _index(v) is None:
                raise InputError(f"{name}: line {i}: {col} {_cut(v, 40)}: accepted {INDEX}")
        run = _index(fields[0])
        if run in seen:
            raise InputError(f"{name}: line {i}: the run index {run} is given twice")
        seen.add(run)
        for n, v in zip(names, fields[2:]):
            if _finite(v) is None:
                raise InputError(f"{name}: line {i}: {n} {_cut(v, 40) or '(empty)'}: accepted {VALUE} ({VALUE.why})")
        rows.append(",".join(fields))
    return ",".join(cols), rows


def read_plan(path):
    """`parse_plan` of the file at `path` (at most MAX_PLAN_BYTES; an unreadable file is
    the OSError of `open`)."""
    with open_bounded(path, MAX_PLAN_BYTES, "a plan") as f:
        return parse_plan(f, str(path))


def plan_values(header, rows):
    """[(run, sample, [value])] of a plan's (header, rows) as `parse_plan` returns them."""
    out = []
    for r in rows:
        fields = r.split(",")
        out.append((_index(fields[0]), _index(fields[1]), [float(v) for v in fields[2:]]))
    return out


# ---- what the binary prints ----
class _IntText(str):
    """A JSON integer's text: kept as written (json's int() would lose -0 and refuse more
    than 4300 digits), read as the field wants it."""


class _Constant(str):
    """NaN, Infinity or -Infinity, which Python's JSON reader takes and JSON has not: kept
    apart from strings, so that neither a number nor a text field takes one."""


def _json_number(v):
    """A JSON number's value as a float, or None if `v` is not a number or not finite."""
    if isinstance(v, _IntText):
        x = float(v)
    elif isinstance(v, float):
        x = v
    else:
        return None
    return x if math.isfinite(x) else None


def _json_index(v):
    return _index(v) if isinstance(v, _IntText) and not v.startswith("+") else None


def parse_records(text, names, where="inchworm sweep --json"):
    """[record] of the JSON lines the binary prints (`inchworm sweep --plan … --json`), one
    a run: {"run", "sample" (whole numbers), "params" (each of `names` a finite number),
    "metrics" (name → a finite number or None, the same names in the same order on every
    line), "status" ("ok" or "failed"), "error" (None or text)}; lines that do not start
    with `{` are not runs and are passed over. A `BinaryError` naming `where` and the line
    for any other line; `names` (a plan's parameters) an InputError if they are not texts."""
    names = list(names)
    if not all(type(n) is str for n in names):
        raise InputError(f"names {names!r:.80}: accepted the plan's parameter names, texts")
    records, metric_names = [], None
    for number, line in enumerate(text.split("\n"), start=1):
        line = line.rstrip("\r")
        if not line.startswith("{"):
            continue

        def bad(why):
            return BinaryError(f"{where}: line {number}: {why}: `{_cut(line)}`")

        try:
            r = json.loads(line, parse_int=_IntText, parse_constant=_Constant)
        except (ValueError, RecursionError):
            raise bad("not a JSON line") from None
        if not isinstance(r, dict) or set(r) != {"run", "sample", "params", "metrics", "status", "error"}:
            raise bad("not a run's JSON: accepted the keys run, sample, params, metrics, status, error")
        run, sample = _json_index(r["run"]), _json_index(r["sample"])
        if run is None or sample is None:
            raise bad("run and sample: accepted whole numbers, 0 ≤ value ≤ 2^64 − 1")
        params, metrics = r["params"], r["metrics"]
        if not isinstance(params, dict) or set(params) != set(names):
            raise bad(f"params: accepted the plan's parameters {list(names)}")
        values = {n: _json_number(params[n]) for n in names}
        if any(v is None for v in values.values()):
            raise bad("params: accepted finite numbers")
        if not isinstance(metrics, dict):
            raise bad("metrics: accepted an object of metric values")
        got = {}
        for m, v in metrics.items():
            got[m] = None if v is None else _json_number(v)
            if v is not None and got[m] is None:
                raise bad(f"metric {_cut(m, 80)}: accepted a finite number or null")
        if metric_names is None:
            metric_names = list(got)
        elif list(got) != metric_names:
            raise bad(f"metrics {list(got)}: the lines before have {metric_names}")
        text_error = type(r["error"]) is str  # not an _IntText or a _Constant
        if type(r["status"]) is not str or r["status"] not in ("ok", "failed") or not (r["error"] is None or text_error):
            raise bad("status: accepted ok or failed, error null or text")
        records.append({"run": run, "sample": sample, "params": values, "metrics": got,
                        "status": r["status"], "error": r["error"]})
    return records


_SPLIT_LINE = re.compile(r"([0-9]{1,3})\t(.+)")


def parse_split(text, parts, where="inchworm run --show-split"):
    """[(part, column)] of what `--show-split` prints: one line a recorded column, in the
    run's order, `K<TAB>NAME` with K from 1 to `parts` (ASCII digits) and each name once.
    A `BinaryError` naming `where` and the line for any other line, or for none; `parts`
    as `check_parts` takes it (an InputError)."""
    parts = check_parts(parts)
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    split, seen = [], set()
    for number, line in enumerate(lines, start=1):
        line = line.rstrip("\r")
        m = _SPLIT_LINE.fullmatch(line)
        k = int(m.group(1)) if m else 0
        if not m or not 1 <= k <= parts or "," in m.group(2) or m.group(2) in seen:
            raise BinaryError(f"{where}: line {number}: accepted `K<TAB>NAME`, K from 1 to {parts}, each name once "
                              f"and without a comma: `{_cut(line)}`")
        seen.add(m.group(2))
        split.append((k, m.group(2)))
    if not split:
        raise BinaryError(f"{where}: listed no column")
    return split


def read_part(path, where):
    """A part's CSV, as the binary wrote it at `path`: UTF-8 text of at most MAX_PART_BYTES,
    or a `BinaryError` naming `where`."""
    try:
        data = read_bounded(path, MAX_PART_BYTES)
    except InputError:
        raise BinaryError(f"{where}: its CSV is longer than {MAX_PART_BYTES} bytes, the most a part may send "
                          "back") from None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise BinaryError(f"{where}: its CSV is not UTF-8 text") from None
