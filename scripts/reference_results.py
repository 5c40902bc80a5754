"""The reference results each FMU carries (extra/org.fmi-standard.fmi-ls-ref/) and the
compatibility tree repeats (dist/cross-check/): one experiment per model, its input
(`_in.csv`), its options (`_ref.opt`) and FMPy's output (`_ref.csv`), committed under
fmu-build/reference/<Model>/.

    .venv/bin/python scripts/reference_results.py      # after cargo run --release -p fmu-build

re-records them from dist/'s FMI 2.0 FMUs (then run fmu-build again to package them).
tests/python/test_reference_results.py simulates every FMU of both standards with
`simulate` below and requires exactly the committed output, and holds the plant's to the
independent check trace of tests/data within 1 count.

The experiments:
- InchwormPlant and InchwormPlantFull (the same Co-Simulation): the check trace's DAC volts
  (tests/data), 1 s, encoder, mode, runner.
- InchwormController: the Fig. 5 loop's encoder counts (the full-control loop of both
  FMUs in FMPy's FMI 2.0 API, as tests/python/test_closed_loop.py runs it) and the 100 µm
  reference, 2 s; the DAC volts and the disturbance estimate out.
- InchwormReference: no inputs, the default step (Fig. 5), 1 s.
- InchwormMount: three runner positions on ramps, 1 s; piston, tip and tilt out.
- InchwormDelayLine: the runner on a ramp of 1 µm, 1 s, in the default (ground, 10 m)
  atmosphere; the controller's reference, the residual path, the fine stage and the lock
  out.
"""
import csv
import pathlib
import sys

import numpy as np
from fmpy import simulate_fmu
from fmpy.util import read_ref_opt_file
from inchworm_variables import (InchwormController as Controller, InchwormDelayLine as DelayLine,
                                InchwormMount as Mount, InchwormPlant as Plant)

ROOT = pathlib.Path(__file__).resolve().parents[1]
OUT = ROOT / "fmu-build" / "reference"
CHECK_TRACE = ROOT / "tests" / "data" / "plant-check-trace-fia20-passive.csv"
H = 0.002

OUTPUTS = {
    "InchwormPlant": [Plant.ENCODER_COUNTS, Plant.MODE, Plant.RUNNER_POSITION],
    "InchwormPlantFull": [Plant.ENCODER_COUNTS, Plant.MODE, Plant.RUNNER_POSITION],
    "InchwormController": [Plant.DAC_EARTH, Plant.DAC_NONEARTH, Plant.DAC_EXTENSION, Controller.DISTURBANCE_ESTIMATE],
    "InchwormReference": [Controller.REFERENCE],
    "InchwormMount": [Mount.PISTON, Mount.TIP, Mount.TILT],
    "InchwormDelayLine": [DelayLine.REFERENCE, DelayLine.RESIDUAL, DelayLine.FINE_PATH, DelayLine.LOCKED],
}
STOP = {"InchwormPlant": 1.0, "InchwormPlantFull": 1.0, "InchwormController": 2.0, "InchwormReference": 1.0,
        "InchwormMount": 1.0, "InchwormDelayLine": 1.0}


def fmt(x):
    """A number as the CSV holds it: integers plainly, floats round-tripping exactly."""
    if isinstance(x, (int, np.integer)) or (isinstance(x, float) and x.is_integer() and abs(x) < 2 ** 53):
        return str(int(x))
    return repr(float(x))


def write_csv(path, names, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(names)
        for r in rows:
            w.writerow([fmt(v) for v in r])


def step_rows(samples):
    """Input rows that hold each sample's values over [t, t + H): a repeated time row at
    every change, which FMPy reads as a step (it takes the value after it)."""
    rows, prev = [], None
    for t, values in samples:
        if prev is not None and values != prev:
            rows.append([t] + prev)
        if values != prev:
            rows.append([t] + values)
        prev = values
    rows.append([samples[-1][0] + H] + prev)
    return rows


def plant_input():
    with open(CHECK_TRACE, newline="") as f:
        rows = list(csv.DictReader(f))
    names = [Plant.DAC_EARTH, Plant.DAC_NONEARTH, Plant.DAC_EXTENSION]
    return names, step_rows([(round(float(r["time"]), 6), [float(r[n]) for n in names]) for r in rows])


def controller_input(steps):
    """The encoder counts the controller saw in the Fig. 5 full-control loop: the loop of
    tests/python/test_closed_loop.py (dist/'s FMI 2.0 FMUs in FMPy), whose step k reads
    the count after step k - 1 (0, at rest, before the first)."""
    sys.path.insert(0, str(ROOT / "tests" / "python"))
    from test_closed_loop import jacobi_fig5

    after = jacobi_fig5(steps * H)
    seen = [0] + after[:-1]
    return [Controller.REFERENCE, Plant.ENCODER_COUNTS], step_rows([(round(k * H, 6), [100e-6, c]) for k, c in enumerate(seen)])


def mount_input():
    # a: 0 -> 30 µm, b: 0 -> -10 µm, c: constant 5 µm, linear over the second.
    return [Mount.POSITION_A, Mount.POSITION_B, Mount.POSITION_C], [[0.0, 0.0, 0.0, 5e-6], [1.0, 30e-6, -10e-6, 5e-6]]


def delay_line_input():
    # The runner from 0 to 1 µm, linear over the second.
    return [DelayLine.RUNNER_POSITION], [[0.0, 0.0], [1.0, 1e-6]]


def simulate(fmu, model_dir, name):
    """FMPy's output of the experiment in `model_dir` (the `_ref.opt` options and the
    `_in.csv` inputs, if any), as a structured array."""
    opt = read_ref_opt_file(str(model_dir / f"{name}_ref.opt"))
    inp = model_dir / f"{name}_in.csv"
    signals = np.genfromtxt(inp, delimiter=",", names=True, deletechars="") if inp.exists() else None
    return simulate_fmu(str(fmu), start_time=opt["StartTime"], stop_time=opt["StopTime"],
                        output_interval=opt["StepSize"], relative_tolerance=opt["RelTol"],
                        input=signals, output=OUTPUTS[name], fmi_type="CoSimulation")


def record(dist):
    inputs = {
        "InchwormPlant": plant_input(),
        "InchwormPlantFull": plant_input(),
        "InchwormController": controller_input(int(round(STOP["InchwormController"] / H))),
        "InchwormMount": mount_input(),
        "InchwormDelayLine": delay_line_input(),
    }
    for name in OUTPUTS:
        d = OUT / name
        d.mkdir(parents=True, exist_ok=True)
        with open(d / f"{name}_ref.opt", "w") as f:
            f.write(f"StartTime,0.0\nStopTime,{STOP[name]}\nStepSize,{H}\nRelTol,1e-06\n")
        if name in inputs:
            names, rows = inputs[name]
            write_csv(d / f"{name}_in.csv", ["time"] + names, rows)
        result = simulate(dist / f"{name}.fmu", d, name)
        write_csv(d / f"{name}_ref.csv", list(result.dtype.names), [list(r) for r in result])
        print(f"{d}: {len(result)} rows of {', '.join(result.dtype.names[1:])}")


if __name__ == "__main__":
    record(ROOT / "dist")
