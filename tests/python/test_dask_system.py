"""python/inchworm_dask.system: one SSP system split by subsystem across dask workers gives
the one-process run's CSV byte for byte; parts that do not fit together are refused."""
import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
# This tree's package, whatever version the venv holds.
sys.path.insert(0, str(ROOT / "python" / "inchworm_dask"))
from inchworm_dask import system  # noqa: E402

# INCHWORM_BIN: the binary to test, if not this tree's target/release/inchworm.
EXE = pathlib.Path(os.environ.get("INCHWORM_BIN", ROOT / "target" / "release" / "inchworm"))

PART1 = "time,a.x,a.y\n0,1,2\n0.002,1.5,2.5\n"
PART2 = "time,b.x\n0,3\n0.002,3.5\n"
SPLIT = [(1, "a.x"), (2, "b.x"), (1, "a.y")]


def test_join_takes_each_column_from_its_part_in_the_split_order():
    assert system.join_parts(SPLIT, [PART1, PART2]) == (
        "time,a.x,b.x,a.y\n0,1,3,2\n0.002,1.5,3.5,2.5\n")


def test_join_keeps_the_values_text_exactly():
    p1 = "time,a.x\n0,0.1000000000000000055511151231257827\n"
    p2 = "time,b.x\n0,-0\n"
    joined = system.join_parts([(1, "a.x"), (2, "b.x")], [p1, p2])
    assert joined == "time,a.x,b.x\n0,0.1000000000000000055511151231257827,-0\n"


@pytest.mark.parametrize("parts, split, why", [
    ([PART1, "time,b.x\n0,3\n"], SPLIT, "rows"),
    ([PART1, "time,b.x\n0,3\n0.004,3.5\n"], SPLIT, "time column"),
    ([PART1, "t,b.x\n0,3\n0.002,3.5\n"], SPLIT, "rows of t"),
    ([PART1, PART2], [(1, "a.x"), (2, "c.x")], "not in part 2"),
    ([PART1, PART2], [(3, "a.x")], "part 3 of 2"),
    ([PART1, "time,b.x\n0,3,4\n0.002,3.5\n"], SPLIT, "field count"),
    ([PART1, ""], SPLIT, "empty"),
])
def test_join_refuses_parts_that_do_not_fit(parts, split, why):
    with pytest.raises(ValueError, match=why):
        system.join_parts(split, parts)


@pytest.mark.parametrize("parts", [0, 257, 1.5, "2"])
def test_a_split_outside_the_binarys_range_is_refused_before_running(parts):
    with pytest.raises(ValueError, match="parts"):
        system.show_split("/nonexistent/inchworm", "x.ssp", parts)


def test_a_failing_binary_raises_with_its_message(tmp_path):
    assert EXE.exists(), "build the CLI first: cargo build --release"
    with pytest.raises(RuntimeError, match="exited with"):
        system.run_part(str(EXE), str(tmp_path / "missing.ssp"), 1, 2)


FMU_BUILD = ROOT / "target" / "release" / "fmu-build"


@pytest.fixture(scope="module", params=[1, 3], ids=["7 segments", "37 segments"])
def mirror(request, tmp_path_factory):
    """The seven- and 37-segment mirrors (`fmu-build segmented --rings 1`, `--rings 3`):
    seven and 37 independent subsystems."""
    assert FMU_BUILD.exists(), "build fmu-build first: cargo run --release -p fmu-build"
    assert (ROOT / "dist" / "InchwormPlant.fmu").exists(), "build dist/ first: fmu-build"
    rings = request.param
    d = tmp_path_factory.mktemp(f"mirror{rings}")
    ssp = d / "mirror.ssp"
    p = subprocess.run([str(FMU_BUILD), "segmented", "--rings", str(rings), "--seed", "3",
                        "--out", str(ssp)], capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 0, p.stderr
    return d, ssp


ARGS = ["--stop-time", "0.3"]


def test_two_dask_workers_give_the_one_process_run_byte_for_byte(mirror):
    from distributed import Client, LocalCluster

    d, ssp = mirror
    one = d / "one.csv"
    p = subprocess.run([str(EXE), "run", str(ssp), "--out", str(one), *ARGS],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    split = system.show_split(str(EXE), str(ssp), 2, ARGS)
    # Both parts record columns, and each part's are whole segments.
    assert {k for k, _ in split} == {1, 2}
    owner = {}
    for k, name in split:
        segment = name.split("_", 1)[0]
        assert owner.setdefault(segment, k) == k, f"{segment} split across parts"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        text = system.run_system(ssp, 2, client=client, inchworm=str(EXE), args=ARGS,
                                 out=d / "dask.csv")
    expected = one.read_bytes()
    assert (d / "dask.csv").read_bytes() == expected
    assert text.encode() == expected
    assert expected.count(b"\n") == 152  # the header and t = 0 to 0.3 s every 2 ms
