"""One campaign task: a continuation sweep of the FMU over the speed grid
for one (wear state, sun torque, direction), its points written one by one.

Protocol per speed (scripts/study_fmu.py, docs/MODEL.md §3): driveMode 2 keeps
the torque boundary condition and steps the set's rigid-body speed to each
new inputSpeedReference with the elastic state kept; `run_in_cycles` mesh
cycles of run-in, then `window_cycles` whose mesh-force harmonics the FMU
reports through its windowed outputs (harmonicWindowCycles = window).

Each finished point is one small Parquet file (one row) and, written before
it, the FMU state after the point (fmi2SerializeFMUstate bytes) and the
task's load duty up to the point (the FMU's dutyCycle output as a
duty-cycle file, `<point>.duty.json`, docs/DUTY.md), all atomically
(temporary file, fsync, rename). A task that finds k finished
points in its directory deserializes the state of point k − 1 into a fresh
instance and continues with point k at the stored communication point:
nothing is recomputed or written twice, and with a deterministic integrator
the continued sweep gives the numbers of an uninterrupted one.

Layer 2 (FMU access): this module owns one task (`run_task`), its point
files (`PointStore`, `task_directory`, the Parquet `schema`, `table_bytes`)
and the fingerprint of its results (`task_fingerprint`). Of the package it
imports only `files` (`write_atomic`, re-exported here) and `duty`; Dask
workers import it alone, and the runner (`runner.task_specs`) builds its specs.
"""

from __future__ import annotations

import json
import math
import os
import socket
import time
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from .duty import write_duty_cycle
from .files import read_input, write_atomic

STATE_SUFFIX = ".fmustate"
DUTY_SUFFIX = ".duty.json"

BASE_COLUMNS = [
    ("label", pa.string()),
    ("kappa", pa.int64()),
    ("state", pa.string()),
    ("sun_torque_nm", pa.float64()),
    ("direction", pa.string()),
    ("index", pa.int64()),
    ("speed_rpm", pa.float64()),
    ("mesh_frequency_hz", pa.float64()),
    ("time_s", pa.float64()),
]
TAIL_COLUMNS = [
    ("sun_frms_n_per_mm", pa.float64()),
    ("ring_frms_n_per_mm", pa.float64()),
    ("wall_s", pa.float64()),
    ("fmu_step_s", pa.float64()),
]
# Columns that depend on the machine, not on the model.
TIMING_COLUMNS = ("wall_s", "fmu_step_s")


def schema(outputs):
    """The point table's schema for the kept outputs [(name, "Real"|"Integer")]."""
    cols = BASE_COLUMNS + [(n, pa.float64() if t == "Real" else pa.int64()) for n, t in outputs] + TAIL_COLUMNS
    return pa.schema(cols)


def table_bytes(table):
    buf = pa.BufferOutputStream()
    pq.write_table(table, buf)
    return buf.getvalue().to_pybytes()


class PointStore:
    """The points of one sweep in its directory: `<index>_<speed>rpm.parquet`
    and `<index>_<speed>rpm.fmustate`, index in sweep order."""

    def __init__(self, directory, speeds):
        self.dir = Path(directory)
        self.speeds = list(speeds)
        self.width = max(3, len(str(len(self.speeds) - 1)))

    def name(self, i):
        return f"{i:0{self.width}d}_{self.speeds[i]:g}rpm"

    def result_path(self, i):
        return self.dir / f"{self.name(i)}.parquet"

    def state_path(self, i):
        return self.dir / f"{self.name(i)}{STATE_SUFFIX}"

    def done(self):
        """Finished points: the length of the run of results from index 0."""
        k = 0
        while k < len(self.speeds) and self.result_path(k).is_file():
            k += 1
        return k

    def row(self, i):
        return pq.read_table(self.result_path(i)).to_pylist()[0]

    def duty_path(self, i):
        return self.dir / f"{self.name(i)}{DUTY_SUFFIX}"

    def state(self, i):
        return read_input(self.state_path(i), "record")

    def write(self, i, table, state, duty):
        # The state and the duty first: a result on disk always has them beside it.
        write_atomic(self.state_path(i), state)
        write_duty_cycle(self.duty_path(i), duty)
        write_atomic(self.result_path(i), table_bytes(table))


def task_directory(output_dir, label, torque, direction):
    return Path(output_dir) / "points" / f"{label}_T{torque:g}_{direction}"


def _emit(topic, msg, on_point):
    if on_point is not None:
        on_point(msg)
        return
    try:
        from distributed import get_worker

        get_worker().log_event(topic, msg)
    except (ImportError, ValueError):
        pass


