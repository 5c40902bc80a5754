"""The Modelica plant (modelica/Inchworm) compiled and simulated by rumoca, and the Rust
plant FMU stepped by FMPy on the same DAC volts, in the shape the cross-check compares:
per 2 ms sample the encoder count, mode and runner position at its end, and the brake
switches (their count and the first one's time) inside it (docs/modelica.md)."""
import ctypes
import pathlib
import re

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy.logging import addLoggerProxy

from conftest import DIST, ROOT
from inchworm_variables import InchwormController as Controller, InchwormPlant as Plant

LIBRARY = ROOT / "modelica"
H = 0.002
DAC = [Plant.DAC_EARTH, Plant.DAC_NONEARTH, Plant.DAC_EXTENSION]
# rumoca's explicit Runge-Kutta family: its BDF refuses runs with hundreds of sample
# events at rtol <= 1e-7 ("accepted-interval left endpoint sampler state ..."), and at
# 1e-6 it is 0.15 nm off; rk-like at 1e-8 is within 0.002 nm of the check trace.
SOLVER = {"solver": "rk-like", "rtol": 1e-8, "atol": 1e-12}


class ModelicaError(Exception):
    """The compiler is missing or not the pinned one, or the package does not compile or
    simulate: one line that says which and what to do."""


def pinned_version():
    """The rumoca version scripts/setup.sh installs: the one the package is checked with."""
    setup = (ROOT / "scripts" / "setup.sh").read_text()
    found = re.search(r"\brumoca==([0-9.]+)", setup)
    if not found:
        raise ModelicaError("scripts/setup.sh pins no rumoca version")
    return found.group(1)


def compiler():
    """The rumoca module, if it is the pinned version."""
    want = pinned_version()
    try:
        import rumoca
    except ImportError as e:
        raise ModelicaError(f"the Modelica compiler rumoca {want} is not installed ({e}): scripts/setup.sh installs it") from None
    have = rumoca.version()
    if have != want:
        raise ModelicaError(f"rumoca {have} is installed, but the package is checked with rumoca {want}: run scripts/setup.sh")
    return rumoca


def _first_line(e):
    text = str(e).strip()
    return text.splitlines()[0] if text else type(e).__name__


def compile_model(source, name, library=LIBRARY):
    """Compiles model `name` of `source` (Modelica text) against the package at `library`."""
    rm = compiler()
    session = rm.Session(roots=[str(pathlib.Path(library).resolve())])
    try:
        return session.loads(source, model=name, filename=f"{name}.mo")
    except (rm.RumocaError, RuntimeError) as e:
        raise ModelicaError(f"rumoca could not compile {name}: {type(e).__name__}: {_first_line(e)}") from None


def replay_source(name, rows, modifiers=""):
    """A model `name` that drives InchwormPlant (with `modifiers`, e.g. "T_em = 2.5") with
    the DAC volts of `rows`, one per sample."""
    arrays = ",\n    ".join(
        f"{key} = {{{', '.join(repr(float(r[col])) for r in rows)}}}"
        for key, col in zip(["earth", "nonearth", "extension"], DAC)
    )
    plant = f"Inchworm.InchwormPlant plant({modifiers});" if modifiers else "Inchworm.InchwormPlant plant;"
    return (
        f"model {name}\n  {plant}\n  Inchworm.Sources.DacSequence dac(\n    T_sample = {H!r},\n    {arrays});\n"
        "equation\n  connect(dac.y_earth, plant.dac_earth);\n  connect(dac.y_nonearth, plant.dac_nonearth);\n"
        f"  connect(dac.y_extension, plant.dac_extension);\nend {name};\n"
    )


def simulate(model, samples, prefix="plant."):
    """Runs `model` for `samples` samples; per sample the encoder count, mode and runner
    position at its end, and the brake switches inside it."""
    rm = compiler()
    try:
        r = model.simulate(t=samples * H, dt=H, config=rm.SimConfig(max_wall_seconds=600, **SOLVER))
    except (rm.RumocaError, RuntimeError) as e:
        raise ModelicaError(f"rumoca could not simulate {model.name}: {type(e).__name__}: {_first_line(e)}") from None
    t = np.asarray(r.time)
    ends = H * np.arange(1, samples + 1)
    # The last row at each sample's end: after the event there (rumoca writes the rows
    # before and after every event at its time).
    at = np.searchsorted(t, ends + 1e-12, side="right") - 1
    col = lambda name: np.asarray(r[prefix + name])
    switches = []
    for name in (Plant.EARTH_CLOSED, Plant.NONEARTH_CLOSED):
        b = col(name)
        switches += [t[i] for i in np.nonzero(b[1:] != b[:-1])[0] + 1]
    return {
        "counts": col(Plant.ENCODER_COUNTS)[at].astype(int),
        "mode": col(Plant.MODE)[at].astype(int),
        "runner": col(Plant.RUNNER_POSITION)[at],
        "switches": per_sample(sorted(switches), samples),
    }


