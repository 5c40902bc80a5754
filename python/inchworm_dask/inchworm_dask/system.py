"""Run one SSP system too large for one process, split by subsystem across dask workers.

`inchworm run SYSTEM --part K/N` runs part K of the N parts that `--jobs N` splits the
system into (its independent subsystems: the connected components of its connections,
dealt into N parts) and records the columns that part owns; `--show-split` says, for every
column of the whole run in order, which part records it. Each dask task runs one part
through the binary and returns its CSV text; the parts' rows are joined column by column in
the whole run's order. The parts share nothing while they run (no connection crosses a
part), and every part steps on the same time grid, so the joined table is the one-process
run's byte for byte: the values are joined as the text the binary wrote, never parsed.

Every worker needs the `inchworm` binary and the system file at the paths given.
"""
from __future__ import annotations

import os
import subprocess
import tempfile
from typing import Sequence
from inchworm_output import check, replacing

__all__ = ["show_split", "run_part", "join_parts", "run_system"]

# A split the binary accepts (`--part K/N`, `--jobs N`).
MAX_PARTS = 256


def _check_parts(parts: int) -> None:
    if not isinstance(parts, int) or not 1 <= parts <= MAX_PARTS:
        raise ValueError(f"parts: give a whole number from 1 to {MAX_PARTS}, not {parts!r}")


def _run(cmd: Sequence[str]) -> str:
    p = subprocess.run(list(cmd), capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} exited with {p.returncode}: {p.stderr.strip()}")
    return p.stdout


def show_split(inchworm: str, system: str, parts: int, args: Sequence[str] = ()) -> list[tuple[int, str]]:
    """Every recorded column of the whole run, in order, with the part (1 to `parts`) that
    records it."""
    _check_parts(parts)
    out = _run([inchworm, "run", str(system), "--part", f"1/{parts}", "--show-split", *args])
    split = []
    for line in out.splitlines():
        k, sep, name = line.partition("\t")
        if not sep or not k.isdigit() or not 1 <= int(k) <= parts:
            raise RuntimeError(f"--show-split printed an unexpected line: {line!r}")
        split.append((int(k), name))
    if not split:
        raise RuntimeError(f"{system}: --show-split listed no column")
    return split


def run_part(inchworm: str, system: str, part: int, parts: int, args: Sequence[str] = ()) -> str:
    """Part `part` (1 to `parts`) of the system run on this machine: its CSV, as written."""
    _check_parts(parts)
    if not 1 <= part <= parts:
        raise ValueError(f"part {part} is not one of 1 to {parts}")
    fd, path = tempfile.mkstemp(prefix=f"inchworm-part{part}-", suffix=".csv")
    os.close(fd)
    try:
        _run([inchworm, "run", str(system), "--part", f"{part}/{parts}", "--out", path, *args])
        with open(path, newline="") as f:
            return f.read()
    finally:
        os.unlink(path)


def join_parts(split: Sequence[tuple[int, str]], texts: Sequence[str]) -> str:
    """The whole run's CSV from its parts' (`texts[k - 1]` is part k's): the first column
    (time) from part 1, each other column from the part `split` gives it, in `split`'s
    order. Refuses parts whose columns or time grids disagree with the split."""
    tables = []
    for k, text in enumerate(texts, start=1):
        lines = text.splitlines()
        if not lines:
            raise ValueError(f"part {k}: empty CSV")
        header = lines[0].split(",")
        rows = [line.split(",") for line in lines[1:]]
        if any(len(r) != len(header) for r in rows):
            raise ValueError(f"part {k}: a row's field count differs from its header's")
        tables.append((header, rows))
    time_name = tables[0][0][0]
    n_rows = len(tables[0][1])
    where = []
    for k, name in split:
        if not 1 <= k <= len(tables):
            raise ValueError(f"column {name}: part {k} of {len(tables)}")
        header, _ = tables[k - 1]
        if name not in header[1:]:
            raise ValueError(f"column {name}: not in part {k}'s CSV")
        where.append((k - 1, header.index(name)))
    for k, (header, rows) in enumerate(tables, start=1):
        if header[0] != time_name or len(rows) != n_rows:
            raise ValueError(f"part {k}: {len(rows)} rows of {header[0]}, part 1 {n_rows} of {time_name}")
        if any(r[0] != t[0] for r, t in zip(rows, tables[0][1])):
            raise ValueError(f"part {k}: its time column differs from part 1's")
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