def run_task(spec, on_point=None):
    """Runs (or continues) one sweep; returns its summary. `spec` is the
    plain dict `runner.task_specs` builds; `on_point(msg)` is called after
    each written point when the task runs outside a Dask worker."""
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    started = time.perf_counter()
    cpu_started = time.process_time()
    speeds = spec["speeds"]
    store = PointStore(spec["dir"], speeds)
    store.dir.mkdir(parents=True, exist_ok=True)
    k = store.done()
    summary = {"key": spec["key"], "points": len(speeds), "resumed_from": k, "computed": 0, "init_s": 0.0,
               "fmu_step_s": 0.0, "wall_s": 0.0, "cpu_s": 0.0, "pid": os.getpid(), "host": socket.gethostname()}
    if k == len(speeds):
        summary["wall_s"] = time.perf_counter() - started
        return summary

    vr = spec["value_references"]
    outputs = spec["outputs"]
    real_out = [n for n, t in outputs if t == "Real"]
    int_out = [n for n, t in outputs if t == "Integer"]
    sch = schema(outputs)
    slave = FMU2Slave(guid=spec["guid"], unzipDirectory=spec["unzipdir"], modelIdentifier=spec["model_identifier"],
                      instanceName=spec["key"])
    # Logging off in-process (fmpy's logger shim); fmu_check has already
    # asked the FMU, with its reasons logged, whether it accepts this set-up.
    slave.instantiate(loggingOn=False)
    point = None
    try:
        slave.setupExperiment(startTime=0.0)
        p = spec["parameters"]
        for name, v in p["strings"].items():
            slave.setString([vr[name]], [v])
        for name, v in p["integers"].items():
            slave.setInteger([vr[name]], [v])
        for name, v in p["reals"].items():
            slave.setReal([vr[name]], [v])
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        t = 0.0
        if k > 0:
            path = store.state_path(k - 1)
            if not path.is_file():
                raise RuntimeError(f"{spec['key']}: point {k - 1} has a result but its FMU state {path} is missing; "
                                   f"remove {store.result_path(k - 1)} (and the points after it) to recompute it")
            try:
                saved = slave.deserializeFMUState(read_input(path, "record"))
                slave.setFMUState(saved)
                slave.freeFMUState(saved)
            except FMICallException as e:
                raise RuntimeError(f"{spec['key']}: the FMU cannot restore the state {path} ({e}): it was written "
                                   "by another FMU or with other parameters, or is damaged; remove it and its "
                                   "result to recompute the point") from None
            t = store.row(k - 1)["time_s"]
        summary["init_s"] = time.perf_counter() - started
        per_rev = spec["mesh_cycles_per_revolution"]
        cycles = spec["run_in_cycles"] + spec["window_cycles"]
        h_fixed = spec["communication_step"]
        for i in range(k, len(speeds)):
            point = (i, speeds[i])
            t_point = time.perf_counter()
            rpm = speeds[i]
            slave.setReal([vr["inputSpeedReference"]], [rpm * math.pi / 30])
            fm = per_rev * rpm / 60
            step_s = 0.0
            if h_fixed is None:
                h = 1.0 / fm
                for _ in range(cycles):
                    t0 = time.perf_counter()
                    slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)
                    step_s += time.perf_counter() - t0
                    t += h
            else:
                end = t + cycles / fm
                n = max(1, math.ceil(cycles / fm / h_fixed - 1e-9))
                for j in range(n):
                    h = h_fixed if j < n - 1 else end - t
                    t0 = time.perf_counter()
                    slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)
                    step_s += time.perf_counter() - t0
                    t += h
            values = dict(zip(real_out, slave.getReal([vr[n] for n in real_out]))) if real_out else {}
            if int_out:
                values.update(zip(int_out, slave.getInteger([vr[n] for n in int_out])))
            bad = [n for n, v in values.items() if not math.isfinite(v)]
            if bad:
                raise RuntimeError(f"{spec['key']}: at {rpm:g} rpm the FMU returned non-finite {', '.join(bad)}")
            saved = slave.getFMUState()
            state = slave.serializeFMUState(saved)
            slave.freeFMUState(saved)
            duty = slave.getString([vr["dutyCycle"]])[0]
            duty = duty.decode() if isinstance(duty, bytes) else duty
            row = {"label": spec["label"], "kappa": spec["kappa"], "state": spec["state"],
                   "sun_torque_nm": spec["torque"], "direction": spec["direction"], "index": i, "speed_rpm": rpm,
                   "mesh_frequency_hz": fm, "time_s": t, **values,
                   "sun_frms_n_per_mm": values["window.sunMeshFrms"] / spec["face_width_mm"],
                   "ring_frms_n_per_mm": values["window.ringMeshFrms"] / spec["face_width_mm"],
                   "fmu_step_s": step_s, "wall_s": 0.0}
            row["wall_s"] = time.perf_counter() - t_point
            store.write(i, pa.Table.from_pylist([row], schema=sch), state, duty)
            summary["computed"] += 1
            summary["fmu_step_s"] += step_s
            _emit(spec["topic"], {"key": spec["key"], "index": i}, on_point)
        point = None
        slave.terminate()
    except FMICallException as e:
        where = f" at {point[1]:g} rpm (point {point[0]})" if point else " during initialization"
        raise RuntimeError(f"{spec['key']}: the FMU failed{where}: {e}") from None
    finally:
        slave.freeInstance()
    summary["wall_s"] = time.perf_counter() - started
    summary["cpu_s"] = time.process_time() - cpu_started
    return summary


def task_fingerprint(spec):
    """What a task's results depend on; a directory holding points of another
    fingerprint is not continued."""
    keep = {k: spec[k] for k in ("fmu_sha256", "scene_sha256", "state_sha256", "label", "kappa", "torque",
                                 "direction", "speeds", "communication_step", "run_in_cycles", "window_cycles",
                                 "parameters", "outputs")}
    return json.loads(json.dumps(keep))
