"""`inchworm run` on FMUs another toolchain built: two PythonFMU models (a gain and an
integrator with state), built here with `pythonfmu build`, run as single FMUs with an
input CSV, their outputs checked against closed forms.

PythonFMU's binaries leave the Python C API to the host (its FMUs declare
needsExecutionTool="true"); a non-Python master provides it by preloading libpython, as
here."""
import csv
import os
import pathlib
import subprocess
import sys
import sysconfig
import textwrap

import pytest

from conftest import ROOT

GAIN = '''
from pythonfmu import Fmi2Causality, Fmi2Slave, Real

class Gain(Fmi2Slave):
    description = "y = k * u"
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.k = 3.0
        self.u = 0.0
        self.y = 0.0
        self.register_variable(Real("k", causality=Fmi2Causality.parameter, variability="fixed"))
        self.register_variable(Real("u", causality=Fmi2Causality.input))
        self.register_variable(Real("y", causality=Fmi2Causality.output))
    def do_step(self, current_time, step_size):
        self.y = self.k * self.u
        return True
'''

INTEGRATOR = '''
from pythonfmu import Fmi2Causality, Fmi2Slave, Real

class Integrator(Fmi2Slave):
    description = "x' = u, forward Euler over each communication step"
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.u = 0.0
        self.x = 0.0
        self.register_variable(Real("u", causality=Fmi2Causality.input))
        self.register_variable(Real("x", causality=Fmi2Causality.output))
    def do_step(self, current_time, step_size):
        self.x += self.u * step_size
        return True
'''


@pytest.fixture(scope="module")
def third_party(tmp_path_factory):
    d = tmp_path_factory.mktemp("pythonfmu")
    fmus = {}
    for name, src in [("Gain", GAIN), ("Integrator", INTEGRATOR)]:
        script = d / f"{name}.py"
        script.write_text(textwrap.dedent(src))
        exe = pathlib.Path(sys.executable).parent / "pythonfmu"
        run = subprocess.run([str(exe), "build", "-f", str(script), "-d", str(d)], capture_output=True, text=True)
        assert run.returncode == 0, run.stdout + run.stderr
        fmus[name] = d / f"{name}.fmu"
    return d, fmus


def run_inchworm(fmu, args, tmp):
    exe = ROOT / "target" / "release" / "inchworm"
    assert exe.exists(), "build the CLI first: cargo build --release"
    env = dict(os.environ)
    env["LD_PRELOAD"] = str(pathlib.Path(sysconfig.get_config_var("LIBDIR")) / sysconfig.get_config_var("INSTSONAME"))
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    out = tmp / f"{fmu.stem}.csv"
    r = subprocess.run([str(exe), "run", str(fmu), "--out", str(out)] + args, capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stdout + r.stderr
    with open(out, newline="") as f:
        return list(csv.DictReader(f))


def test_gain_with_a_parameter_and_a_piecewise_constant_input(third_party):
    d, fmus = third_party
    (d / "u.csv").write_text("time,u\n0,1\n0.5,2\n")
    rows = run_inchworm(fmus["Gain"], ["--input", str(d / "u.csv"), "--stop-time", "1", "--step-size", "0.1", "--param", "k=4"], d)
    y = [float(r["y"]) for r in rows]
    assert len(y) == 11
    # The step from t holds u(t): y(t + h) = k u(t).
    assert y[1:6] == [4.0] * 5 and y[6:] == [8.0] * 5


def test_integrator_state_advances_exactly(third_party):
    d, fmus = third_party
    (d / "v.csv").write_text("time,u\n0,2\n1,-1\n")
    rows = run_inchworm(fmus["Integrator"], ["--input", str(d / "v.csv"), "--stop-time", "2", "--step-size", "0.25"], d)
    x = [float(r["x"]) for r in rows]
    # 4 steps at u = 2, then 4 at u = -1.
    assert x[4] == pytest.approx(2.0) and x[-1] == pytest.approx(1.0)
