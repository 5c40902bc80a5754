"""`MirrorMount.ssp` stepped by FMPy, sample by sample, the way a Python optics model
couples to the FMUs.

Why FMPy and not the `inchworm` master's CSV: the fine-guidance loop measures the image
and changes the mount's tip/tilt references while the run goes on, so the optics has to
sit inside the co-simulation loop; a CSV written by a finished run cannot be steered.
The loop here is the master's Jacobi loop (`src/master.rs`): parameters in
initialization mode (each component's first binding from the SSD, then overrides),
every output read after initialization, then per step every connection written from the
latest outputs and every component stepped by h; row 0 is the state after
initialization. So the pose trace equals `inchworm run dist/MirrorMount.ssp` bit for bit
(tests/python/test_optics.py checks it).

The guidance loop reaches the mount through the references: `offset_m[x]` is added to
`reference_x.reference` on its way to `controller_x.reference`, for x = a, b, c.
"""
import math
import pathlib
import shutil
import tempfile
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

SSD = "{http://ssp-standard.org/SSP1/SystemStructureDescription}"
SSV = "{http://ssp-standard.org/SSP1/SystemStructureParameterValues}"
CHAINS = ("a", "b", "c")
STEP_S = 0.002


def _typed(tag, text):
    if tag == "Boolean":
        return text in ("true", "1")
    if tag == "Integer":
        return int(text)
    return float(text)


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
        self._dir = pathlib.Path(tempfile.mkdtemp(prefix="inchworm-optics-"))
        with zipfile.ZipFile(ssp_path) as z:
            z.extractall(self._dir / "ssp")
        root = self._dir / "ssp"
        ssd = ET.parse(root / "SystemStructure.ssd").getroot()
        self.components = {}
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
            if inp == "reference" and dst.startswith("controller_"):
                value += self.offset_m[dst.split("_", 1)[1]]
            self.components[dst].set(inp, value)
        for comp in self.components.values():
            comp.fmu.doStep(currentCommunicationPoint=self.t, communicationStepSize=self.h)
        self.t = round(self.t / self.h + 1) * self.h
        self._read_sources()

    def pose(self):
        """(piston m, tip rad, tilt rad) of the mount output now."""
        m = self.components["mount"]
        return m.get("piston"), m.get("tip"), m.get("tilt")

    def encoders(self):
        return tuple(self.components[f"plant_{x}"].get("encoder_counts") for x in CHAINS)

    def close(self):
        for comp in self.components.values():
            comp.fmu.terminate()
            comp.fmu.freeInstance()
        shutil.rmtree(self._dir, ignore_errors=True)


def parked(encoders, window=8):
    """Rows at which all three runners are parked: every encoder unchanged over the last
    `window` samples (the rule of `inchworm scenario mirror`, src/scenario.rs)."""
    enc = np.asarray(encoders)
    ok = np.zeros(len(enc), dtype=bool)
    for i in range(window - 1, len(enc)):
        ok[i] = np.all(enc[i - window + 1:i + 1] == enc[i])
    return ok
