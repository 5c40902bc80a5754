"""`python -m inchworm_segments.compare NAME=DIR …`: runs of the command side by side (the
co-phasing scenario's controllers, scripts/cophase.sh): each DIR's segments-summary.csv,
segments-samples.csv and segments-frames.csv into one table (printed as Markdown and
written as cophase-table.csv) and one figure of co-phasing error and frame contrast
against time (cophase-timeseries.png, its CSV cophase-timeseries.csv)."""
import argparse
import csv
import pathlib
import sys
from inchworm_output import replacing, replacing_path

#: The table's rows: (summary name, label, format).
ROWS = (
    ("cophasing_rms_regulation_parked_nm", "co-phasing RMS, parked samples (nm)", ".3g"),
    ("cophasing_rms_regulation_nm", "co-phasing RMS, every sample (nm)", ".3g"),
    ("contrast_mean_regulation_frames", "mean dark-zone contrast, regulation frames", ".2e"),
    ("strehl_mean_regulation", "Strehl ratio, mean over regulation", ".6f"),
    ("regulation_parked_samples", "parked samples of regulation", "d"),
    ("regulation_samples", "samples of regulation", "d"),
    ("cophasing_max_nm", "co-phasing error at worst (nm)", ".4g"),
)


def _read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def summary(folder):
    """name → value (float, or None where empty) of a run's segments-summary.csv."""
    return {r["name"]: (float(r["value"]) if r["value"] != "" else None)
            for r in _read(pathlib.Path(folder) / "segments-summary.csv")}


def table(runs):
    """[(label, [value text per run])] of `runs` [(name, summary)]."""
    out = []
    for key, label, fmt in ROWS:
        cells = []
        for _, s in runs:
            v = s.get(key)
            cells.append("—" if v is None else format(int(v) if fmt == "d" else v, fmt))
        out.append((label, cells))
    return out


def markdown(runs, regulation_from_s):
    rows = table(runs)
    head = f"| from {regulation_from_s:g} s to the end | " + " | ".join(n for n, _ in runs) + " |"
    lines = [head, "|---|" + "---|" * len(runs)]
    lines += ["| " + label + " | " + " | ".join(cells) + " |" for label, cells in rows]
    return "\n".join(lines)


def figure(png, csv_path, runs):
    """Co-phasing error per sample and contrast per frame of each run against time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, figsize=(8, 6), sharex=True)
    with replacing(csv_path) as f:
        w = csv.writer(f)
        w.writerow(["run", "kind", "t_s", "cophasing_rms_nm", "contrast"])
        for name, folder in runs:
            samples = _read(pathlib.Path(folder) / "segments-samples.csv")
            frames = _read(pathlib.Path(folder) / "segments-frames.csv")
            t = [float(r["t_s"]) for r in samples]
            c = [max(float(r["cophasing_rms_nm"]), 1e-3) for r in samples]
            axes[0].semilogy(t, c, lw=0.7, label=name)
            tf = [float(r["t_start_s"]) for r in frames] + [float(frames[-1]["t_end_s"])]
            cf = [float(r["contrast"]) for r in frames]
            axes[1].stairs(cf, tf, lw=1.0, label=name)
            w.writerows([name, "sample", r["t_s"], r["cophasing_rms_nm"], r["contrast"]] for r in samples)
            w.writerows([name, "frame", r["t_start_s"], r["cophasing_rms_nm"], r["contrast"]] for r in frames)
    axes[0].set_ylabel("co-phasing error (nm)")
    axes[1].set_yscale("log")
    axes[1].set_ylabel("dark-zone contrast per frame")
    axes[1].set_xlabel("time (s)")
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    with replacing_path(png) as tmp:
        fig.savefig(tmp, dpi=90)
    plt.close(fig)


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m inchworm_segments.compare", description=__doc__)
    p.add_argument("runs", nargs="+", metavar="NAME=DIR", help="a run of inchworm_segments with --regulation-from")
    p.add_argument("--out", required=True, help="folder for cophase-table.csv and cophase-timeseries.png/.csv")
    args = p.parse_args(sys.argv[1:] if argv is None else argv)
    runs = []
    for text in args.runs:
        name, sep, folder = text.partition("=")
        if not sep or not name:
            print(f"inchworm_segments.compare: error: {text}: give NAME=DIR", file=sys.stderr)
            return 2
        runs.append((name, folder))
    try:
        summaries = [(n, summary(d)) for n, d in runs]
    except OSError as e:
        print(f"inchworm_segments.compare: error: {e}", file=sys.stderr)
        return 1
    starts = {s.get("regulation_from_s") for _, s in summaries}
    if len(starts) != 1 or None in starts:
        print("inchworm_segments.compare: error: the runs need the same --regulation-from", file=sys.stderr)
        return 2
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with replacing(out / "cophase-table.csv") as f:
        w = csv.writer(f)
        w.writerow(["name"] + [n for n, _ in summaries])
        for key, _, _ in ROWS:
            w.writerow([key] + ["" if s.get(key) is None else s[key] for _, s in summaries])
    figure(out / "cophase-timeseries.png", out / "cophase-timeseries.csv", runs)
    print(markdown(summaries, starts.pop()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
