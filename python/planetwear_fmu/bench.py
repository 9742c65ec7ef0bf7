"""`campaign bench`: throughput of the campaign runner on the local cluster.

Runs the same set of sweeps (N sun torques, sweep up, unworn set, the
native sweep's settings: the default integrator of the FMU and of the scene
(RK 5(4); the FMU's relativeTolerance default 1e-5, the scene's
relative_tolerance 3e-6), 34 mesh cycles of run-in and 68 of
window, one mesh cycle per communication step) as a campaign on a LocalCluster of each worker count asked for, and
prints points per second, per core, and the scaling efficiency
(points/s per core against one worker). It also times one sweep in-process
(no Dask: the FMU's initialization, the time inside fmi2DoStep and the whole
point with its Parquet and state files) and the native `planetwear sweep` of
the same speeds, the fmpy overhead being the ratio of the per-point times.
The figures are recorded in docs/CAMPAIGNS.md with the command.

Layer 4 (front end): this module owns the bench (`run_bench`, `bench_raw`)
and its command-line options (`add_arguments`, which the command line
`campaign` adds to its `bench` subcommand). Of the package it imports
`campaign_file`, `fmu_check` (`load_campaign`), `sweep` and `runner`, all
below it; only the command line (`campaign`) imports it.
"""

from __future__ import annotations

import json
import os
import shutil
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

from . import campaign_file
from .fmu_check import load_campaign
from .runner import dask_client, extract_fmu, run_campaign, task_specs
from .sweep import PointStore, run_task

REPO = Path(__file__).resolve().parents[2]


def add_arguments(q):
    q.add_argument("--fmu", default=str(REPO / "fmu" / "planetwear.fmu"))
    q.add_argument("--scene", default="example-2004")
    q.add_argument("--tasks", type=int, default=6, help="sweeps per run (N sun torques around 750 N·m)")
    q.add_argument("--from-rpm", type=float, default=1000.0)
    q.add_argument("--to-rpm", type=float, default=6000.0)
    q.add_argument("--step-rpm", type=float, default=250.0)
    q.add_argument("--workers-list", default="1,2", help="worker counts of the local cluster, comma-separated")
    q.add_argument("--out", help="keep the bench's files here (default: a temporary directory, removed)")
    q.add_argument("--json", action="store_true", help="print the figures as JSON too")


