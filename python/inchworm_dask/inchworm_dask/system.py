"""Run one SSP system too large for one process, split by subsystem across dask workers.

`inchworm run SYSTEM --part K/N` runs part K of the N parts that `--jobs N` splits the
system into (its independent subsystems: the connected components of its connections,
dealt into N parts) and records the columns that part owns; `--show-split` says, for every
column of the whole run in order, which part records it. Each dask task runs one part
through the binary and returns its CSV text; the parts' rows are joined column by column in
the whole run's order. The parts share nothing while they run (no connection crosses a
part), and every part steps on the same time grid, so the joined table is the one-process
run's byte for byte: the values are joined as the text the binary wrote, never parsed.

Every worker needs the `inchworm` binary and the system file at the paths given. The
split, the parts' CSVs and every argument are checked (`inputs`): an `InputError` for an
argument, a `BinaryError` for a binary that fails or prints what cannot be read.
"""
from __future__ import annotations

import os
import subprocess
import tempfile
from typing import Sequence
from inchworm_output import check, replacing

from .inputs import MAX_PART_BYTES, MAX_PARTS, BinaryError, InputError, check_parts, parse_split, read_part

__all__ = ["show_split", "run_part", "join_parts", "run_system", "MAX_PARTS"]


def _run(cmd: Sequence[str]) -> str:
    p = subprocess.run(list(cmd), capture_output=True)
    if p.returncode != 0:
        raise BinaryError(f"{' '.join(cmd)} exited with {p.returncode}: {p.stderr.decode('utf-8', 'replace').strip()}")
    try:
        return p.stdout.decode("utf-8")
    except UnicodeDecodeError:
        raise BinaryError(f"{' '.join(cmd)}: printed what is not UTF-8 text") from None


def _args(args):
    args = list(args)
    if not all(isinstance(a, str) for a in args):
        raise InputError("args: accepted a sequence of strings")
    return args


def show_split(inchworm: str, system: str, parts: int, args: Sequence[str] = ()) -> list[tuple[int, str]]:
    """Every recorded column of the whole run, in order, with the part (1 to `parts`) that
    records it (`inputs.parse_split` decodes what the binary prints)."""
    parts = check_parts(parts)
    cmd = [inchworm, "run", str(system), "--part", f"1/{parts}", "--show-split", *_args(args)]
    return parse_split(_run(cmd), parts, f"{system}: --show-split")


def run_part(inchworm: str, system: str, part: int, parts: int, args: Sequence[str] = ()) -> str:
    """Part `part` (1 to `parts`) of the system run on this machine: its CSV, as written."""
    parts = check_parts(parts, part)
    args = _args(args)
    fd, path = tempfile.mkstemp(prefix=f"inchworm-part{part}-", suffix=".csv")
    os.close(fd)
    try:
        _run([inchworm, "run", str(system), "--part", f"{part}/{parts}", "--out", path, *args])
        return read_part(path, f"{system}: part {part}/{parts}")
    finally:
        os.unlink(path)


def _table(k, text):
    """(header, rows) of part k's CSV text: lines cut at newlines (a carriage return
    before one dropped), fields at commas, as the binary writes them (no quoting)."""
    if not isinstance(text, str):
        raise InputError(f"part {k}: accepted its CSV as text, not {type(text).__name__}")
    if len(text) > MAX_PART_BYTES:
        raise InputError(f"part {k}: longer than {MAX_PART_BYTES} characters")
    lines = text.split("\n")
    if lines[-1] == "":
        lines.pop()
    lines = [line[:-1] if line.endswith("\r") else line for line in lines]
    if not lines:
        raise InputError(f"part {k}: empty CSV")
    header = lines[0].split(",")
    if len(set(header)) != len(header):
        raise InputError(f"part {k}: a column name is in its header twice")
    rows = [line.split(",") for line in lines[1:]]
    if any(len(r) != len(header) for r in rows):
        raise InputError(f"part {k}: a row's field count differs from its header's")
    return header, rows


def join_parts(split: Sequence[tuple[int, str]], texts: Sequence[str]) -> str:
    """The whole run's CSV from its parts' (`texts[k - 1]` is part k's): the first column
    (time) from part 1, each other column from the part `split` gives it, in `split`'s
    order. Refuses (an InputError) parts whose columns or time grids disagree with the
    split, and a split that is not [(part, column name)]."""
    texts = list(texts)
    if not 1 <= len(texts) <= MAX_PARTS:
        raise InputError(f"{len(texts)} parts: accepted 1 to {MAX_PARTS} parts' CSVs")
    tables = [_table(k, text) for k, text in enumerate(texts, start=1)]
    time_name = tables[0][0][0]
    n_rows = len(tables[0][1])
    where = []
    for entry in split:
        if (not isinstance(entry, (tuple, list)) or len(entry) != 2 or isinstance(entry[0], bool)
                or not isinstance(entry[0], int) or not isinstance(entry[1], str)):
            raise InputError(f"split entry {entry!r:.80}: accepted (part, column name)")
        k, name = entry
        if not 1 <= k <= len(tables):
            raise InputError(f"column {name}: part {k} of {len(tables)}")
        header, _ = tables[k - 1]
        if name not in header[1:]:
            raise InputError(f"column {name}: not in part {k}'s CSV")
        where.append((k - 1, header.index(name, 1)))
    for k, (header, rows) in enumerate(tables, start=1):
        if header[0] != time_name or len(rows) != n_rows:
            raise InputError(f"part {k}: {len(rows)} rows of {header[0]}, part 1 {n_rows} of {time_name}")
        if any(r[0] != t[0] for r, t in zip(rows, tables[0][1])):
            raise InputError(f"part {k}: its time column differs from part 1's")
    out = [",".join([time_name, *(name for _, name in split)])]
    for i in range(n_rows):
        out.append(",".join([tables[0][1][i][0], *(tables[p][1][i][c] for p, c in where)]))
    return "\n".join(out) + "\n"


def run_system(system: str | os.PathLike, parts: int, *, client=None, inchworm: str = "inchworm",
               args: Sequence[str] = (), out: str | os.PathLike | None = None) -> str:
    """The system run in `parts` parts on the dask cluster of `client` (default: the
    current one); `args` are `inchworm run` options every part shares (`--stop-time`,
    `--param`, `--output`, …). Returns the joined CSV text (written to `out` if given)."""
    from distributed import get_client

    parts = check_parts(parts)
    args = _args(args)
    if out is not None:  # before any work: `out` is not the system
        check({"out": out}, [system])
    client = client or get_client()
    split = show_split(inchworm, str(system), parts, args)
    futures = client.map(run_part, [inchworm] * parts, [str(system)] * parts,
                         range(1, parts + 1), [parts] * parts, [list(args)] * parts, pure=False)
    text = join_parts(split, client.gather(futures))
    if out is not None:
        with replacing(out) as f:
            f.write(text)
    return text
