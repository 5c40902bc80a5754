"""FMPy's CVode on the plant's Model Exchange (InchwormPlant, the reduced formulation), for
the Model Exchange bench (benches/model_exchange.rs runs it and prints its lines beside
the master's). Usage: `fmpy_me.py PLANT_FMU GAIT_CSV CS_COUNTS_CSV`: GAIT_CSV the check
trace's DAC volts as an FMPy input file (a repeated time row at each change), CS_COUNTS_CSV
the Co-Simulation plant's encoder counts at the 2 ms samples (`time,encoder_counts`).

`simulate_fmu(..., fmi_type="ModelExchange", solver="CVode")` at FMPy's default tolerance
(the default experiment's) and at rtol 1e-8, output intervals 1 and 2 ms. Prints one line a
run, `fmpy-me <rtol> <interval s> <wall s> <CPU s> <steps> <rhs> <jacobian rhs> <root>
<worst counts> <samples>`: CVode's steps and evaluations summed over its
re-initializations at events, the largest difference in counts from CS at the 2 ms samples.
Then `fmpy-call <µs>`: one right-hand side as CVode's callback makes it (FMPy's Python `f`:
`fmi2SetTime`, `fmi2SetContinuousStates`, `fmi2GetDerivatives` through ctypes), timed apart."""
import gc
import sys
import time
from ctypes import POINTER, byref, c_int, c_long, c_void_p

import numpy as np
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Model
from fmpy.sundials import CVodeSolver
from fmpy.sundials.nvector_serial import N_VNew_Serial
from fmpy.sundials.libraries import sundials_cvode
from inchworm_variables import InchwormPlant as Plant

Q_ENC = 1.2e-9  # m a count (docs/model.md §2.6)
T = 0.002


def counter(name):
    f = getattr(sundials_cvode, name)
    f.argtypes, f.restype = [c_void_p, POINTER(c_long)], c_int
    return f


COUNTERS = {"steps": counter("CVodeGetNumSteps"), "rhs": counter("CVodeGetNumRhsEvals"),
            "jac_rhs": counter("CVodeGetNumLinRhsEvals"), "root": counter("CVodeGetNumGEvals")}
TOTALS = dict.fromkeys(COUNTERS, 0)


def tally(solver):
    """CVode's counts of `solver` so far into TOTALS (a re-initialization resets them)."""
    for key, f in COUNTERS.items():
        n = c_long(0)
        f(solver.cvode_mem, byref(n))
        TOTALS[key] += n.value


def counted(original):
    def wrapper(self, *args):
        tally(self)
        return original(self, *args)
    return wrapper


CVodeSolver.reset = counted(CVodeSolver.reset)
CVodeSolver.__del__ = counted(CVodeSolver.__del__)


def counts_at_samples(result, n):
    """The encoder counts of the runner position at the 2 ms samples 1..n, each after its events."""
    last = {}
    for i, t in enumerate(result["time"]):
        k = int(round(t / T))
        if abs(t - T * k) < 1e-9:
            last[k] = i
    rows = result[[last[k] for k in range(1, n + 1)]]
    return np.round(rows[Plant.RUNNER_POSITION] / Q_ENC).astype(int)


def rhs_call_us(path):
    """Microseconds of one right-hand side through FMPy's callback path, outside CVode."""
    md = read_model_description(path)
    fmu = FMU2Model(guid=md.guid, unzipDirectory=extract(path),
                    modelIdentifier=md.modelExchange.modelIdentifier, instanceName="plant")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.enterContinuousTimeMode()
    nx = md.numberOfContinuousStates
    solver = CVodeSolver(nx=nx, nz=md.numberOfEventIndicators, get_x=fmu.getContinuousStates,
                         set_x=fmu.setContinuousStates, get_dx=fmu.getDerivatives, get_z=fmu.getEventIndicators,
                         get_nominals=fmu.getNominalsOfContinuousStates, set_time=fmu.setTime, input=None,
                         startTime=0.0)
    y, ydot = solver.x, N_VNew_Serial(nx, solver.sunctx)
    n = 20000
    start = time.perf_counter()
    for k in range(n):
        solver.f(1e-6 * k, y, ydot, None)
    us = (time.perf_counter() - start) / n * 1e6
    del solver
    fmu.terminate()
    fmu.freeInstance()
    return us


def main(plant, gait, cs_counts):
    signals = np.genfromtxt(gait, delimiter=",", names=True)
    cs = np.genfromtxt(cs_counts, delimiter=",", names=True)[Plant.ENCODER_COUNTS].astype(int)
    stop = len(cs) * T
    for rtol in (None, 1e-8):
        for interval in (0.001, 0.002):
            for key in TOTALS:
                TOTALS[key] = 0
            cpu, wall = time.process_time(), time.perf_counter()
            result = simulate_fmu(plant, fmi_type="ModelExchange", solver="CVode", relative_tolerance=rtol,
                                  stop_time=stop, output_interval=interval, input=signals,
                                  output=[Plant.RUNNER_POSITION])
            wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
            gc.collect()  # the last solver (a cycle through its callbacks) counted by its __del__
            worst = int(np.max(np.abs(counts_at_samples(result, len(cs)) - cs)))
            print(f"fmpy-me {rtol or 'default'} {interval} {wall:.4f} {cpu:.4f} {TOTALS['steps']} {TOTALS['rhs']} "
                  f"{TOTALS['jac_rhs']} {TOTALS['root']} {worst} {len(cs)}")
    print(f"fmpy-call {rhs_call_us(plant):.3f}")


if __name__ == "__main__":
    main(*sys.argv[1:4])
