"""python/inchworm_dask: a 40-row sweep plan run on a dask.distributed LocalCluster (2
workers) gives the table the local `inchworm sweep` gives, row for row and bit for bit,
failed rows included."""
import json
import math
import os
import pathlib
import subprocess
import sys

import pandas as pd
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
# This tree's package, whatever version the venv holds.
sys.path.insert(0, str(ROOT / "python" / "inchworm_dask"))
import inchworm_dask  # noqa: E402

# INCHWORM_BIN: the binary to test, if not this tree's target/release/inchworm.
EXE = pathlib.Path(os.environ.get("INCHWORM_BIN", ROOT / "target" / "release" / "inchworm"))
SSP = ROOT / "dist" / "InchwormSystemOpen.ssp"
METRICS = ["settle:1e-6", "rms:6:10", "disturbance", "slips", "max:plant.runner_position"]


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    assert EXE.exists(), "build the CLI first: cargo build --release"
    assert SSP.exists(), "build the SSP first: cargo run --release -p fmu-build"
    d = tmp_path_factory.mktemp("sweep")
    ref = d / "ref.csv"
    ref.write_text("time,reference\n0,100e-6\n")
    args = ["--input", str(ref), "--parameter-set", "full-control"]
    for m in METRICS:
        args += ["--metric", m]
    p = subprocess.run([str(EXE), "sweep", str(SSP), "--plan-only", "--out", str(d),
                        "--sample", "plant.T_em=normal(8.8,0.22)",
                        "--sample", "plant.F_d0=uniform(157.5,192.5)",
                        "--sample", "plant.k_p=normal(3e7,7.5e5)",
                        "--samples", "40", "--seed", "11"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    plan = d / "plan.csv"
    lines = plan.read_text().splitlines()
    assert len(lines) == 41 and lines[0] == "run,sample,plant.T_em,plant.F_d0,plant.k_p"
    # The plan is data: one row edited by hand to a T_em below its declared minimum.
    f = lines[18].split(",")
    f[2] = "-1"
    lines[18] = ",".join(f)
    plan.write_text("\n".join(lines) + "\n")
    local = subprocess.run([str(EXE), "sweep", str(SSP), "--plan", str(plan), "--no-plots",
                            "--jobs", "2", "--out", str(d / "local"), *args],
                           capture_output=True, text=True)
    assert local.returncode == 0, local.stderr
    return d, plan, args


def test_dask_table_equals_the_local_sweep_row_for_row(setup):
    from distributed import Client, LocalCluster

    d, plan, args = setup
    expected = pd.read_csv(d / "local" / "results.csv", float_precision="round_trip")

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        df = inchworm_dask.run_plan(plan, SSP, client=client, inchworm=str(EXE), args=args,
                                    rows_per_task=7, out=d / "dask.csv")
    written = pd.read_csv(d / "dask.csv", float_precision="round_trip")

    cols = ["run", "sample", "plant.T_em", "plant.F_d0", "plant.k_p", *METRICS, "status", "error"]
    assert list(expected.columns) == cols
    assert list(df.columns) == cols and list(written.columns) == cols
    assert len(expected) == len(df) == len(written) == 40
    assert list(expected["run"]) == list(range(40)) == list(df["run"])
    # An empty error field reads as NaN: compare errors as text.
    for t in (expected, df, written):
        t["error"] = t["error"].fillna("")
    for table in (df, written):
        for c in cols:
            for i, (a, b) in enumerate(zip(expected[c], table[c])):
                if isinstance(a, float) and math.isnan(a):
                    assert isinstance(b, float) and math.isnan(b), f"{c} row {i}: {a} vs {b}"
                elif c in ("status", "error"):
                    assert a == b, f"{c} row {i}: {a!r} vs {b!r}"
                else:
                    assert float(a) == float(b), f"{c} row {i}: {a!r} vs {b!r}"

    # The numbers themselves: one failed row, with its reason; 39 that settle near Fig. 5's
    # 0.788 s, none slipping, each disturbance estimate near its nominal 4.66 µm.
    failed = df[df["status"] == "failed"]
    assert list(failed["run"]) == [17]
    assert failed["error"].iloc[0] == "parameter plant.T_em = -1 is outside its range [0.001, 1000]"
    ok = df[df["status"] == "ok"]
    assert len(ok) == 39
    assert ok["settle:1e-6"].between(0.3, 6.0).all()
    assert (ok["slips"] == 0).all()
    assert ok["disturbance"].between(3.5e-6, 6e-6).all()
    assert ok["max:plant.runner_position"].between(100e-6, 115e-6).all()


def test_a_row_runs_alone_as_one_json_line(setup):
    d, plan, args = setup
    p = subprocess.run([str(EXE), "sweep", str(SSP), "--plan", str(plan), "--row", "3", *args],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    lines = p.stdout.splitlines()
    assert len(lines) == 1
    r = json.loads(lines[0])
    assert (r["run"], r["sample"], r["status"], r["error"]) == (3, 3, "ok", None)
    assert list(r["metrics"]) == METRICS
    # Alone, on a freshly loaded system, it gives what it gave in the sweep after resets.
    expected = pd.read_csv(d / "local" / "results.csv", float_precision="round_trip").iloc[3]
    for m in METRICS:
        assert float(r["metrics"][m]) == float(expected[m]), m
    assert r["params"]["plant.T_em"] == float(expected["plant.T_em"])


def test_the_closed_system_sweeps_with_the_default_and_loop_metrics(tmp_path):
    """dist/InchwormSystem.ssp has no system input: its reference is the output of its
    reference component, and the loop metrics (the default settle among them) read it there.
    Each row is the open system's run of the same step (tests/sweep.rs holds the bits)."""
    closed = ROOT / "dist" / "InchwormSystem.ssp"
    assert closed.exists(), "build the SSP first: cargo run --release -p fmu-build"
    base = [str(EXE), "sweep", "--parameter-set", "full-control", "--grid", "plant.T_em=8.8;9.2", "--json"]

    def runs(*args):
        p = subprocess.run(base + list(args), capture_output=True, text=True, timeout=600)
        assert p.returncode == 0, p.stderr
        return [json.loads(line) for line in p.stdout.splitlines()]

    default = runs(str(closed))
    assert [r["status"] for r in default] == ["ok", "ok"], default
    assert default[0]["metrics"]["settle:1e-6"] == pytest.approx(0.788, abs=1e-9)
    loop = runs(str(closed), "--metric", "settle:1e-6", "--metric", "rms:6:10")
    ref = tmp_path / "ref.csv"
    ref.write_text("time,reference\n0,100e-6\n")
    open_runs = runs(str(SSP), "--input", str(ref), "--metric", "settle:1e-6", "--metric", "rms:6:10")
    assert [r["metrics"] for r in loop] == [r["metrics"] for r in open_runs]
    assert loop[0]["metrics"]["rms:6:10"] == pytest.approx(3.027e-9, abs=5e-13)
    assert loop[0]["metrics"] != loop[1]["metrics"]
