"""The Python packages' output discipline (python/inchworm_output; README, "Reliability:
your files"): outputs are checked before any work, written beside their targets and
renamed only when complete; a refused or failed run leaves every file as it was and no
temporary behind. The Rust programs' is inchworm_cosim::output (tests/outputs.rs)."""
import os

import numpy as np
import pytest

from inchworm_output import OutputError, check, replacing, replacing_path
from inchworm_segments import __main__ as segments_cli
from inchworm_segments.poses import synthetic, write_csv


def names(folder):
    return sorted(p.name for p in folder.iterdir())


def test_outputs_that_would_destroy_data_are_refused_by_name(tmp_path):
    a, b, src = tmp_path / "a.csv", tmp_path / "b.csv", tmp_path / "in.ssp"
    src.write_text("system")
    with pytest.raises(OutputError, match="is also --out; two outputs would overwrite each other"):
        check({"--out": a, "--poses": tmp_path / "." / "a.csv"})
    with pytest.raises(OutputError, match="is the input"):
        check({"--out": src}, [src])
    os.link(src, b)  # a hard link to the input is the input
    with pytest.raises(OutputError, match="is the input"):
        check({"--out": b}, [src])
    with pytest.raises(OutputError, match="is a folder, not a file"):
        check({"--out": tmp_path})
    check({"--out": tmp_path / "new" / "deeper" / "a.csv", "--plot": a}, [src])
    assert (tmp_path / "new" / "deeper").is_dir(), "its folder is made"
    assert names(tmp_path) == ["b.csv", "in.ssp", "new"], "nothing else is left behind"


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a read-only folder")
def test_a_folder_that_takes_no_file_is_refused(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    with pytest.raises(OutputError, match="cannot take a new file"):
        check({"--out": ro / "a.csv"})


def test_a_failed_write_leaves_the_target_as_it_was_and_no_temporary(tmp_path):
    target = tmp_path / "run.csv"
    target.write_text("the user's rows\n")
    (tmp_path / "run.partial").write_text("a user's file with the old fixed name")
    for exc in (RuntimeError("disk full"), KeyboardInterrupt()):
        with pytest.raises(type(exc)):
            with replacing(target) as f:
                f.write("half of the new rows")
                raise exc
        assert target.read_text() == "the user's rows\n"
        assert names(tmp_path) == ["run.csv", "run.partial"]
    with replacing(target) as f:
        f.write("new\n")
        (temporary,) = [p for p in tmp_path.iterdir() if p.name not in ("run.csv", "run.partial")]
        assert temporary.name.startswith(".run.csv.") and temporary.name.endswith(".partial.csv")
        assert target.read_text() == "the user's rows\n", "replaced only when complete"
    assert target.read_text() == "new\n" and names(tmp_path) == ["run.csv", "run.partial"]


def test_a_figure_is_saved_in_its_target_s_format(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure()
    with replacing_path(tmp_path / "fig.png") as tmp:
        fig.savefig(tmp)
    plt.close(fig)
    assert (tmp_path / "fig.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert names(tmp_path) == ["fig.png"]


def test_segments_refuses_an_out_that_holds_its_poses_before_any_work(tmp_path, capsys):
    t, poses, parked = synthetic(7, duration_s=0.2, seed=5)
    out = tmp_path / "out"
    out.mkdir()
    src = out / "segments-samples.csv"  # the name of one of its outputs
    write_csv(src, t, poses, parked)
    before = src.read_bytes()
    assert segments_cli.main(["--poses", str(src), "--out", str(out), "--pupil-px", "48", "--frame-ms", "20"]) == 2
    err = capsys.readouterr().err
    assert "segments-samples.csv: is the input" in err and err.count("\n") == 1, err
    assert src.read_bytes() == before and names(out) == ["segments-samples.csv"]


def test_dask_refuses_results_over_the_plan_before_any_work(tmp_path):
    pytest.importorskip("distributed")
    from inchworm_dask import run_plan

    plan = tmp_path / "plan.csv"
    plan.write_text("run,sample,x\n0,0,1\n")
    with pytest.raises(OutputError, match="is the input"):
        run_plan(plan, tmp_path / "s.ssp", client=object(), out=plan)
    assert plan.read_text() == "run,sample,x\n0,0,1\n"
    assert np.array_equal(names(tmp_path), ["plan.csv"])


def test_optics_refuses_an_out_that_holds_its_prescription(tmp_path, capsys):
    from inchworm_optics import __main__ as optics_cli

    from conftest import DIST

    out = tmp_path / "out"
    out.mkdir()
    rx = out / "optics-prescription.json"  # the name of one of its outputs
    rx.write_text("{}")
    status = optics_cli.main(["--prescription", str(rx), "--out", str(out), "--dist", str(DIST), "--pupil", "8", "--fov", "8",
                              "--duration", "0.1", "--regulation", "0", "--held-from", "0", "--runs", "stepping"])
    err = capsys.readouterr().err
    assert status == 2 and "optics-prescription.json: is the input" in err, err
    assert rx.read_text() == "{}" and names(out) == ["optics-prescription.json"]
