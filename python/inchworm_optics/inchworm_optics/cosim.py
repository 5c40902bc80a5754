"""`MirrorMount.ssp` stepped by FMPy, sample by sample, the way a Python optics model
couples to the FMUs.

Why FMPy and not the `inchworm` master's CSV: the fine-guidance loop measures the image
and changes the mount's tip/tilt references while the run goes on, so the optics has to
sit inside the co-simulation loop; a CSV written by a finished run cannot be steered.
The loop here is the master's Jacobi loop (`src/master/`): parameters in
initialization mode (each component's first binding from the SSD, then overrides),
every output read after initialization, then per step every connection written from the
latest outputs and every component stepped by h; row 0 is the state after
initialization. So the pose trace equals `inchworm run dist/MirrorMount.ssp` bit for bit
(tests/python/test_optics.py checks it).

The guidance loop reaches the mount through the references: `offset_m[x]` is added to
`reference_x.reference` on its way to `controller_x.reference`, for x = a, b, c.
"""
import io
import lzma
import math
import pathlib
import shutil
import struct
import tempfile
import xml.etree.ElementTree as ET
import zipfile
import zlib

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from .inputs import STEP_S, InputError, Range
from inchworm_variables import InchwormController as Controller, InchwormMount as Mount, InchwormPlant as Plant

SSD = "{http://ssp-standard.org/SSP1/SystemStructureDescription}"
SSV = "{http://ssp-standard.org/SSP1/SystemStructureParameterValues}"
CHAINS = ("a", "b", "c")
#: fmi2Integer is 32 bits.
INTEGER_RANGE = (-(2**31), 2**31 - 1)


def _typed(tag, text):
    if tag == "Boolean":
        return text in ("true", "1")
    if tag == "Integer":
        return int(text)
    return float(text)


#: The largest member of an SSP read to find the variables (an FMU inside it, the SSD, a
#: model description), bytes, by its declared size: zipfile stops at the declared size, so
#: a member that inflates past it (a zip bomb) is not read.
MAX_MEMBER_BYTES = 256 << 20
#: What a damaged or hostile archive raises while it is read: zipfile's own errors, the
#: decompressors' (zlib, bz2's OSError, lzma, a truncated stream's EOFError), a compression
#: or encryption zipfile has not (NotImplementedError, RuntimeError), a name that is not
#: UTF-8 (a ValueError), a missing member (KeyError) or name (TypeError), XML that does not
#: parse or names an unknown encoding (ParseError, LookupError), a component or variable
#: without a name or a bound that is no number (ValueError), and struct's and the recursion
#: limit's.
_ARCHIVE_ERRORS = (OSError, EOFError, KeyError, TypeError, ValueError, LookupError, RuntimeError,
                   NotImplementedError, RecursionError, struct.error, zlib.error, lzma.LZMAError,
                   zipfile.BadZipFile, zipfile.LargeZipFile, ET.ParseError)


def _member(z, name):
    """A member's bytes, refused past MAX_MEMBER_BYTES by its declared size."""
    info = z.getinfo(name)
    if info.file_size > MAX_MEMBER_BYTES:
        raise ValueError(f"{name} declares {info.file_size} bytes, more than {MAX_MEMBER_BYTES}")
    return z.read(info)


def ssp_variables(ssp_path):
    """{component: {variable: (type, min, max)}} of an SSP's FMUs, from the SSD and each
    FMU's modelDescription.xml read inside the archive (nothing unpacked); min and max are
    None where the FMU declares none. An `InputError` if the file is not such an SSP, or a
    member is larger than MAX_MEMBER_BYTES."""
    try:
        with zipfile.ZipFile(ssp_path) as z:
            ssd = ET.fromstring(_member(z, "SystemStructure.ssd"))
            out = {}
            for c in ssd.iter(f"{SSD}Component"):
                if c.get("name") is None:
                    raise ValueError("a component without a name")
                with zipfile.ZipFile(io.BytesIO(_member(z, c.get("source")))) as fmu:
                    md = ET.fromstring(_member(fmu, "modelDescription.xml"))
                out[c.get("name")] = {
                    _named(v): (t.tag, _bound(t.get("min")), _bound(t.get("max")))
                    for v in md.iter("ScalarVariable") for t in v[:1]
                }
    except _ARCHIVE_ERRORS as e:
        kind = type(e).__name__ if type(e).__module__ == "builtins" else f"{type(e).__module__}.{type(e).__name__}"
        raise InputError(f"{ssp_path}: not a readable SSP of FMUs ({kind}: {str(e)[:200]})") from None
    return out


