"""The closed loop of InchwormSystem stepped by a plain 2 ms Jacobi loop in FMPy, for the
master benchmark (benches/closed_loop.rs runs it and compares). Prints
`fmpy: <simulated s> <wall s> <final encoder count> <CPU s>` (the loop's own, start-up
and loading excluded)."""
import sys
import time

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from inchworm_variables import InchwormController as Controller, InchwormPlant as Plant

H = 0.002
LEVELS = [100e-6, 60e-6, 250e-6, 245e-6, 130e-6, 131.5e-6, 20e-6]


def load(path, name):
    md = read_model_description(path)
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    return fmu, {v.name: v.valueReference for v in md.modelVariables}


def main(dist, duration):
    plant, pv = load(f"{dist}/InchwormPlant.fmu", "plant")
    ctrl, cv = load(f"{dist}/InchwormController.fmu", "controller")
    for f in (plant, ctrl):
        f.enterInitializationMode()
    ctrl.setBoolean([cv[Controller.PREFILTER]], [True])
    for f in (plant, ctrl):
        f.exitInitializationMode()
    dac = [Plant.DAC_EARTH, Plant.DAC_NONEARTH, Plant.DAC_EXTENSION]
    pdac, cdac = [pv[n] for n in dac], [cv[n] for n in dac]
    penc, cenc, cref = [pv[Plant.ENCODER_COUNTS]], [cv[Plant.ENCODER_COUNTS]], [cv[Controller.REFERENCE]]
    n = int(round(duration / H))
    start = time.perf_counter()
    cpu_start = time.process_time()
    for k in range(n):
        t = k * H
        enc = plant.getInteger(penc)
        volts = ctrl.getReal(cdac)
        plant.setReal(pdac, volts)
        ctrl.setInteger(cenc, enc)
        ctrl.setReal(cref, [LEVELS[min(int(t / 100.0), len(LEVELS) - 1)]])
        plant.doStep(t, H)
        ctrl.doStep(t, H)
    wall = time.perf_counter() - start
    cpu = time.process_time() - cpu_start
    final = plant.getInteger(penc)[0]
    print(f"fmpy: {duration} {wall} {final} {cpu}")


if __name__ == "__main__":
    main(sys.argv[1], float(sys.argv[2]))
