"""A drive cycle through the FMU in its steady fidelity, and the wear loop it drives
(docs/DRIVE_CYCLE.md).

The cycle: the WLTC class 3b vehicle speed (UN GTR No. 15, Annex 1; 1800 s at 1 s,
`data/wltc_class3b.csv`) on a stated vehicle (`VEHICLE`) whose electric motor drives the
example set's sun; the ring drives the wheels through a final drive. The vehicle's road
load and inertia give the sun torque, the wheel speed the sun speed. The FMU runs the
cycle with `fidelity` 3 (steady, transverse-torsional), the torque drive with the load
balance: `sunTorque` is the motor torque, `inputSpeedReference` the cycle's sun speed,
and the output is held at the cycle's speed by the balance (the vehicle). At every
communication step the FMU records its load duty; the cycle's duty (`dutyCycle`) wears
the flanks by `planetwear wear step --duty-cycle FILE --hours H`, and the loop runs the
cycle again on the worn state until the target κ.

Layer 4 (front end): imports `files`, `campaign_file` (the state's format, the binary),
`duty` (the FMU's duty document) and `plots`.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import math
import subprocess
import sys
import time
import zipfile
from pathlib import Path

from .campaign_file import check_state_document, find_planetwear_bin, max_wear_depth
from .duty import OUTPUT as DUTY_OUTPUT
from .duty import DutyCycleError, read_duty_cycle, write_duty_cycle
from .files import read_input, write_atomic

CYCLE_FILE = Path(__file__).resolve().parent / "data" / "wltc_class3b.csv"

# The vehicle the cycle is driven with: a 12 t electric delivery truck whose motor drives
# the example set's sun (the set's rated 750 N·m at about its acceleration demand).
VEHICLE = {
    "mass_kg": 12000.0,
    "rotating_mass_factor": 1.05,
    "rolling_resistance": 0.008,
    "drag_area_m2": 4.5,
    "air_density_kg_m3": 1.2,
    "wheel_radius_m": 0.5,
    "final_drive": 8.0,
    "efficiency": 0.95,
    "traction_limit_nm": 1000.0,
    "regeneration_limit_nm": -600.0,
    "power_limit_w": 350e3,
    "gravity_m_s2": 9.81,
}

# The FMU's built-in set (its sceneFile left empty), which the wear stepper wears.
SCENE = "example-2004"


def set_ratio(fmu_path, scene=SCENE):
    """The output member's speed per input speed of the FMU's scene (ring per sun for the
    example, −34/70), from the kinematics the FMU ships beside the scene
    (resources/<scene>.kinematics.json, written by `planetwear fmu pack`)."""
    with zipfile.ZipFile(fmu_path) as z:
        k = json.loads(z.read(f"resources/{scene}.kinematics.json"))
    index = {"sun": 0, "ring": 1, "carrier": 2}
    return k["rigid_speeds"][index[k["output"]]] / k["rigid_speeds"][index[k["input"]]]


# The duty's bins: load torque 0 to 1100 N·m by 100 (regeneration, below 0, is outside
# every bin: the coast flanks' wear is not modelled), sun speed 0 to 1300 rad/s by 100.
DUTY_TORQUE_EDGES = [100.0 * k for k in range(12)]
DUTY_SPEED_EDGES = [100.0 * k for k in range(14)]

OUTPUTS = ("sun.speed", "planet[1].sunMeshForceMax", "planet[1].ringMeshForceMax", "window.sunMeshFrms",
           "window.ringMeshFrms", "window.sunMeshMean", "window.ringMeshMean", "window.sunSeparation")


def read_cycle(path=CYCLE_FILE):
    """[(time s, vehicle speed km/h)] of a cycle file (`time_s,speed_kmh`, comment lines '#')."""
    rows = []
    for line in read_input(path, "record").decode().splitlines():
        if not line or line.startswith("#") or line.startswith("time_s"):
            continue
        t, v = line.split(",")
        rows.append((float(t), float(v)))
    return rows


def traces(cycle, ratio, vehicle=VEHICLE):
    """Sun speed [rad/s] at each second and sun torque [N·m] over each second of `cycle`:
    the speed from the wheel speed through the final drive and the set (`ratio`, its output
    speed per input speed: `set_ratio`), the torque from the
    road load and the acceleration over the second, through the efficiency (traction) or
    against it (regeneration), limited by the motor's torque and power; friction brakes take
    what regeneration does not."""
    v = vehicle
    gear = v["final_drive"] / abs(ratio)
    speeds = [s / 3.6 / v["wheel_radius_m"] * gear for _, s in cycle]
    torques = []
    for (t0, s0), (t1, s1) in zip(cycle, cycle[1:]):
        u0, u1 = s0 / 3.6, s1 / 3.6
        a = (u1 - u0) / (t1 - t0)
        u = 0.5 * (u0 + u1)
        road = v["rolling_resistance"] * v["mass_kg"] * v["gravity_m_s2"] * (u > 0.0) + 0.5 * v[
            "air_density_kg_m3"] * v["drag_area_m2"] * u * u
        force = v["mass_kg"] * v["rotating_mass_factor"] * a + road
        wheel = force * v["wheel_radius_m"]
        torque = wheel / gear / v["efficiency"] if wheel >= 0.0 else wheel / gear * v["efficiency"]
        omega = 0.5 * (speeds[len(torques)] + speeds[len(torques) + 1])
        if omega > 0.0:
            limit = v["power_limit_w"] / omega
            torque = max(-limit, min(limit, torque))
        torques.append(max(v["regeneration_limit_nm"], min(v["traction_limit_nm"], torque)))
    return speeds, torques


def run_cycle(fmu_path, speeds, torques, *, step=1e-3, seconds=None, state_file="", record_every=0.1,
              fidelity=3, duty_torque_edges=None, duty_speed_edges=None, unpack_dir=None, unzipdir=None):
    """Runs the cycle through the FMU at communication step `step` [s] (the first `seconds`
    of it when given), from the worn-profile state `state_file` (empty: unworn). Returns
    {"time", one list per output in OUTPUTS, "sun_torque", "duty" (the dutyCycle document),
    "wall_s" (the cycle's steps), "init_s" (instantiation and initialization)}. The FMU is
    extracted into `unpack_dir` (fmpy's temporary directory when None), or taken as
    extracted in `unzipdir` (a loop extracts once: a library loaded in this process must
    not be written over)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu_path))
    vrs = {v.name: v.valueReference for v in md.modelVariables}
    if unzipdir is None:
        unzipdir = extract(str(fmu_path), unzipdir=str(unpack_dir) if unpack_dir else None)
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName="drive-cycle")
    duration = len(torques) if seconds is None else min(seconds, len(torques))
    n = int(round(duration / step))
    t_init = time.perf_counter()
    fmu.instantiate()
    try:
        fmu.setupExperiment(startTime=0.0)
        first = max(speeds[0], 1e-3)
        fmu.setInteger([vrs["fidelity"], vrs["driveMode"], vrs["loadBalance"]], [fidelity, 0, 1])
        fmu.setReal([vrs["initialSpeed"]], [first])
        strings = [(vrs["wearStateFile"], str(state_file))]
        if duty_torque_edges:
            strings.append((vrs["dutyTorqueEdges"], ",".join(map(str, duty_torque_edges))))
        if duty_speed_edges:
            strings.append((vrs["dutySpeedEdges"], ",".join(map(str, duty_speed_edges))))
        fmu.setString([r for r, _ in strings], [s for _, s in strings])
        fmu.enterInitializationMode()
        fmu.setReal([vrs["sunTorque"], vrs["inputSpeedReference"]], [torques[0], first])
        fmu.exitInitializationMode()
        init_s = time.perf_counter() - t_init
        out_vrs = [vrs[name] for name in OUTPUTS]
        record = {"time": [], "sun_torque": [], **{name: [] for name in OUTPUTS}}
        # fmi2SetReal and fmi2DoStep called directly with buffers made once: fmpy's
        # setReal builds its arrays at every call.
        c_vr = (ctypes.c_uint * 1)(vrs["inputSpeedReference"])
        c_val = (ctypes.c_double * 1)()
        t_vr = (ctypes.c_uint * 1)(vrs["sunTorque"])
        t_val = (ctypes.c_double * 1)()
        set_real, do_step, component = fmu.fmi2SetReal, fmu.fmi2DoStep, fmu.component
        every = max(1, int(round(record_every / step)))
        per_second = int(round(1.0 / step))
        t0 = time.perf_counter()
        for k in range(n):
            second, within = divmod(k, per_second)
            if within == 0:
                t_val[0] = torques[second]
                set_real(component, t_vr, 1, t_val)
            # The cycle's speed at the step's end, linear within the second.
            f = (within + 1) / per_second
            c_val[0] = max(speeds[second] + f * (speeds[second + 1] - speeds[second]), 0.0)
            set_real(component, c_vr, 1, c_val)
            status = do_step(component, k * step, step, 1)
            if status > 1:  # fmi2OK or fmi2Warning (logged through the callback)
                raise RuntimeError(f"fmi2DoStep at t = {k * step} s returned status {status}")
            if (k + 1) % every == 0:
                values = fmu.getReal(out_vrs)
                record["time"].append((k + 1) * step)
                record["sun_torque"].append(torques[second])
                for name, value in zip(OUTPUTS, values):
                    record[name].append(value)
        wall = time.perf_counter() - t0
        duty = fmu.getString([vrs[DUTY_OUTPUT]])[0]
        duty = duty.decode() if isinstance(duty, bytes) else duty
        fmu.terminate()
    finally:
        fmu.freeInstance()
    record.update({"duty": duty, "wall_s": wall, "init_s": init_s, "steps": n, "step": step})
    return record


