"""Runs an SSP in four masters and returns the same thing from each: the values of chosen
component variables at every communication point, and how the master labelled the rows.

* `inchworm run`: row k is the state at k h (row 0 after initialization), labelled k h.
* Ecos (ecospy 0.7.2): read through `get_*` after `init` and after each `step`; labelled
  with `get_time()`, which is k h.
* OSP libcosim (libcosimpy 0.0.6, `CosimExecution.from_ssp_file` on the unpacked SSP):
  a last-value observer read after each `step`; labelled with the execution's
  `current_time` (ns), k h; no row for t = 0 (the observer has nothing before a step).
* FMPy 0.3.32 (`fmpy.ssp.simulate_ssp`): its row k is labelled k h, the start of the
  step, but holds the values at its end, (k + 1) h; no row for t = 0.

Every function returns (labels, {"component.variable": values}) as NumPy arrays.
"""
import os
import pathlib
import subprocess
import tempfile
import types
import xml.etree.ElementTree as ET
import zipfile

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXE = ROOT / "target" / "release" / "inchworm"
H = 0.002
NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
}


def bindings(ssp):
    """{set name: {component: {variable: (type, text)}}} from the SSD's component-level
    ParameterBindings, each component's bindings in document order (first = default)."""
    out = {}
    order = {}
    with zipfile.ZipFile(ssp) as z:
        ssd = ET.fromstring(z.read("SystemStructure.ssd"))
        for comp in ssd.iter(f"{{{NS['ssd']}}}Component"):
            order[comp.get("name")] = []
            for b in comp.iter(f"{{{NS['ssd']}}}ParameterBinding"):
                ssv = ET.fromstring(z.read(b.get("source")))
                name = ssv.get("name")
                order[comp.get("name")].append(name)
                values = {}
                for p in ssv.iter(f"{{{NS['ssv']}}}Parameter"):
                    (v,) = list(p)
                    values[(b.get("prefix") or "") + p.get("name")] = (v.tag.split("}")[1], v.get("value"))
                out.setdefault(name, {})[comp.get("name")] = values
    return out, order


def _python_value(ty, text):
    if ty == "Boolean":
        return text in ("true", "1")
    if ty == "Integer":
        return int(text)
    return float(text)


def inchworm(ssp, stop, names, parameter_set=None, params=(), h=H):
    """`inchworm run` with no --input, at master step `h`."""
    fd, out = tempfile.mkstemp(suffix=".csv", prefix="inchworm-run-")
    os.close(fd)
    out = pathlib.Path(out)
    cmd = [str(EXE), "run", str(ssp), "--stop-time", str(stop), "--step-size", str(h), "--out", str(out)]
    if parameter_set:
        cmd += ["--parameter-set", parameter_set]
    for p in params:
        cmd += ["--param", p]
    for n in names:
        cmd += ["--output", n]
    assert EXE.exists(), "build the CLI first: cargo build --release"
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    rows = np.loadtxt(out, delimiter=",", skiprows=1, ndmin=2)
    out.unlink()
    return rows[:, 0], {n: rows[:, i + 1] for i, n in enumerate(names)}


def fmpy(ssp, stop, names, parameter_set=None, h=H):
    """FMPy's SSP master; `parameter_set` by name, from the SSD's bindings, each
    parameter typed as its .ssv says (FMPy's own read_ssv would turn `false` into true)."""
    from fmpy.ssp.simulation import simulate_ssp

    ps = None
    if parameter_set:
        sets, _ = bindings(ssp)
        params = [
            types.SimpleNamespace(name=f"{c}.{v}", value=float(_python_value(ty, text)))
            for c, vals in sets[parameter_set].items()
            for v, (ty, text) in vals.items()
        ]
        ps = types.SimpleNamespace(parameters=params)
    r = simulate_ssp(str(ssp), stop_time=stop, step_size=h, parameter_set=ps)
    return r["time"], {n: np.asarray(r[n]) for n in names}


