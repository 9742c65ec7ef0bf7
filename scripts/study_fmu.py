"""Speed sweeps of the planetwear FMU driven by fmpy, one instance per
(wear state, direction), the steady state of each speed carried to the next.

Protocol per speed (docs/MODEL.md §3, the study's): driveMode 2 keeps the
published torque boundary condition and steps the set's rigid-body speed to
each new inputSpeedReference with the elastic state kept (the continuation of
the native `planetwear sweep`), one input revolution of run-in, then
two revolutions whose mesh-force harmonics the FMU reports through its
windowed outputs (window.*; harmonicWindowCycles = 2 revolutions). At the
speeds asked for time histories the running instance's state is saved with
fmi2GetFMUstate, a few mesh cycles are recorded at a fine communication step,
and the saved state is restored, so the sweep itself does not see the detour.

Used by scripts/study.py; importable on its own:

    rows, histories = sweep(fmu, unzipdir, wear_state, speeds, "up", history_speeds=[3000])
"""

import math
import time
from pathlib import Path

from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave

WINDOW = ["F1", "F2", "F3", "F4", "F5", "F6", "Frms", "Separation"]
HISTORY_CYCLES = 3
HISTORY_SAMPLES_PER_CYCLE = 40


def _window_name(mesh, quantity):
    return f"window.{mesh}Separation" if quantity == "Separation" else f"window.{mesh}Mesh{quantity}"


def sweep(fmu, unzipdir, wear_state, speeds, direction, history_speeds=(), progress=None,
          run_in_revolutions=1, window_revolutions=2, instance="sweep", scene_file=""):
    """Sweeps `speeds` [rpm] (already in sweep order) with one instance.

    Returns (rows, histories): rows = one dict per speed with the windowed
    harmonics of planet 1's sun-planet and ring-planet mesh forces in N/mm
    and the wall time; histories = {rpm: dict of arrays} at `history_speeds`.
    `wear_state` is the worn-profile state file ('' for the unworn set);
    `scene_file` a scene file the FMU loads ('' for its built-in example).
    """
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    slave = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir,
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=instance)
    slave.instantiate()
    try:
        slave.setupExperiment(startTime=0.0)
        slave.setString([vr["wearStateFile"]], [str(wear_state)])
        if scene_file:
            slave.setString([vr["sceneFile"]], [str(scene_file)])
        slave.setInteger([vr["driveMode"]], [2])
        # Parameters cannot be read before initialisation (FMI 2.0 call order): the sun's
        # teeth and the face width come from the model description's start values.
        start = {v.name: v.start for v in md.modelVariables}
        z_sun = int(start["sun.teeth"])
        slave.setInteger([vr["harmonicWindowCycles"]], [window_revolutions * z_sun])
        omega0 = speeds[0] * math.pi / 30
        slave.setReal([vr["initialSpeed"], vr["inputSpeedReference"]], [omega0, omega0])
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        face_mm = float(start["faceWidth"]) * 1e3
        names = [_window_name(m, q) for m in ("sun", "ring") for q in WINDOW]
        refs = [vr[n] for n in names]
        t = 0.0
        rows, histories = [], {}
        for i, rpm in enumerate(speeds):
            start = time.perf_counter()
            slave.setReal([vr["inputSpeedReference"]], [rpm * math.pi / 30])
            # Carrier held: the mesh frequency is Z_sun times the sun's speed.
            fm = z_sun * rpm / 60
            h = 1.0 / fm
            for _ in range((run_in_revolutions + window_revolutions) * z_sun):
                slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)
                t += h
            values = dict(zip(names, slave.getReal(refs)))
            row = {"direction": direction, "speed_rpm": rpm, "mesh_frequency_hz": fm}
            for m in ("sun", "ring"):
                for q in WINDOW:
                    v = values[_window_name(m, q)]
                    row[f"{m}_{q.lower()}"] = v if q == "Separation" else v / face_mm
            row["seconds"] = time.perf_counter() - start
            rows.append(row)
            if rpm in history_speeds:
                histories[rpm] = _history(slave, vr, t, h)
            if progress:
                progress(i + 1, len(speeds), row)
        slave.terminate()
    finally:
        slave.freeInstance()
    return rows, histories


def _history(slave, vr, t, h_cycle):
    """Records a few mesh cycles at a fine step from a saved state, then
    restores it (fmi2GetFMUstate / fmi2SetFMUstate)."""
    state = slave.getFMUstate()
    names = ["planet[1].sunMeshForce", "planet[1].ringMeshForce", "sun.speed"]
    refs = [vr[n] for n in names]
    h = h_cycle / HISTORY_SAMPLES_PER_CYCLE
    out = {"time_s": [], "sun_force_n": [], "ring_force_n": [], "sun_speed": []}
    tt = t
    for _ in range(HISTORY_CYCLES * HISTORY_SAMPLES_PER_CYCLE):
        slave.doStep(currentCommunicationPoint=tt, communicationStepSize=h)
        tt += h
        fs, fr, ws = slave.getReal(refs)
        out["time_s"].append(tt - t)
        out["sun_force_n"].append(fs)
        out["ring_force_n"].append(fr)
        out["sun_speed"].append(ws)
    slave.setFMUstate(state)
    slave.freeFMUstate(state)
    return out


def grid(start, stop, step):
    n = int(math.floor((stop - start) / step + 1e-9)) + 1
    return [start + step * i for i in range(n)]


if __name__ == "__main__":
    import argparse

    from fmpy import extract

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--fmu", default=str(Path(__file__).resolve().parents[1] / "fmu" / "planetwear.fmu"))
    p.add_argument("--wear-state", default="")
    p.add_argument("--speeds", default="2000,3000,4000")
    a = p.parse_args()
    rows, _ = sweep(a.fmu, extract(a.fmu), a.wear_state, [float(s) for s in a.speeds.split(",")], "up")
    for r in rows:
        print(f"{r['speed_rpm']:7.0f} rpm  sun F(rms) {r['sun_frms']:8.3f} N/mm  ring {r['ring_frms']:8.3f} N/mm")