def dynamic_factor(record):
    """Planet 1's sun–planet dynamic factor at each recorded point: the largest mesh force
    over the step over the mean mesh force (NaN where the mesh carries no mean load)."""
    return [m / f if f > 1.0 else math.nan
            for m, f in zip(record["planet[1].sunMeshForceMax"], record["window.sunMeshMean"])]


def _state_kappa(path):
    if not path:
        return 0, 0.0, 0.0
    content, reason = check_state_document(read_input(path, "worn_state").decode("utf-8", errors="replace"))
    if reason:
        raise RuntimeError(f"{path}: {reason}")
    return content["kappa"], max_wear_depth(content) * 1e6, content.get("operating_time", 0.0) / 3600.0


def run_loop(fmu_path, out_dir, *, to_kappa=6, hours_per_stage=50.0, seconds=None, step=1e-3,
             planetwear_bin=None, plots=True, log=print):
    """Runs the cycle on the unworn set, wears it by the cycle's duty for
    `hours_per_stage` hours, and again on the worn state, until κ reaches `to_kappa`.
    Writes <out_dir>/stage-<n>/ (cycle.json: the recorded outputs; duty.json),
    <out_dir>/states/stage-<n>.json, <out_dir>/loop.json and the plots; returns the loop
    record."""
    exe = find_planetwear_bin(planetwear_bin)
    if exe is None:
        raise RuntimeError("no planetwear binary: set PLANETWEAR_BIN or put planetwear on PATH")
    from fmpy import extract

    out_dir = Path(out_dir)
    speeds, torques = traces(read_cycle(), set_ratio(fmu_path))
    unzipdir = extract(str(fmu_path))
    state, stages = "", []
    for n in range(64):
        kappa, wear_um, hours = _state_kappa(state)
        stage_dir = out_dir / f"stage-{n}"
        stage_dir.mkdir(parents=True, exist_ok=True)
        rec = run_cycle(fmu_path, speeds, torques, step=step, seconds=seconds, state_file=state,
                        unzipdir=unzipdir, duty_torque_edges=DUTY_TORQUE_EDGES,
                        duty_speed_edges=DUTY_SPEED_EDGES)
        duty_path = stage_dir / "duty.json"
        try:
            write_duty_cycle(duty_path, rec["duty"])
        except DutyCycleError as e:
            raise RuntimeError(f"stage {n}: the FMU's dutyCycle is not a duty cycle: {e}") from None
        cycle_seconds = rec["steps"] * rec["step"]
        log(f"stage {n}: κ = {kappa}, deepest wear {wear_um:.3f} µm after {hours:.1f} h; cycle of "
            f"{cycle_seconds:.0f} s in {rec['wall_s']:.1f} s ({cycle_seconds / rec['wall_s']:.1f}× real time, "
            f"initialization {rec['init_s']:.2f} s)")
        stage = {"stage": n, "kappa": kappa, "max_wear_um": wear_um, "operating_hours": hours,
                 "state": str(state), "wall_s": rec["wall_s"], "init_s": rec["init_s"],
                 "cycle_seconds": cycle_seconds, "real_time_factor": cycle_seconds / rec["wall_s"]}
        cycle = {k: rec[k] for k in ("time", "sun_torque", *OUTPUTS)}
        cycle["dynamic_factor"] = dynamic_factor(rec)
        write_atomic(stage_dir / "cycle.json", json.dumps(cycle).encode())
        stages.append(stage)
        if kappa >= to_kappa:
            break
        next_state = out_dir / "states" / f"stage-{n + 1}.json"
        next_state.parent.mkdir(parents=True, exist_ok=True)
        cmd = [exe, "wear", "step", "--scene", SCENE, "--out", str(next_state), "--duty-cycle", str(duty_path),
               "--hours", str(hours_per_stage)]
        if state:
            cmd += ["--state", str(state)]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"the wear stepper refused ({' '.join(cmd)}): {proc.stderr.strip()}")
        state = str(next_state)
    record = {"cycle": "WLTC class 3b", "vehicle": VEHICLE, "step_s": step, "hours_per_stage": hours_per_stage,
              "stages": stages}
    write_atomic(out_dir / "loop.json", json.dumps(record, indent=1).encode())
    if plots:
        from .plots import plot_drive_cycle, plot_duty_histogram, plot_wear_against_hours

        (out_dir / "plots").mkdir(parents=True, exist_ok=True)
        first = json.loads(read_input(out_dir / "stage-0" / "cycle.json", "record"))
        plot_drive_cycle(first, out_dir / "plots" / "cycle.png")
        plot_duty_histogram(read_duty_cycle(out_dir / "stage-0" / "duty.json"), out_dir / "plots" / "duty.png")
        plot_wear_against_hours(stages, out_dir / "plots" / "wear_hours.png")
    return record


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m planetwear_fmu.drive_cycle", description=__doc__.split("\n\n")[0])
    p.add_argument("--fmu", required=True, help="the planetwear FMU (planetwear fmu pack)")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--to-kappa", type=int, default=6)
    p.add_argument("--hours-per-stage", type=float, default=50.0)
    p.add_argument("--seconds", type=float, default=None, help="run only the cycle's first seconds")
    p.add_argument("--step", type=float, default=1e-3, help="communication step [s]")
    p.add_argument("--no-plots", action="store_true")
    a = p.parse_args(argv)
    run_loop(a.fmu, a.out, to_kappa=a.to_kappa, hours_per_stage=a.hours_per_stage, seconds=a.seconds,
             step=a.step, plots=not a.no_plots, log=lambda m: print(m, file=sys.stderr))
    return 0


if __name__ == "__main__":
    sys.exit(main())