def ecos(ssp, stop, names, parameter_set=None, h=H):
    """Ecos's SSP loader at step `h`; names as `component.variable`, Ecos's
    `component::variable`."""
    from ecospy import EcosSimulation

    types_ = _types(ssp, names)
    labels, cols = [], {n: [] for n in names}
    with EcosSimulation(ssp_path=str(ssp), step_size=h) as sim:
        sim.init(parameter_set=parameter_set)

        def sample():
            labels.append(sim.get_time())
            for n in names:
                ident = n.replace(".", "::", 1)
                get = {"Integer": sim.get_integer, "Boolean": sim.get_bool}.get(types_[n], sim.get_real)
                cols[n].append(get(ident))

        sample()
        for _ in range(int(round(stop / h))):
            sim.step()
            sample()
        sim.terminate()
    return np.array(labels), {n: np.array(v) for n, v in cols.items()}


def libcosim(ssp_dir, stop, names, h=H):
    """libcosim's SSP loader on the unpacked SSP `ssp_dir` (it applies each component's
    first binding); fixed step `h`."""
    from libcosimpy import _internal
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    # libcosimpy dereferences a NULL slave on a wrong path: check it first.
    assert (pathlib.Path(ssp_dir) / "SystemStructure.ssd").is_file(), ssp_dir
    try:
        ex = CosimExecution.from_ssp_file(str(ssp_dir), step_size=int(round(h * 1e9)))
    except AssertionError as e:
        # from_ssp_file hides the loader's message; libcosim keeps it.
        raise AssertionError(f"libcosim: {_internal.get_last_error_message()}") from e
    index = {i.name.decode(): i.index for i in ex.slave_infos()}
    obs = CosimObserver.create_last_value()
    ex.add_observer(obs)
    refs = {}
    for n in names:
        c, v = n.split(".", 1)
        (var,) = [x for x in ex.slave_variables(index[c]) if x.name.decode() == v]
        refs[n] = (index[c], var.reference, var.type)
    labels, cols = [], {n: [] for n in names}
    for _ in range(int(round(stop / h))):
        ex.step()
        labels.append(ex.status().current_time * 1e-9)
        for n, (i, vr, ty) in refs.items():
            if ty == CosimVariableType.INTEGER.value:
                cols[n].append(obs.last_integer_values(i, [vr])[0])
            elif ty == CosimVariableType.BOOLEAN.value:
                cols[n].append(obs.last_boolean_values(i, [vr])[0])
            else:
                cols[n].append(obs.last_real_values(i, [vr])[0])
    ex.stop()
    return np.array(labels), {n: np.array(v) for n, v in cols.items()}


def _types(ssp, names):
    """The SSD connector type of each `component.connector`."""
    with zipfile.ZipFile(ssp) as z:
        ssd = ET.fromstring(z.read("SystemStructure.ssd"))
    out = {}
    for comp in ssd.iter(f"{{{NS['ssd']}}}Component"):
        for c in comp.iter(f"{{{NS['ssd']}}}Connector"):
            (t,) = list(c)
            out[f"{comp.get('name')}.{c.get('name')}"] = t.tag.split("}")[1]
    return {n: out.get(n, "Real") for n in names}


def unpack_with_first(ssp, dest, component_sets):
    """Unpacks `ssp` into `dest` with the bindings of each component in
    `component_sets` ({component: set name}) moved first, for masters that apply only a
    component's first binding (libcosim)."""
    with zipfile.ZipFile(ssp) as z:
        z.extractall(dest)
    path = pathlib.Path(dest) / "SystemStructure.ssd"
    ET.register_namespace("ssd", NS["ssd"])
    ET.register_namespace("ssc", "http://ssp-standard.org/SSP1/SystemStructureCommon")
    tree = ET.parse(path)
    for comp in tree.getroot().iter(f"{{{NS['ssd']}}}Component"):
        want = component_sets.get(comp.get("name"))
        pb = comp.find(f"{{{NS['ssd']}}}ParameterBindings")
        if want is None or pb is None:
            continue
        items = list(pb)
        for b in items:
            name = ET.parse(pathlib.Path(dest) / b.get("source")).getroot().get("name")
            if name == want:
                pb.remove(b)
                pb.insert(0, b)
                break
        else:
            raise KeyError(f"{comp.get('name')} has no binding {want}")
    # libcosim reads the literal prefixes ssd:, ssc:, ssv: (ElementTree keeps them as registered).
    tree.write(path, xml_declaration=True, encoding="UTF-8")
    return dest
