"""Run an `inchworm sweep` plan on a dask.distributed cluster (and, in `system`, one system
split by subsystem across the cluster's workers).

The plan is data (`inchworm sweep SYSTEM --plan-only` writes it: `run,sample,<parameter>,…`).
Each dask task takes a slice of its rows, writes them as a small plan file on the worker
and runs them through the `inchworm` binary (`inchworm sweep SYSTEM --plan SLICE --json`),
which loads the system once per task and resets it between rows; every row comes back as
one JSON line. The rows are gathered into a pandas DataFrame in run order, with the
columns of the local `results.csv`: run, sample, the parameters, the metrics, status and
error.

Every worker needs the `inchworm` binary and the system file (and any `--input` CSV) at the
paths given, e.g. on a shared file system or installed at the same place on every node.

Every argument, the plan and whatever the binary prints back are checked (`inputs`): a bad
input is an `InputError` (a ValueError) before any work, a binary that fails or prints what
cannot be read a `BinaryError` (a RuntimeError).
"""
from __future__ import annotations

import os
import subprocess
import tempfile
from typing import Iterable, Sequence

import pandas as pd
from inchworm_output import check, replacing

from .inputs import (ROWS_PER_TASK, BinaryError, InputError, parse_plan, parse_records, plan_values,
                     read_plan)
from .system import join_parts, run_part, run_system, show_split

__all__ = [
    "read_plan", "parse_plan", "run_rows", "run_plan", "write_results",
    "show_split", "run_part", "join_parts", "run_system", "InputError", "BinaryError",
]


def _strings(what, values):
    values = list(values)
    if not all(isinstance(v, str) for v in values):
        raise InputError(f"{what}: accepted a sequence of strings")
    return values


def run_rows(inchworm: str, system: str, header: str, rows: Sequence[str],
             args: Sequence[str] = ()) -> list[dict]:
    """Runs plan rows through the binary on this machine; one dict per row (the JSON line,
    decoded and checked by `inputs.parse_records`).

    The rows are checked as `parse_plan` checks a plan first (an InputError). A row that
    fails (an FMU error, a value out of range) is a dict with status "failed" and its error;
    a binary that cannot run at all (missing, bad system file), or prints what is not one
    run's JSON line for each row, raises a `BinaryError`.
    """
    header, rows = parse_plan("\n".join(_strings("plan rows", [header, *rows])).encode("utf-8"), "plan rows")
    args = _strings("args", args)
    fd, path = tempfile.mkstemp(prefix="inchworm-plan-", suffix=".csv")
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
            f.write(header + "\n" + "".join(r + "\n" for r in rows))
        cmd = [inchworm, "sweep", str(system), "--plan", path, "--json", "--jobs", "1", *args]
        p = subprocess.run(cmd, capture_output=True)
    finally:
        os.unlink(path)
    where = " ".join(cmd)
    if p.returncode != 0:
        raise BinaryError(f"{where} exited with {p.returncode}: {p.stderr.decode('utf-8', 'replace').strip()}")
    try:
        out = p.stdout.decode("utf-8")
    except UnicodeDecodeError:
        raise BinaryError(f"{where}: printed what is not UTF-8 text") from None
    records = parse_records(out, header.split(",")[2:], where)
    want = sorted(run for run, _, _ in plan_values(header, rows))
    if sorted(r["run"] for r in records) != want:
        raise BinaryError(f"{where}: printed runs {sorted(r['run'] for r in records)[:10]}…, not the rows' "
                          f"{want[:10]}…")
    return records


def _frame(records: Iterable[dict], names: Sequence[str]) -> pd.DataFrame:
    rows = []
    metric_names: list[str] = []
    for r in records:
        if not metric_names:
            metric_names = list(r["metrics"])
        row = {"run": int(r["run"]), "sample": int(r["sample"])}
        for n in names:
            row[n] = float(r["params"][n])
        for m in metric_names:
            v = r["metrics"].get(m)
            row[m] = float("nan") if v is None else float(v)
        row["status"] = r["status"]
        row["error"] = r["error"] if r["error"] is not None else ""
        rows.append(row)
    cols = ["run", "sample", *names, *metric_names, "status", "error"]
    return pd.DataFrame(rows, columns=cols).sort_values("run", kind="stable").reset_index(drop=True)


def run_plan(plan: str | os.PathLike, system: str | os.PathLike, *, client=None,
             inchworm: str = "inchworm", args: Sequence[str] = (), rows_per_task: int = 10,
             out: str | os.PathLike | None = None) -> pd.DataFrame:
    """Runs every row of `plan` on the dask cluster of `client` (default: the current one).

    `args` are the `inchworm sweep` options every run shares (`--input`, `--parameter-set`,
    `--param`, `--metric`, `--stop-time`, …), exactly as for a local sweep. The rows go out
    in slices of `rows_per_task`; the result is the results table as a DataFrame (written
    to `out` as CSV too if given). Before any work (and before the cluster is asked for):
    `out` neither the plan nor the system, the plan read and checked (`read_plan`),
    `rows_per_task` in its range.
    """
    from distributed import get_client

    if out is not None:  # before any work: `out` neither the plan nor the system
        check({"out": out}, [plan, system])
    header, rows = read_plan(plan)
    rows_per_task = ROWS_PER_TASK.check("rows_per_task", rows_per_task)
    args = _strings("args", args)
    client = client or get_client()
    names = header.split(",")[2:]
    slices = [rows[i:i + rows_per_task] for i in range(0, len(rows), rows_per_task)]
    futures = client.map(run_rows, [inchworm] * len(slices), [str(system)] * len(slices),
                         [header] * len(slices), slices, [list(args)] * len(slices), pure=False)
    records = [r for chunk in client.gather(futures) for r in chunk]
    df = _frame(records, names)
    if out is not None:
        write_results(df, out)
    return df


def write_results(df: pd.DataFrame, path: str | os.PathLike) -> None:
    """The results table as CSV, one row per run, floats in their shortest exact text;
    written beside `path` and renamed over it when complete."""
    with replacing(path) as f:
        df.to_csv(f, index=False, float_format=None)
