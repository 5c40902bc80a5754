"""The shipped FMUs' libraries, loaded side by side as a master loads them, handed each
other's instances: each kind of call a master makes in its loop refuses a foreign instance
with fmi2Error or fmi3Error instead of reading it (a plant getter given the controller's
instance would read it as its own), a free of it is a no-op, and both instances still
work. Each case runs in its own process, so a crash fails the case, not the session."""
import subprocess
import sys
import textwrap

import pytest

from conftest import built_fmu

SCRIPT = textwrap.dedent(
    r"""
    import ctypes, sys
    from ctypes import POINTER, byref, c_bool, c_double, c_int, c_size_t, c_uint, c_void_p
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    version, paths = sys.argv[1], sys.argv[2:]
    two = version == "2"

    def open_fmu(path, name):
        md = read_model_description(path)
        token = md.guid if two else md.instantiationToken
        fmu = (FMU2Slave if two else FMU3Slave)(
            guid=token, unzipDirectory=extract(path),
            modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        fmu.instantiate()
        if two:
            fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        reals = [v.valueReference for v in md.modelVariables if v.type in ("Real", "Float64")]
        return fmu, reals[0]

    def raw(fmu, name, *argtypes):
        # A function object of its own: FMPy's would raise on the error status.
        return ctypes.CFUNCTYPE(c_int, c_void_p, *argtypes)((name, fmu.dll))

    U, N, D, I, B = POINTER(c_uint), c_size_t, POINTER(c_double), POINTER(c_int), POINTER(c_bool)
    if two:
        SIGNATURES = [
            ("fmi2GetReal", (U, N, D)), ("fmi2SetReal", (U, N, D)), ("fmi2GetInteger", (U, N, I)),
            ("fmi2DoStep", (c_double, c_double, c_int)), ("fmi2GetFMUstate", (POINTER(c_void_p),)),
            ("fmi2SetTime", (c_double,)),
        ]
    else:
        SIGNATURES = [
            ("fmi3GetFloat64", (U, N, D, N)), ("fmi3SetFloat64", (U, N, D, N)),
            ("fmi3GetInt32", (U, N, I, N)), ("fmi3DoStep", (c_double, c_double, c_bool, B, B, B, D)),
            ("fmi3GetFMUState", (POINTER(c_void_p),)), ("fmi3SetTime", (c_double,)),
        ]

    def arguments(name, vr):
        x, i, b, state = (c_double * 1)(5.0), (c_int * 1)(0), (c_bool * 1)(), c_void_p()
        if "DoStep" in name:
            return (0.0, 0.002, 1) if two else (0.0, 0.002, True, b, b, b, x)
        if "FMU" in name:
            return (byref(state),)
        if "SetTime" in name:
            return (1.0,)
        values = i if "Int" in name else x
        return (vr, 1, values) if two else (vr, 1, values, 1)

    (plant, plant_vr), (controller, controller_vr) = open_fmu(paths[0], "plant"), open_fmu(paths[1], "controller")
    for fmu, vr, foreign in [(plant, plant_vr, controller), (controller, controller_vr, plant)]:
        vrs = (c_uint * 1)(vr)
        for name, argtypes in SIGNATURES:
            print(name, raw(fmu, name, *argtypes)(foreign.component, *arguments(name, vrs)))
        ctypes.CFUNCTYPE(None, c_void_p)(("fmi%sFreeInstance" % version, fmu.dll))(foreign.component)
    plant.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.002)
    controller.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.002)
    print("alive")
    """
)


@pytest.mark.parametrize("version", ["2", "3"])
def test_each_fmu_refuses_the_other_s_instance_in_every_kind_of_call(tmp_path, version):
    sub = "" if version == "2" else "fmi3/"
    fmus = [built_fmu(f"{sub}InchwormPlant"), built_fmu(f"{sub}InchwormController")]
    r = subprocess.run(
        [sys.executable, "-c", SCRIPT, version, *fmus],
        capture_output=True, text=True, timeout=120, cwd=tmp_path,
    )
    assert r.returncode == 0, f"exit {r.returncode}: {r.stderr[-2000:]}"
    *calls, last = r.stdout.splitlines()
    assert last == "alive", r.stdout
    assert len(calls) == 12, r.stdout
    assert all(line.split()[1] == "3" for line in calls), r.stdout


RELOAD = textwrap.dedent(
    r"""
    import _ctypes, ctypes, sys
    from ctypes import c_double, c_int, c_void_p
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    path = sys.argv[1]
    md = read_model_description(path)
    unzipped = extract(path)
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipped,
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="kept")
    fmu.instantiate()
    library = fmu.dll._name
    # The master lets go of the library while its instance lives, then loads it again.
    _ctypes.dlclose(fmu.dll._handle)
    again = ctypes.CDLL(library)
    call = lambda name, *types: ctypes.CFUNCTYPE(c_int, c_void_p, *types)((name, again))
    c = fmu.component
    print(call("fmi2SetupExperiment", c_int, c_double, c_double, c_int, c_double)(c, 0, 0.0, 0.0, 0, 0.0))
    print(call("fmi2EnterInitializationMode")(c), call("fmi2ExitInitializationMode")(c))
    print(call("fmi2DoStep", c_double, c_double, c_int)(c, 0.0, 0.002, 1))
    """
)


def test_an_instance_outlives_its_library_being_closed_and_opened_again(tmp_path):
    # Ecos does this between the components of one FMU: the instance must still be the
    # library's own when the library is opened again.
    r = subprocess.run(
        [sys.executable, "-c", RELOAD, built_fmu("InchwormPlant")],
        capture_output=True, text=True, timeout=120, cwd=tmp_path,
    )
    assert r.returncode == 0, f"exit {r.returncode}: {r.stderr[-2000:]}"
    assert r.stdout.split() == ["0", "0", "0", "0"], r.stdout
