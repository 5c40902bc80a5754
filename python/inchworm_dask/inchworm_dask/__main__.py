"""`python -m inchworm_dask --scheduler tcp://HOST:8786 --system S.ssp --plan plan.csv
--out results.csv -- <inchworm sweep options>`: a sweep plan on a running dask scheduler (or
a LocalCluster without --scheduler); `--parts N` instead of `--plan`: the one system split
by subsystem into N parts, one a task (`-- <inchworm run options>`)."""
from __future__ import annotations

import argparse
import sys

from . import run_plan
from .system import run_system


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    extra: list[str] = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    ap = argparse.ArgumentParser(prog="inchworm-dask", description=__doc__)
    ap.add_argument("--scheduler", help="address of a dask scheduler (default: a LocalCluster)")
    ap.add_argument("--system", required=True, help="the .ssp or .fmu, at this path on every worker")
    what = ap.add_mutually_exclusive_group(required=True)
    what.add_argument("--plan", help="a plan.csv from `inchworm sweep --plan-only`")
    what.add_argument("--parts", type=int, help="run the system in this many parts (its subsystems)")
    ap.add_argument("--inchworm", default="inchworm", help="the binary, on every worker")
    ap.add_argument("--rows-per-task", type=int, default=10)
    ap.add_argument("--out", default="results.csv")
    a = ap.parse_args(argv)
    from distributed import Client, LocalCluster

    if a.scheduler:
        client = Client(a.scheduler)
    else:
        client = Client(LocalCluster())
    with client:
        if a.parts is not None:
            text = run_system(a.system, a.parts, client=client, inchworm=a.inchworm, args=extra,
                              out=a.out)
            print(f"{text.count(chr(10)) - 1} rows in {a.parts} parts; wrote {a.out}")
            return 0
        df = run_plan(a.plan, a.system, client=client, inchworm=a.inchworm, args=extra,
                      rows_per_task=a.rows_per_task, out=a.out)
    failed = int((df["status"] != "ok").sum())
    print(f"{len(df)} runs, {failed} failed; wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
