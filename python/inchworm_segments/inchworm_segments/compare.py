"""`python -m inchworm_segments.compare NAME=DIR …`: runs of the command side by side (the
co-phasing scenario's controllers, scripts/cophase.sh): each DIR's segments-summary.csv,
segments-samples.csv and segments-frames.csv into one table (printed as Markdown and
written as cophase-table.csv) and one figure of co-phasing error and frame contrast
against time (cophase-timeseries.png, its CSV cophase-timeseries.csv)."""
import argparse
import csv
import io
import pathlib
import sys
from inchworm_inputs import command, open_bounded
from inchworm_output import OutputError, replacing, replacing_path

from .config import TIME_S, InputError, Range
from .files import csv_rows

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
#: The largest of a run's CSVs read, bytes (segments-samples.csv of an hour is about 170 MB).
MAX_CSV_BYTES = 1 << 30
#: The largest segments-summary.csv read, bytes (it has about 30 rows).
MAX_SUMMARY_BYTES = 1 << 20
MAX_LINE_CHARS = 64 << 10
#: A summary's value: any finite number (counts, nm, contrasts, Strehl ratios, seconds).
VALUE = Range()
#: The columns the figure reads, with their ranges.
SAMPLE_COLUMNS = {"t_s": TIME_S, "cophasing_rms_nm": Range(0.0, unit="nm"), "contrast": Range(0.0)}
FRAME_COLUMNS = {"t_start_s": TIME_S, "t_end_s": TIME_S, "cophasing_rms_nm": Range(0.0, unit="nm"),
                 "contrast": Range(0.0)}


def _stream(data):
    return io.BytesIO(data) if isinstance(data, (bytes, bytearray, memoryview)) else data


def _cell(rng, label, text):
    """A CSV cell as a number in `rng`, or the InputError naming it."""
    t = text.strip()
    try:
        if not t.isascii() or "_" in t:
            raise ValueError
        x = float(t)
    except ValueError:
        x = t[:80]
    return rng.check(label, x, shown=None if isinstance(x, float) else repr(x))


def parse_summary(data, name="segments-summary.csv"):
    """name → value (float, or None where empty) of a summary CSV's bytes (or binary
    stream): the header `name,value`, then one row of two cells a name, each name once and
    each value empty or a finite number; else an InputError naming `name` and the row."""
    rows = csv_rows(_stream(data), name, MAX_SUMMARY_BYTES, MAX_LINE_CHARS)
    first = next(rows, None)
    if first is None or [c.strip() for c in first[1]] != ["name", "value"]:
        raise InputError(f"{name}: accepted the header `name,value`, then one row a number")
    out = {}
    for i, row in rows:
        if len(row) != 2:
            raise InputError(f"{name}: row {i} has {len(row)} columns: accepted 2, name and value")
        key, value = row
        if not key or key in out:
            raise InputError(f"{name}: row {i}: name {key[:80]!r}: accepted a name not empty and not given before")
        out[key] = None if value == "" else _cell(VALUE, f"{name}: row {i}: {key[:80]}", value)
    return out


def parse_columns(data, columns, name):
    """{column: [float]} of the CSV bytes (or binary stream) `data`, for `columns` (name →
    Range): a header naming each of them, then at least one row with every one of them a
    number in its range; else an InputError naming `name`, the row and the column."""
    rows = csv_rows(_stream(data), name, MAX_CSV_BYTES, MAX_LINE_CHARS)
    first = next(rows, None)
    head = [] if first is None else [c.strip() for c in first[1]]
    missing = [c for c in columns if c not in head]
    if missing:
        raise InputError(f"{name}: no column {missing[0]}: accepted a header with {', '.join(columns)}")
    where = {c: head.index(c) for c in columns}
    out = {c: [] for c in columns}
    for i, row in rows:
        if len(row) != len(head):
            raise InputError(f"{name}: row {i} has {len(row)} columns, the header {len(head)}")
        for c, rng in columns.items():
            out[c].append(_cell(rng, f"{name}: row {i}: {c}", row[where[c]]))
    if not out[next(iter(columns))]:
        raise InputError(f"{name}: no rows: accepted at least one")
    return out


def _read(path, parse, limit, *args):
    with open_bounded(path, limit) as f:
        return parse(f, *args, str(path))


def summary(folder):
    """name → value (float, or None where empty) of a run's segments-summary.csv."""
    return _read(pathlib.Path(folder) / "segments-summary.csv", parse_summary, MAX_SUMMARY_BYTES)


def series(folder):
    """({column: [float]} of a run's segments-samples.csv, the same of its
    segments-frames.csv): what the figure draws."""
    folder = pathlib.Path(folder)
    return (_read(folder / "segments-samples.csv", parse_columns, MAX_CSV_BYTES, SAMPLE_COLUMNS),
            _read(folder / "segments-frames.csv", parse_columns, MAX_CSV_BYTES, FRAME_COLUMNS))


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
    regulation_from_s = TIME_S.check("regulation_from_s", regulation_from_s)
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

    data = [(name, *series(folder)) for name, folder in runs]  # every file read and checked first
    fig, axes = plt.subplots(2, figsize=(8, 6), sharex=True)
    with replacing(csv_path) as f:
        w = csv.writer(f)
        w.writerow(["run", "kind", "t_s", "cophasing_rms_nm", "contrast"])
        for name, samples, frames in data:
            t, cp, c = samples["t_s"], samples["cophasing_rms_nm"], samples["contrast"]
            axes[0].semilogy(t, [max(v, 1e-3) for v in cp], lw=0.7, label=name)
            tf = frames["t_start_s"] + [frames["t_end_s"][-1]]
            axes[1].stairs(frames["contrast"], tf, lw=1.0, label=name)
            # Times as segments-samples.csv and segments-frames.csv write them (0.1 ms).
            w.writerows([name, "sample", f"{v[0]:.4f}", *v[1:]] for v in zip(t, cp, c))
            w.writerows([name, "frame", f"{v[0]:.4f}", *v[1:]] for v in zip(frames["t_start_s"],
                                                                             frames["cophasing_rms_nm"],
                                                                             frames["contrast"]))
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


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise InputError(f"{message} (see --help)")


PROG = "inchworm_segments.compare"


def main(argv=None):
    return command(PROG, lambda: _main(argv), refused=(InputError, OutputError))


def _main(argv):
    p = _Parser(prog=f"python -m {PROG}", description=__doc__)
    p.add_argument("runs", nargs="+", metavar="NAME=DIR", help="a run of inchworm_segments with --regulation-from")
    p.add_argument("--out", required=True, help="folder for cophase-table.csv and cophase-timeseries.png/.csv")
    args = p.parse_args(sys.argv[1:] if argv is None else argv)
    runs = []
    for text in args.runs:
        name, sep, folder = text.partition("=")
        if not sep or not name:
            raise InputError(f"{text}: give NAME=DIR")
        runs.append((name, folder))
    summaries = [(n, summary(d)) for n, d in runs]
    starts = {s.get("regulation_from_s") for _, s in summaries}
    if len(starts) != 1 or None in starts:
        raise InputError("the runs need the same --regulation-from")
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
