"""The campaign runner: a checked campaign's sweeps on Dask, one task per
(wear state, sun torque, direction), every point written atomically, an
interrupted campaign resumed where it stopped.

Tasks run on a Dask LocalCluster (one process per core, one thread each) or
on the cluster whose scheduler address is given; each task instantiates its
own FMU, so instances are never shared. A task whose worker dies is run
again by Dask and continues from its last written point (sweep). At the end
the points are gathered into results.parquet and results.csv, the F^(rms)
plots are drawn and summary.json records the run. The file format and the
resume semantics are in docs/CAMPAIGNS.md; the command line is `campaign`.

Layer 3 (campaign running): this module owns the task specifications
(`extract_fmu`, `task_specs`, `claim_task_directories`), the Dask client
(`dask_client`), `run_campaign` and its summary (`print_summary`,
`CampaignRunError`) and the gathered results (`consolidate`,
`read_points_of`). Of the package it imports `files`, `campaign_file`,
`fmu_check` (`task_parameters`), `sweep` and `plots`, all below it; the
front ends (`loop`, `bench`, the command line `campaign`) import it, never
the reverse.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import sys
import time
import uuid
from pathlib import Path

from .campaign_file import CampaignError, Problem
from .extras import require
from .files import read_input, remove_stale_temps, write_atomic
from .fmu_check import task_parameters
from .plots import plot_results
from .sweep import PointStore, run_task, table_bytes, task_directory, task_fingerprint


class CampaignRunError(RuntimeError):
    """Some sweeps failed; their finished points stay on disk for a rerun."""

    def __init__(self, summary):
        self.summary = summary
        lines = "\n".join(f"  - {f['key']}: {f['error']}" for f in summary["failed"])
        super().__init__(f"{len(summary['failed'])} sweep(s) failed (finished points are kept; "
                         f"fix the cause and run again to continue):\n{lines}")


def extract_fmu(campaign):
    """The FMU unpacked once into <output_dir>/.fmu/<sha256 prefix>/ (or the
    campaign's `unpack_dir`; a temporary directory renamed into place),
    shared by the tasks."""
    from fmpy import extract

    root = campaign.unpack_dir or campaign.output_dir / ".fmu"
    target = root / campaign.fmu_sha256[:16]
    if (target / "modelDescription.xml").is_file():
        return target
    root.mkdir(parents=True, exist_ok=True)
    tmp = root / f".tmp-{os.getpid()}-{uuid.uuid4().hex[:8]}"
    extract(str(campaign.fmu), str(tmp))
    try:
        os.rename(tmp, target)
    except OSError:
        # Another process placed it first.
        shutil.rmtree(tmp, ignore_errors=True)
    return target


def task_specs(campaign, topic="planetwear-campaign"):
    """One plain dict per sweep (what `sweep.run_task` needs), in campaign order."""
    from fmpy import read_model_description

    unzipdir = extract_fmu(campaign)
    md = read_model_description(str(unzipdir / "modelDescription.xml"))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    scene_sha = hashlib.sha256(campaign.scene.text.encode()).hexdigest()
    specs = []
    for state, torque, direction in campaign.tasks():
        speeds = list(campaign.speeds) if direction == "up" else list(reversed(campaign.speeds))
        specs.append({
            "key": f"{state.label}_T{torque:g}_{direction}",
            "topic": topic,
            "dir": str(task_directory(campaign.output_dir, state.label, torque, direction)),
            "unzipdir": str(unzipdir),
            "guid": md.guid,
            "model_identifier": md.coSimulation.modelIdentifier,
            "value_references": vr,
            "parameters": task_parameters(campaign.scene, campaign.integrator, campaign.window_cycles,
                                          state.fmu_value, torque, speeds[0]),
            "speeds": speeds,
            "direction": direction,
            "label": state.label,
            "kappa": state.kappa,
            "state": state.fmu_value,
            "torque": torque,
            "mesh_cycles_per_revolution": campaign.scene.mesh_cycles_per_revolution(),
            "communication_step": campaign.communication_step,
            "run_in_cycles": campaign.run_in_cycles,
            "window_cycles": campaign.window_cycles,
            "outputs": [(n, campaign.output_types[n]) for n in campaign.outputs],
            "face_width_mm": campaign.scene.face_width * 1e3,
            "fmu_sha256": campaign.fmu_sha256,
            "scene_sha256": scene_sha,
            "state_sha256": state.sha256,
        })
    return specs


def _fingerprint(spec):
    f = task_fingerprint(spec)
    # Paths may move with the output directory; the checksums pin the files.
    f["parameters"] = {k: v for k, v in f["parameters"].items() if k != "strings"}
    return f


def claim_task_directories(campaign, specs):
    """Checks that no task directory holds points of another campaign, then
    records each task's fingerprint (task.json) and removes temporary files
    left by a killed writer. Raises CampaignError before anything is written."""
    problems = []
    for spec in specs:
        d = Path(spec["dir"])
        meta = d / "task.json"
        if meta.is_file():
            old = json.loads(read_input(meta, "record"))
            new = _fingerprint(spec)
            if old != new:
                diff = sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))
                problems.append(Problem("output_dir", str(campaign.output_dir),
                                        f"{d.name} holds points of another campaign (differs in: {', '.join(diff)}); "
                                        "choose another output_dir or remove that directory"))
        elif d.is_dir() and any(d.glob("*.parquet")):
            problems.append(Problem("output_dir", str(campaign.output_dir),
                                    f"{d.name} holds points without a task.json; remove it or choose another output_dir"))
    if problems:
        raise CampaignError(campaign.source, problems)
    for spec in specs:
        d = Path(spec["dir"])
        d.mkdir(parents=True, exist_ok=True)
        remove_stale_temps(d)
        if not (d / "task.json").is_file():
            write_atomic(d / "task.json", json.dumps(_fingerprint(spec), indent=1).encode())


@contextlib.contextmanager
def dask_client(scheduler=None, workers=None):
    """A Dask client: of the scheduler at `scheduler`, or of a new
    LocalCluster with `workers` processes (default: one per core), one thread
    each."""
    require("dask", "running a campaign")
    from distributed import Client, LocalCluster

    if scheduler:
        client = Client(scheduler)
        try:
            yield client
        finally:
            client.close()
        return
    n = workers or os.cpu_count() or 1
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=40)
    client = Client(cluster)
    try:
        yield client
    finally:
        client.close()
        cluster.close()


def _workers(client):
    info = client.scheduler_info()
    return sum(w.get("nthreads", 1) for w in info.get("workers", {}).values())


def run_campaign(campaign, client=None, scheduler=None, workers=None, progress=True, plots=True):
    """Runs (or continues) a checked campaign; returns its summary (also
    written to <output_dir>/summary.json). Uses `client` when given, else a
    client of `scheduler`, else a LocalCluster of `workers` processes."""
    if client is None:
        with dask_client(scheduler, workers) as c:
            return run_campaign(campaign, client=c, progress=progress, plots=plots)
    from distributed import as_completed

    started = time.perf_counter()
    run_id = uuid.uuid4().hex[:8]
    topic = f"planetwear-campaign-{run_id}"
    specs = task_specs(campaign, topic)
    claim_task_directories(campaign, specs)
    done_before = {s["key"]: PointStore(s["dir"], s["speeds"]).done() for s in specs}
    total = sum(len(s["speeds"]) for s in specs)
    before = sum(done_before.values())
    todo = [s for s in specs if done_before[s["key"]] < len(s["speeds"])]

    bar = None
    if progress and todo:
        from tqdm import tqdm

        bar = tqdm(total=total, initial=before, unit="point", desc=campaign.source.stem, file=sys.stderr)
        client.subscribe_topic(topic, lambda event: bar.update(1))
    n_workers = _workers(client)
    futures = {client.submit(run_task, s, key=f"{s['key']}-{run_id}", pure=False): s for s in todo}
    results, failed = [], []
    try:
        for f in as_completed(list(futures)):
            spec = futures[f]
            if f.status == "finished":
                results.append(f.result())
            elif f.status == "error":
                failed.append({"key": spec["key"], "error": f"{type(f.exception()).__name__}: {f.exception()}"})
            else:
                failed.append({"key": spec["key"], "error": f"the task ended {f.status}"})
    finally:
        after = {s["key"]: PointStore(s["dir"], s["speeds"]).done() for s in specs}
        if bar is not None:
            client.unsubscribe_topic(topic)
            # Events may trail the results: the bar ends on what is on disk.
            bar.n = sum(after.values())
            bar.refresh()
            bar.close()
    wall = time.perf_counter() - started
    # Workers of a running cluster may join while the campaign runs.
    n_workers = max(n_workers, _workers(client))
    computed = sum(after.values()) - before
    by_key = {r["key"]: r for r in results}
    tasks = []
    for s in specs:
        r = by_key.get(s["key"], {})
        tasks.append({"key": s["key"], "points": len(s["speeds"]), "done_before": done_before[s["key"]],
                      "done": after[s["key"]], "resumed_from": r.get("resumed_from"),
                      "restarted": r.get("resumed_from", 0) > done_before[s["key"]],
                      "init_s": r.get("init_s"), "fmu_step_s": r.get("fmu_step_s"), "wall_s": r.get("wall_s"),
                      "cpu_s": r.get("cpu_s")})
    summary = {
        "campaign": str(campaign.source),
        "output_dir": str(campaign.output_dir),
        "points": total,
        "points_done": sum(after.values()),
        "points_before": before,
        "computed": computed,
        "sweeps": len(specs),
        "sweeps_run": len(todo),
        "workers": n_workers,
        "wall_s": wall,
        "points_per_s": computed / wall if wall > 0 else 0.0,
        "points_per_s_per_core": computed / wall / max(1, n_workers) if wall > 0 else 0.0,
        "tasks": tasks,
        "failed": failed,
    }
    summary["files"] = consolidate(campaign.output_dir, specs, plots=plots)
    write_atomic(campaign.output_dir / "summary.json", json.dumps(summary, indent=1).encode())
    if failed:
        raise CampaignRunError(summary)
    return summary


def consolidate(output_dir, specs, plots=True):
    """<output_dir>/results.parquet and results.csv of every point of the
    sweeps `specs` (each point once: one file per point), and the plots."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    tables = [t for t in (read_points_of(s) for s in specs) if t is not None]
    if not tables:
        return []
    table = pa.concat_tables(tables, promote_options="default")
    keys = list(zip(*(table.column(c).to_pylist() for c in ("label", "sun_torque_nm", "direction", "index"))))
    if len(set(keys)) != len(keys):
        raise RuntimeError("a point appears twice in the results: the output directory was written by two campaigns")
    out = Path(output_dir)
    write_atomic(out / "results.parquet", table_bytes(table))
    buf = pa.BufferOutputStream()
    pacsv.write_csv(table, buf)
    write_atomic(out / "results.csv", buf.getvalue().to_pybytes())
    files = [str(out / "results.parquet"), str(out / "results.csv")]
    if plots:
        files += [str(p) for p in plot_results(table, out / "plots")]
    return files


def read_points_of(spec):
    import pyarrow as pa
    import pyarrow.parquet as pq

    store = PointStore(spec["dir"], spec["speeds"])
    files = [store.result_path(i) for i in range(store.done())]
    if not files:
        return None
    return pa.concat_tables([pq.read_table(f) for f in files])


def print_summary(s, out=sys.stdout):
    print(f"{s['points_done']}/{s['points']} points in {s['output_dir']} ({s['computed']} computed now, "
          f"{s['points_before']} found done); {s['sweeps_run']} of {s['sweeps']} sweeps run on {s['workers']} "
          f"worker(s) in {s['wall_s']:.1f} s: {s['points_per_s']:.2f} points/s, "
          f"{s['points_per_s_per_core']:.2f} points/s per core", file=out)
    restarted = [t["key"] for t in s["tasks"] if t["restarted"]]
    if restarted:
        print(f"continued after a lost worker: {', '.join(restarted)}", file=out)