def bench_raw(a, output_dir):
    torques = [750.0 + 25.0 * (i - a.tasks // 2) for i in range(a.tasks)]
    return {
        "fmu": str(Path(a.fmu).resolve()),
        "scene": a.scene,
        "output_dir": str(output_dir),
        "wear": {"states": [""]},
        "speeds": {"from_rpm": a.from_rpm, "to_rpm": a.to_rpm, "step_rpm": a.step_rpm, "directions": "up"},
        "load": {"sun_torque_nm": torques},
        "timing": {"communication_step": "mesh cycle", "run_in_cycles": 34, "window_cycles": 68},
    }


def run_bench(a):
    workers_list = [int(x) for x in str(a.workers_list).split(",") if x.strip()]
    if a.tasks < 1 or not workers_list or min(workers_list) < 1:
        raise SystemExit("bench: --tasks and every --workers-list entry must be at least 1")
    root = Path(a.out) if a.out else Path(tempfile.mkdtemp(prefix="planetwear-bench-"))
    root.mkdir(parents=True, exist_ok=True)
    try:
        figures = _bench(a, workers_list, root)
    finally:
        if not a.out:
            shutil.rmtree(root, ignore_errors=True)
    if a.json:
        print(json.dumps(figures, indent=1))
    return figures


def _bench(a, workers_list, root):
    src = root / "bench.toml"
    cores = os.cpu_count()
    figures = {"cores": cores, "tasks": a.tasks, "runs": [], "load_average_1min_at_start": os.getloadavg()[0]}
    print(f"{cores} cores; load average {os.getloadavg()[0]:.2f} at the start (other processes share the cores)")

    # One sweep in-process, no Dask: the FMU's own cost per point.
    raw = bench_raw(a, root / "inprocess")
    src.write_text(campaign_file.dumps_toml(raw))
    c = load_campaign(src)
    spec = next(s for s in task_specs(c) if s["torque"] == 750.0) if 750.0 in c.torques else task_specs(c)[0]
    t0 = time.perf_counter()
    r = run_task(spec)
    wall = time.perf_counter() - t0
    store = PointStore(spec["dir"], spec["speeds"])
    rows = [store.row(i) for i in range(store.done())]
    n = len(rows)
    point_s = statistics.fmean(x["wall_s"] for x in rows)
    step_s = statistics.fmean(x["fmu_step_s"] for x in rows)
    figures["inprocess"] = {"points": n, "wall_s": wall, "init_s": r["init_s"], "point_s": point_s,
                            "fmu_step_s": step_s}
    print(f"in-process sweep (fmpy, no Dask): {n} points in {wall:.2f} s; initialization {r['init_s']:.2f} s, "
          f"{point_s * 1e3:.1f} ms per point of which {step_s * 1e3:.1f} ms in fmi2DoStep")

    # The native sweep of the same speeds and settings.
    exe = campaign_file.find_planetwear_bin(None)
    if exe:
        out = root / "native"
        cmd = [exe, "sweep", "--scene", a.scene, "--from", f"{a.from_rpm:g}", "--to", f"{a.to_rpm:g}", "--step",
               f"{a.step_rpm:g}", "--direction", "up", "--out", str(out), "--json"]
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True, text=True)
        proc_wall = time.perf_counter() - t0
        summary = json.loads((out / "sweep.json").read_text())
        native_point = summary["wall_time_s"] / summary["speeds"]
        figures["native"] = {"command": " ".join(cmd[1:]), "points": summary["speeds"],
                             "sweep_s": summary["wall_time_s"], "process_s": proc_wall, "point_s": native_point,
                             "overhead_point": point_s / native_point, "overhead_step": step_s / native_point}
        print(f"native `planetwear sweep` of the same speeds: {summary['speeds']} points in "
              f"{summary['wall_time_s']:.2f} s of sweep ({proc_wall:.2f} s for the whole process), "
              f"{native_point * 1e3:.1f} ms per point")
        print(f"fmpy overhead per point: {point_s / native_point:.2f}× the native time with the Parquet and state "
              f"files, {step_s / native_point:.2f}× inside fmi2DoStep alone")
    else:
        print("native sweep not timed: no planetwear binary (set PLANETWEAR_BIN)")

    # The campaign on the local cluster at each worker count.
    base = None
    for w in workers_list:
        raw = bench_raw(a, root / f"workers-{w}")
        src.write_text(campaign_file.dumps_toml(raw))
        c = load_campaign(src)
        extract_fmu(c)
        with dask_client(workers=w) as client:
            # Warm the workers (imports) so the run times the sweeps.
            client.run(lambda: __import__("planetwear_fmu.sweep") and __import__("fmpy.fmi2"))
            s = run_campaign(c, client=client, progress=False, plots=False)
        pps = s["points_per_s"]
        per_core = pps / w
        if base is None and w == min(workers_list):
            base = per_core
        eff = per_core / base if base else float("nan")
        ran = [t for t in s["tasks"] if t["init_s"] is not None]
        task_init = statistics.fmean(t["init_s"] for t in ran)
        cpu = sum(t["cpu_s"] for t in ran)
        load = os.getloadavg()[0]
        run = {"workers": w, "points": s["computed"], "sweeps": s["sweeps_run"], "wall_s": s["wall_s"],
               "points_per_s": pps, "points_per_s_per_core": per_core, "efficiency": eff,
               "task_init_s": task_init, "task_cpu_s": cpu, "points_per_cpu_s": s["computed"] / cpu,
               "cpu_share": cpu / (s["wall_s"] * w), "load_average_1min": load}
        figures["runs"].append(run)
        print(f"{w} worker(s): {s['computed']} points ({s['sweeps_run']} sweeps × {len(c.speeds)} speeds) in "
              f"{s['wall_s']:.2f} s: {pps:.2f} points/s, {per_core:.2f} points/s per core, "
              f"scaling efficiency {eff:.2f}; FMU initialization {task_init:.2f} s per sweep; "
              f"the sweeps' CPU time {cpu:.1f} s ({s['computed'] / cpu:.2f} points per CPU-second, "
              f"{100 * run['cpu_share']:.0f} % of {w} core(s) over the run); load average {load:.2f}")
    return figures
