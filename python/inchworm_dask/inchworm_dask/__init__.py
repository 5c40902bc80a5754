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
"""
from __future__ import annotations

import json
import os
import subprocess
import tempfile
from typing import Iterable, Sequence

import pandas as pd
from inchworm_output import check, replacing

from .system import join_parts, run_part, run_system, show_split

__all__ = [
    "read_plan", "run_rows", "run_plan", "write_results",
    "show_split", "run_part", "join_parts", "run_system",
]


def read_plan(path: str | os.PathLike) -> tuple[str, list[str]]:
    """The plan's header line and its row lines (text as written, so values stay exact)."""
    with open(path, newline="") as f:
        lines = [line.strip() for line in f if line.strip()]
    if not lines or not lines[0].startswith("run,sample"):
        raise ValueError(f"{path}: not a sweep plan (header `run,sample,<parameter>,…`)")
    return lines[0], lines[1:]


def run_rows(inchworm: str, system: str, header: str, rows: Sequence[str],
             args: Sequence[str] = ()) -> list[dict]:
    """Runs plan rows through the binary on this machine; one dict per row (the JSON line).

    A row that fails (an FMU error, a value out of range) is a dict with status "failed"
    and its error; a binary that cannot run at all (missing, bad system file) raises.
    """
    fd, path = tempfile.mkstemp(prefix="inchworm-plan-", suffix=".csv")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(header + "\n" + "".join(r + "\n" for r in rows))
        cmd = [inchworm, "sweep", str(system), "--plan", path, "--json", "--jobs", "1", *args]
        p = subprocess.run(cmd, capture_output=True, text=True)
    finally:
        os.unlink(path)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} exited with {p.returncode}: {p.stderr.strip()}")
    return [json.loads(line) for line in p.stdout.splitlines() if line.startswith("{")]


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
    to `out` as CSV too if given).
    """
    from distributed import get_client

    if out is not None:  # before any work: `out` neither the plan nor the system
        check({"out": out}, [plan, system])
    client = client or get_client()
    header, rows = read_plan(plan)
    names = header.split(",")[2:]
    slices = [rows[i:i + rows_per_task] for i in range(0, len(rows), max(1, rows_per_task))]
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