def per_sample(times, samples):
    """[(count, first time)] of the switch `times` in each sample (t_k, t_k + H]."""
    out = [(0, None)] * samples
    for time in times:
        k = min(max(int(np.ceil(time / H - 1e-9)) - 1, 0), samples - 1)
        n, first = out[k]
        out[k] = (n + 1, time if first is None else first)
    return out


_libc = ctypes.CDLL(None)
_libc.calloc.restype = ctypes.c_void_p
_libc.calloc.argtypes = [ctypes.c_size_t, ctypes.c_size_t]
_libc.free.argtypes = [ctypes.c_void_p]
_MESSAGES = []  # (instance name, message) of every instance


def _log(_env, instance, _status, _category, message):
    _MESSAGES.append((instance.decode("utf-8", "replace"), message.decode("utf-8", "replace")))


# One set of callbacks for every instance: FMPy's logger proxy (which formats the
# variadic arguments) keeps a single Python logger.
_CALLBACKS = fmi2CallbackFunctions()
_CALLBACKS.logger = fmi2CallbackLoggerTYPE(_log)
_CALLBACKS.allocateMemory = fmi2CallbackAllocateMemoryTYPE(lambda n, size: _libc.calloc(n, size))
_CALLBACKS.freeMemory = fmi2CallbackFreeMemoryTYPE(lambda p: _libc.free(p))
addLoggerProxy(ctypes.byref(_CALLBACKS))


class _Logged:
    """An FMU2Slave with debug category logEvents on, whose log messages are kept."""

    def __init__(self, path, name, start_values):
        md = read_model_description(path)
        self.name = name
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(callbacks=_CALLBACKS, loggingOn=True)
        self.fmu.setDebugLogging(True, ["logEvents"])
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for key, value in start_values.items():
            self.fmu.setReal([self.vr[key]], [value])
        self.fmu.exitInitializationMode()

    def messages(self):
        return [m for name, m in _MESSAGES if name == self.name]

    def free(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


SWITCH = re.compile(r"(\d+) brake switch\(es\) in the step ending at t = ([0-9.e+-]+) s, first at Some\(([0-9.e+-]+)\) s")


def fmu_run(samples, rows=None, start_values=None, reference=None):
    """The plant FMU for `samples` steps of 2 ms: on the DAC volts of `rows`, or (rows
    None) in Fig. 5's closed loop with the controller FMU (reference `reference` m). Returns
    the per-sample record of `simulate` and the DAC volts it ran on."""
    _MESSAGES.clear()
    plant = _Logged(str(DIST / "InchwormPlant.fmu"), "plant", start_values or {})
    ctrl = None
    if rows is None:
        ctrl = _Logged(str(DIST / "InchwormController.fmu"), "controller", {})
    counts, modes, runner, volts_run = [], [], [], []
    try:
        for k in range(samples):
            t = k * H
            if ctrl is not None:
                enc = plant.fmu.getInteger([plant.vr[Plant.ENCODER_COUNTS]])
                volts = ctrl.fmu.getReal([ctrl.vr[n] for n in DAC])
                ctrl.fmu.setInteger([ctrl.vr[Plant.ENCODER_COUNTS]], enc)
                ctrl.fmu.setReal([ctrl.vr[Controller.REFERENCE]], [reference])
            else:
                volts = [float(rows[k][n]) for n in DAC]
            plant.fmu.setReal([plant.vr[n] for n in DAC], volts)
            plant.fmu.doStep(t, H)
            if ctrl is not None:
                ctrl.fmu.doStep(t, H)
            volts_run.append(dict(zip(DAC, volts)))
            counts.append(plant.fmu.getInteger([plant.vr[Plant.ENCODER_COUNTS]])[0])
            modes.append(plant.fmu.getInteger([plant.vr[Plant.MODE]])[0])
            runner.append(plant.fmu.getReal([plant.vr[Plant.RUNNER_POSITION]])[0])
    finally:
        plant.free()
        if ctrl is not None:
            ctrl.free()
    switches = [(0, None)] * samples
    for m in plant.messages():
        hit = SWITCH.search(m)
        if hit:
            k = int(round(float(hit.group(2)) / H)) - 1
            switches[k] = (int(hit.group(1)), float(hit.group(3)))
    record = {"counts": np.array(counts), "mode": np.array(modes), "runner": np.array(runner), "switches": switches}
    return record, volts_run
