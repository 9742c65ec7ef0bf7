"""The messages an importer receives from the FMU for five wrong inputs,
with loggingOn false (docs/FMU.md, "Messages"): each case runs on a fresh
instance through fmpy and prints the call's status and every message the
logger callback received, with its category.

Usage: python scripts/fmu_messages.py [FMU]   (default fmu/planetwear.fmu)
"""

import sys
from ctypes import byref
from pathlib import Path

from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (FMU2Slave, calloc, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, free)

STATUS = ["OK", "Warning", "Discard", "Error", "Fatal", "Pending"]
RECEIVED = []


def _logger(env, name, status, category, message):
    RECEIVED.append((STATUS[status], category.decode(), message.decode()))


# One set of callbacks for the whole process: fmpy's logging shim keeps a
# pointer to the last logger it was given.
CALLBACKS = fmi2CallbackFunctions()
CALLBACKS.logger = fmi2CallbackLoggerTYPE(_logger)
CALLBACKS.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
CALLBACKS.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
try:
    from fmpy.logging import addLoggerProxy
    addLoggerProxy(byref(CALLBACKS))
except Exception:  # an fmpy without the shim passes the message as it is
    pass


def case(md, unzipdir, title, reals, steps=0, h=1e-3, stop=None, outputs=()):
    """Instantiates with loggingOn false, sets `reals` before initialization
    (and `outputs` after it), runs `steps` steps of `h`, and prints what the
    importer sees."""
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="messages")
    s.instantiate(callbacks=CALLBACKS, loggingOn=False)
    RECEIVED.clear()
    outcome = "every call fmi2OK"
    try:
        s.setupExperiment(startTime=0.0, stopTime=stop)
        for name, value in reals.items():
            s.setReal([vr[name]], [value])
        s.enterInitializationMode()
        s.exitInitializationMode()
        for name, value in outputs:
            s.setReal([vr[name]], [value])
        for k in range(steps):
            s.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
    except FMICallException as e:
        outcome = f"fmpy raised: {e}"
    print(f"== {title}")
    print(f"   {outcome}")
    for status, category, message in RECEIVED:
        print(f"   [{status} {category}] {message}")
    received = list(RECEIVED)
    s.freeInstance()
    return received


def main(path):
    md = read_model_description(str(path))
    unzipdir = extract(str(path))
    return [
        case(md, unzipdir, "module = -0.0015 m (a negative module)", {"module": -0.0015}),
        case(md, unzipdir, "sun.speed set (an output)", {}, outputs=[("sun.speed", 100.0)]),
        case(md, unzipdir, "initialSpeed = 3000 (meant as rpm, given in rad/s)", {"initialSpeed": 3000.0}),
        case(md, unzipdir, "sunTorque = 300 N·m against the default ringTorque (unbalanced)",
             {"sunTorque": 300.0}, steps=30),
        case(md, unzipdir, "a step past stopTime = 0.0015 s", {}, steps=2, stop=0.0015),
    ]


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parents[1] / "fmu" / "planetwear.fmu")
