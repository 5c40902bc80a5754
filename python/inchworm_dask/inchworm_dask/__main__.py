"""`python -m inchworm_dask --scheduler tcp://HOST:8786 --system S.ssp --plan plan.csv
--out results.csv -- <inchworm sweep options>`: a sweep plan on a running dask scheduler (or
a LocalCluster without --scheduler); `--parts N` instead of `--plan`: the one system split
by subsystem into N parts, one a task (`-- <inchworm run options>`).

Every argument and the plan are checked before the cluster is started or reached: a
refusal is one line on stderr and exit status 2; a binary that fails, a file that cannot be
read or a cluster that cannot be reached, one line and exit status 1."""
from __future__ import annotations

import argparse
import sys

from inchworm_inputs import command
from inchworm_output import OutputError, check

from .inputs import PARTS, ROWS_PER_TASK, BinaryError, InputError, read_plan

PROG = "inchworm-dask"


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        # One line, as every other refusal (argparse would print the usage first and exit 2).
        raise InputError(f"{message} (see --help)")


def parse_args(argv):
    ap = _Parser(prog=PROG, description=__doc__)
    ap.add_argument("--scheduler", help="address of a dask scheduler (default: a LocalCluster)")
    ap.add_argument("--system", required=True, help="the .ssp or .fmu, at this path on every worker")
    what = ap.add_mutually_exclusive_group(required=True)
    what.add_argument("--plan", help="a plan.csv from `inchworm sweep --plan-only`")
    what.add_argument("--parts", type=int, help=f"run the system in this many parts (its subsystems), {PARTS}")
    ap.add_argument("--inchworm", default="inchworm", help="the binary, on every worker")
    ap.add_argument("--rows-per-task", type=int, default=10, help=f"plan rows per dask task, {ROWS_PER_TASK}")
    ap.add_argument("--out", default="results.csv")
    return ap.parse_args(argv)


def main(argv=None) -> int:
    return command(PROG, lambda: _main(list(sys.argv[1:] if argv is None else argv)),
                   refused=(InputError, OutputError), failed=(BinaryError, OSError))


def _main(argv: list[str]) -> int:
    extra: list[str] = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    a = parse_args(argv)
    # Before the cluster: every number in its range, the plan read and checked, the output
    # neither an input nor a folder.
    ROWS_PER_TASK.check("--rows-per-task", a.rows_per_task)
    if a.parts is not None:
        PARTS.check("--parts", a.parts)
        check({"--out": a.out}, [a.system])
    else:
        read_plan(a.plan)
        check({"--out": a.out}, [a.plan, a.system])

    from distributed import Client, LocalCluster

    from . import run_plan
    from .system import run_system

    client = Client(a.scheduler) if a.scheduler else Client(LocalCluster())
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
