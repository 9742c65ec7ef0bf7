"""Asks the FMU whether it accepts a campaign's settings and wear states,
before any work starts.

Each case instantiates the FMU, sets the parameters a campaign task would
set and initializes it; the FMU refuses a foreign or corrupt wear state (or
a bad setting) in fmi2ExitInitializationMode and logs the reason. The cases
run in a child process (`python -m planetwear_fmu.fmu_check`, a JSON request
on stdin, a JSON answer on stdout) with logging on and the child's own
logger callback: fmpy's logging shim stays out of the caller's process.

Layer 2 (FMU access): this module owns the parameters a task sets
(`task_parameters`), the FMU's verdict (`check`, `run_cases` and the child
process) and `load_campaign`, the full check of a campaign file: the
checks of `campaign_file` with `check` passed in as their `probe`. Of the
package it imports only `campaign_file` (below it); `campaign_file` does not
import it back.
"""

from __future__ import annotations

import json
import subprocess
import sys

from . import campaign_file
from .campaign_file import INTEGRATOR_PARAMETERS, Problem


def load_campaign(path, output_dir=None):
    """Reads a campaign file and checks it whole: every key
    (`campaign_file.load`) and, last, the FMU's verdict on the settings and
    each wear state (`check`). Returns a `campaign_file.Campaign` or raises
    `campaign_file.CampaignError` listing every problem."""
    return campaign_file.load(path, output_dir=output_dir, probe=check)


def task_parameters(scene, integrator, window_cycles, state_value, torque, first_speed_rpm):
    """The parameters and inputs a task sets before initialization:
    {"strings": …, "integers": …, "reals": …} by FMU variable name."""
    import math

    sun, ring, carrier = scene.balanced_torques(torque)
    omega = first_speed_rpm * math.pi / 30
    integers = {"driveMode": 2, "harmonicWindowCycles": window_cycles}
    reals = {"initialSpeed": omega, "inputSpeedReference": omega, "sunTorque": sun, "ringTorque": ring,
             "carrierTorque": carrier}
    for name, v in integrator.items():
        (integers if isinstance(v, int) else reals)[name] = v
    return {"strings": {"sceneFile": scene.fmu_value, "wearStateFile": state_value},
            "integers": integers, "reals": reals}


def check(fmu, scene, integrator, window_cycles, first_speed_rpm, torque, states):
    """Problems the FMU finds with the campaign's settings and each wear
    state [(index in wear.states, entry, WearState)], one initialization per
    state file (the unworn set alone when there is none). Returns a list of
    `Problem` (empty when all is well)."""

    def params(value):
        return task_parameters(scene, integrator, window_cycles, value, torque, first_speed_rpm)

    cases, entries = [], {}
    for i, entry, s in states:
        if s.fmu_value:
            cases.append({"key": f"wear.states[{i}]", **params(s.fmu_value)})
            entries[f"wear.states[{i}]"] = entry
    if not cases:
        cases.append({"key": "settings", **params("")})
    problems = []
    setting_refused = False
    for a in run_cases(str(fmu), cases):
        if a["ok"]:
            continue
        reason = " ".join(line.strip() for line in a["reason"].splitlines() if line.strip())
        # A refusal that names a setting (an integrator parameter under its
        # FMU or its scene name, the scene) is reported once, against that
        # setting, not against each state.
        names = [k for k, p in INTEGRATOR_PARAMETERS.items() if f"{p} =" in reason or f"dynamics.{k} =" in reason]
        if a["key"] == "settings" or names or "sceneFile" in reason or "invalid gear set" in reason:
            if not setting_refused:
                key = f"integrator.{names[0]}" if names else "scene"
                value = integrator.get(INTEGRATOR_PARAMETERS[names[0]]) if names else scene.spec
                problems.append(Problem(key, value, f"the FMU refuses it: {reason}"))
                setting_refused = True
            continue
        problems.append(Problem(a["key"], entries[a["key"]], f"the FMU refuses this wear state: {reason}"))
    return problems


def run_cases(fmu, cases, timeout=600):
    """Runs the cases in a child process; returns one answer per case:
    {"key", "ok", "reason", "messages"}."""
    request = json.dumps({"fmu": fmu, "cases": cases})
    proc = subprocess.run([sys.executable, "-m", "planetwear_fmu.fmu_check"], input=request, capture_output=True,
                          text=True, timeout=timeout)
    lines = proc.stdout.strip().splitlines()
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"the FMU check process failed (exit {proc.returncode}): {proc.stderr.strip()[-2000:]}")
    return json.loads(lines[-1])


def _child(request):
    import tempfile
    from ctypes import byref

    from fmpy import extract, read_model_description
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                           fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
    from fmpy.logging import addLoggerProxy
    from fmpy import calloc, free

    messages = []

    def logger(env, instance, status, category, message):
        label = ["ok", "warning", "discard", "error", "fatal", "pending"][status] if 0 <= status < 6 else status
        messages.append(f"[{label}] {message.decode('utf-8', errors='replace')}")

    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(logger)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    addLoggerProxy(byref(callbacks))

    md = read_model_description(request["fmu"])
    vr = {v.name: v.valueReference for v in md.modelVariables}
    answers = []
    with tempfile.TemporaryDirectory(prefix="planetwear-fmu-check-") as tmp:
        unzipdir = extract(request["fmu"], tmp)
        for case in request["cases"]:
            messages.clear()
            ok, reason = True, ""
            slave = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
                              instanceName=f"check-{case['key']}")
            slave.instantiate(callbacks=callbacks, loggingOn=True)
            try:
                slave.setupExperiment(startTime=0.0)
                for name, v in case["strings"].items():
                    slave.setString([vr[name]], [v])
                for name, v in case["integers"].items():
                    slave.setInteger([vr[name]], [v])
                for name, v in case["reals"].items():
                    slave.setReal([vr[name]], [v])
                slave.enterInitializationMode()
                slave.exitInitializationMode()
                slave.terminate()
            except FMICallException as e:
                ok = False
                refusals = [m for m in messages if not m.startswith("[ok]")]
                reason = "; ".join(refusals) if refusals else f"{e} (no reason logged)"
            finally:
                slave.freeInstance()
            answers.append({"key": case["key"], "ok": ok, "reason": reason, "messages": list(messages)})
    return answers


if __name__ == "__main__":
    print(json.dumps(_child(json.loads(sys.stdin.read()))))