def _named(variable):
    name = variable.get("name")
    if name is None:
        raise ValueError("a ScalarVariable without a name")
    return name


def _bound(text):
    """A declared min or max: None where none is declared, else a number (not NaN)."""
    if text is None:
        return None
    value = float(text)
    if math.isnan(value):
        raise ValueError(f"a declared bound {text[:40]!r} is not a number")
    return value


def parse_params(ssp_path, params):
    """`--param` texts ("component.variable=value") as {name: value} typed by each
    variable's type in the SSP's FMUs (as `inchworm run --param` parses them: Real finite,
    Integer a whole 32-bit number, Boolean true/false/1/0; within the FMU's declared
    min/max); an `InputError` naming the first one the SSP cannot take."""
    variables = ssp_variables(ssp_path) if params else {}
    out = {}
    for p in params:
        name, eq, text = (s.strip() for s in p.partition("="))
        comp, _, var = name.partition(".")
        where = f"--param {p}"
        if not eq or not var:
            raise InputError(f"{where}: expected COMPONENT.VARIABLE=VALUE")
        if var not in variables.get(comp, {}):
            raise InputError(f"{where}: no variable `{name}` in {ssp_path} (components: {', '.join(variables)})")
        kind, lo, hi = variables[comp][var]
        if kind == "Boolean":
            if text not in ("true", "false", "1", "0"):
                raise InputError(f"{where}: `{name}` is a Boolean: accepted true, false, 1 or 0")
            out[name] = text in ("true", "1")
            continue
        if kind not in ("Real", "Integer"):
            raise InputError(f"{where}: `{name}` is of type {kind}: only Real, Integer and Boolean can be set")
        try:
            value = float(text)
        except ValueError:
            value = text
        integer = kind == "Integer"
        lo = (INTEGER_RANGE[0] if integer else -math.inf) if lo is None else lo
        hi = (INTEGER_RANGE[1] if integer else math.inf) if hi is None else hi
        Range(lo, hi, integer=integer, why=f"`{name}` is a {kind} of the SSP's FMUs").check("--param", value, shown=p)
        out[name] = int(value) if kind == "Integer" else value
    return out


class _Component:
    """One FMU instance with its variables by name."""

    def __init__(self, name, fmu_path, workdir):
        md = read_model_description(fmu_path)
        unzipped = extract(fmu_path, unzipdir=str(workdir / name))
        self.name = name
        self.vars = {v.name: v for v in md.modelVariables}
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipped,
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate()

    def set(self, name, value):
        v = self.vars[name]
        if v.type == "Real":
            self.fmu.setReal([v.valueReference], [float(value)])
        elif v.type == "Integer":
            self.fmu.setInteger([v.valueReference], [int(value)])
        elif v.type == "Boolean":
            self.fmu.setBoolean([v.valueReference], [bool(value)])
        else:
            raise ValueError(f"{self.name}.{name}: type {v.type} is not supported")

    def get(self, name):
        v = self.vars[name]
        if v.type == "Real":
            return self.fmu.getReal([v.valueReference])[0]
        if v.type == "Integer":
            return self.fmu.getInteger([v.valueReference])[0]
        return self.fmu.getBoolean([v.valueReference])[0]


class MountCosim:
    """`MirrorMount.ssp` at t = 0, ready to `step()`.

    `params` maps `component.variable` to a value, applied after the SSD's first bindings
    (as `inchworm run --param`); `analog_mode()` gives the three controllers' analog mode.
    """

    def __init__(self, ssp_path, params=None, step_s=STEP_S):
        self.h = step_s
        self.t = 0.0
        self.components = {}
        self._dir = pathlib.Path(tempfile.mkdtemp(prefix="inchworm-optics-"))
        try:
            self._start(ssp_path, params)
        except BaseException:  # an error, Ctrl-C or SIGTERM (raised by the CLI): no folder left
            self._discard()
            raise

    def _start(self, ssp_path, params):
        with zipfile.ZipFile(ssp_path) as z:
            z.extractall(self._dir / "ssp")
        root = self._dir / "ssp"
        ssd = ET.parse(root / "SystemStructure.ssd").getroot()
        values = []
        for c in ssd.iter(f"{SSD}Component"):
            name = c.get("name")
            self.components[name] = _Component(name, str(root / c.get("source")), self._dir / "fmu")
            first = c.find(f"{SSD}ParameterBindings/{SSD}ParameterBinding")
            if first is not None:
                ssv = ET.parse(root / first.get("source")).getroot()
                prefix = first.get("prefix") or ""
                for p in ssv.iter(f"{SSV}Parameter"):
                    (v,) = list(p)
                    values.append((name, prefix + p.get("name"), _typed(v.tag.split("}")[1], v.get("value"))))
        self.connections = [
            (c.get("startElement"), c.get("startConnector"), c.get("endElement"), c.get("endConnector"))
            for c in ssd.iter(f"{SSD}Connection")
        ]
        for qualified, value in (params or {}).items():
            comp, var = qualified.split(".", 1)
            values.append((comp, var, value))
        for comp in self.components.values():
            comp.fmu.setupExperiment(startTime=0.0)
            comp.fmu.enterInitializationMode()
        for comp, var, value in values:
            if comp not in self.components or var not in self.components[comp].vars:
                raise KeyError(f"parameter `{comp}.{var}`: no such component variable in {ssp_path}")
            self.components[comp].set(var, value)
        for comp in self.components.values():
            comp.fmu.exitInitializationMode()
        mount = self.components["mount"]
        self.radius_m = mount.get("radius")
        self.angles_rad = [math.radians(mount.get("angle_a") + 120.0 * i) for i in range(3)]
        #: Added to each chain's reference on its way to the controller (m).
        self.offset_m = {x: 0.0 for x in CHAINS}
        self._latest = {}
        self._read_sources()

    @staticmethod
    def analog_mode():
        """The parameters that turn on analog mode near the target in the three controllers
        (docs/controller-design.md; the default deadband, 0, is what it requires)."""
        return {f"controller_{x}.analog": True for x in CHAINS}

    def _read_sources(self):
        for src, out, _, _ in self.connections:
            self._latest[(src, out)] = self.components[src].get(out)

    def set_tip_tilt_offset(self, tip_rad, tilt_rad):
        """Moves the mount's tip/tilt reference by (tip, tilt) on top of the references'
        tables: each actuator's share, z_i = R (tip sin φ_i + tilt cos φ_i) (the inverse
        of the mount FMU's kinematics)."""
        for x, phi in zip(CHAINS, self.angles_rad):
            self.offset_m[x] = self.radius_m * (tip_rad * math.sin(phi) + tilt_rad * math.cos(phi))

    def step(self):
        """One Jacobi communication step of h."""
        for src, out, dst, inp in self.connections:
            value = self._latest[(src, out)]
            if inp == Controller.REFERENCE and dst.startswith("controller_"):
                value += self.offset_m[dst.split("_", 1)[1]]
            self.components[dst].set(inp, value)
        for comp in self.components.values():
            comp.fmu.doStep(currentCommunicationPoint=self.t, communicationStepSize=self.h)
        self.t = round(self.t / self.h + 1) * self.h
        self._read_sources()

    def pose(self):
        """(piston m, tip rad, tilt rad) of the mount output now."""
        m = self.components["mount"]
        return m.get(Mount.PISTON), m.get(Mount.TIP), m.get(Mount.TILT)

    def encoders(self):
        return tuple(self.components[f"plant_{x}"].get(Plant.ENCODER_COUNTS) for x in CHAINS)

    def close(self):
        """Terminates and frees the FMUs and removes the unpacked folder."""
        try:
            for comp in self.components.values():
                comp.fmu.terminate()
        finally:
            self._discard()

    def _discard(self):
        """Frees whatever instances remain (legal in any state, unlike terminate) and removes
        the unpacked folder: the end of `close` and of a start that failed part-way."""
        for comp in self.components.values():
            try:
                comp.fmu.freeInstance()
            except Exception:  # its library failed: the folder still goes
                pass
        self.components = {}
        shutil.rmtree(self._dir, ignore_errors=True)


def parked(encoders, window=8):
    """Rows at which all three runners are parked: every encoder unchanged over the last
    `window` samples (the rule of `inchworm scenario mirror`, src/scenario.rs)."""
    enc = np.asarray(encoders)
    ok = np.zeros(len(enc), dtype=bool)
    for i in range(window - 1, len(enc)):
        ok[i] = np.all(enc[i - window + 1:i + 1] == enc[i])
    return ok
