"""`campaign loop`: the campaign at κ, the wear stepper, the campaign at
κ + 1, … until a target κ or a target wear depth.

Each stage has its own directory <output_dir>/loop/kappa-<κ>/ holding the
stage's campaign file (the campaign with this one state), its results and
manifest.json: the campaign file, the state in and the state out (paths,
SHA-256, κ, deepest wear), the wear stepper's command and wall time, the
points and the stage's wall time. The states the stepper writes are in
<output_dir>/loop/states/. A loop run again continues: a stage's finished
points are not recomputed (the campaign resumes) and a state already
written is not stepped again. At the end the stages' points are gathered
into <output_dir>/loop/results.parquet and .csv with the plots over κ,
and with `[loop] hours_per_stage` the deepest wear against operating hours
(`loop/plots/wear_hours.png`).

Layer 4 (front end): this module owns the loop (`run_loop`, `stage_raw`,
`print_loop`, `LoopError`). Of the package it imports `files`,
`campaign_file`, `fmu_check` (`load_campaign` for each stage's file),
`sweep` (each sweep's duty-cycle files), `plots` and `runner`, all below it; only the command line (`campaign`) imports it.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
import zipfile
from pathlib import Path

from . import campaign_file
from .campaign_file import CampaignError, Problem, check_state_document, find_planetwear_bin, max_wear_depth
from .files import read_input, sha256_file, write_atomic
from .fmu_check import load_campaign
from .runner import consolidate, dask_client, print_summary, run_campaign, task_specs
from .sweep import PointStore

MAX_STAGES = 200


class LoopError(RuntimeError):
    """The loop could not go on (the wear stepper refused); the finished
    stages and their manifests are kept."""


def _state_record(path):
    data = read_input(path, "worn_state")
    content, reason = check_state_document(data.decode("utf-8", errors="replace"))
    if reason:
        raise RuntimeError(f"{path}: {reason}")
    import hashlib

    return {"path": str(path), "sha256": hashlib.sha256(data).hexdigest(), "kappa": content["kappa"],
            "max_wear_um": max_wear_depth(content) * 1e6,
            "operating_hours": content.get("operating_time", 0.0) / 3600.0}


def _starting_state(campaign, from_state, states_dir):
    """The loop's first state as a file (a resource of the FMU is copied out
    of it), and the campaign entry it came from."""
    raw_states = campaign.raw["wear"]["states"]
    entry = from_state if from_state is not None else raw_states[-1]
    if entry == "":
        return None, entry
    p = Path(entry)
    if not p.is_absolute():
        p = campaign.source.parent / p
    if p.is_file():
        return p.resolve(), entry
    with zipfile.ZipFile(campaign.fmu) as z:
        name = f"resources/{entry}"
        if name in z.namelist():
            states_dir.mkdir(parents=True, exist_ok=True)
            out = states_dir / Path(entry).name
            if not out.is_file():
                write_atomic(out, z.read(name))
            return out, entry
    raise CampaignError(campaign.source, [Problem("--from-state", entry, "no such state file nor FMU resource")])


def stage_raw(campaign, state_path, output_dir):
    """The campaign file of one stage: the campaign with this single state,
    every path absolute."""
    raw = json.loads(json.dumps(campaign.raw))
    raw["fmu"] = str(campaign.fmu)
    raw["scene"] = campaign.scene.cli_value
    raw["output_dir"] = str(output_dir)
    if campaign.planetwear_bin:
        raw["planetwear_bin"] = str(Path(campaign.source.parent, campaign.planetwear_bin).resolve())
    raw["wear"] = {"states": [str(state_path) if state_path else ""]}
    return raw


def run_loop(campaign, to_kappa=None, to_wear_um=None, from_state=None, client=None, scheduler=None,
             workers=None, progress=True):
    """Runs the loop; returns its record (also <output_dir>/loop/loop.json)."""
    problems = []
    if to_kappa is None and to_wear_um is None:
        problems.append(Problem("--to-kappa/--to-wear-um", None, "give a target κ or a target wear depth [µm]"))
    if to_kappa is not None and (not isinstance(to_kappa, int) or to_kappa < 0):
        problems.append(Problem("--to-kappa", to_kappa, "must be a whole number ≥ 0"))
    if to_wear_um is not None and not (to_wear_um > 0 and to_wear_um < 1e4):
        problems.append(Problem("--to-wear-um", to_wear_um, "must be a positive wear depth [µm]"))
    exe = find_planetwear_bin(campaign.planetwear_bin, campaign.source.parent)
    if exe is None:
        problems.append(Problem("planetwear_bin", campaign.planetwear_bin or "(not set)",
                                "the wear stepper is needed: set planetwear_bin, PLANETWEAR_BIN or put planetwear "
                                "on PATH"))
    if problems:
        raise CampaignError(campaign.source, problems)
    if client is None:
        with dask_client(scheduler, workers) as c:
            return run_loop(campaign, to_kappa, to_wear_um, from_state, client=c, progress=progress)

    root = campaign.output_dir / "loop"
    states_dir = root / "states"
    state, _ = _starting_state(campaign, from_state, states_dir)
    stages = []
    started = time.perf_counter()
    all_specs = []
    for _ in range(MAX_STAGES):
        t_stage = time.perf_counter()
        stage_started = time.strftime("%Y-%m-%dT%H:%M:%S%z")
        rec_in = _state_record(state) if state else {"path": "", "sha256": "", "kappa": 0, "max_wear_um": 0.0,
                                                     "operating_hours": 0.0}
        kappa = rec_in["kappa"]
        stage_dir = root / f"kappa-{kappa}"
        stage_dir.mkdir(parents=True, exist_ok=True)
        raw = stage_raw(campaign, state, stage_dir)
        stage_file = stage_dir / "campaign.toml"
        write_atomic(stage_file, campaign_file.dumps_toml(raw).encode())
        stage = load_campaign(stage_file)
        stage.unpack_dir = root / ".fmu"
        summary = run_campaign(stage, client=client, progress=progress, plots=False)
        print_summary(summary, out=sys.stderr)
        all_specs += task_specs(stage)
        last = (to_kappa is not None and kappa >= to_kappa) or (
            to_wear_um is not None and rec_in["max_wear_um"] >= to_wear_um)
        step = None
        if not last:
            lp = campaign.loop
            hours = lp.get("hours_per_stage")
            # With hours_per_stage the duty cycle decides how far κ goes: the file is named by the stage.
            out = states_dir / (f"stage-{len(stages) + 1}.json" if hours else f"kappa-{kappa + 1}.json")
            cmd = [exe, "wear", "step", "--scene", stage.scene.cli_value, "--out", str(out)]
            if state:
                cmd += ["--state", str(state)]
            if hours:
                # The loads this stage's campaign produced: each sweep's duty up to its last point.
                for spec in task_specs(stage):
                    store = PointStore(spec["dir"], spec["speeds"])
                    cmd += ["--duty-cycle", str(store.duty_path(len(spec["speeds"]) - 1))]
                cmd += ["--hours", str(hours)]
            if "threshold_um" in lp:
                cmd += ["--threshold", str(lp["threshold_um"])]
            if lp.get("ring"):
                cmd += ["--ring"]
            if "dynamic_speed_rpm" in lp:
                cmd += ["--dynamic-speed", str(lp["dynamic_speed_rpm"])]
            failure, wall = None, None
            if not out.is_file():
                states_dir.mkdir(parents=True, exist_ok=True)
                t0 = time.perf_counter()
                proc = subprocess.run(cmd, capture_output=True, text=True)
                wall = time.perf_counter() - t0
                if proc.returncode != 0:
                    failure = proc.stderr.strip()
            step = {"command": cmd, "wall_s": wall,
                    "state_out": _state_record(out) if failure is None else None, "error": failure}
        this_run = {
            "started": stage_started,
            "campaign": {k: summary[k] for k in ("points", "points_done", "computed", "points_before", "wall_s",
                                                 "points_per_s", "points_per_s_per_core", "workers", "files")},
            "wear_step_run": step is not None and step["wall_s"] is not None,
            "wall_s": time.perf_counter() - t_stage,
        }
        # A stage run again keeps the record of its earlier runs and of the
        # wear step that made its output state (not repeated).
        old = {}
        if (stage_dir / "manifest.json").is_file():
            old = json.loads(read_input(stage_dir / "manifest.json", "record"))
        if step is not None and step["wall_s"] is None and old.get("wear_step"):
            if (old["wear_step"].get("state_out") or {}).get("sha256") == step["state_out"]["sha256"]:
                step = old["wear_step"]
        manifest = {
            "stage": len(stages),
            "kappa": kappa,
            "campaign_file": {"path": str(stage_file), "sha256": sha256_file(stage_file)},
            "state_in": rec_in,
            "points": summary["points"],
            "wear_step": step,
            "runs": old.get("runs", []) + [this_run],
        }
        write_atomic(stage_dir / "manifest.json", json.dumps(manifest, indent=1).encode())
        stages.append(manifest)
        if step is not None and step["error"]:
            raise LoopError(f"the wear stepper refused to go on from κ = {kappa} ({' '.join(cmd)}): {step['error']}; "
                            f"stages up to κ = {kappa} are complete (manifests in {root})")
        if last:
            break
        state = Path(step["state_out"]["path"])
    else:
        raise RuntimeError(f"the loop reached {MAX_STAGES} stages without reaching its target")

    files = consolidate(root, all_specs, plots=True)
    record = {"campaign": str(campaign.source), "to_kappa": to_kappa, "to_wear_um": to_wear_um,
              "stages": [{"kappa": s["kappa"], "manifest": str(root / f"kappa-{s['kappa']}" / "manifest.json"),
                          "points": s["points"], "computed": s["runs"][-1]["campaign"]["computed"],
                          "max_wear_um": s["state_in"]["max_wear_um"],
                          "operating_hours": s["state_in"].get("operating_hours", 0.0),
                          "wall_s": s["runs"][-1]["wall_s"]}
                         for s in stages],
            "wall_s": time.perf_counter() - started, "files": files}
    if any(s["operating_hours"] for s in record["stages"]):
        from .plots import plot_wear_against_hours

        record["files"].append(str(plot_wear_against_hours(record["stages"], root / "plots" / "wear_hours.png")))
    write_atomic(root / "loop.json", json.dumps(record, indent=1).encode())
    return record


def print_loop(record):
    for s in record["stages"]:
        print(f"κ = {s['kappa']}: deepest wear {s['max_wear_um']:.2f} µm after {s['operating_hours']:.4g} h of "
              f"operation, {s['points']} points ({s['computed']} "
              f"computed now), {s['wall_s']:.1f} s "
              f"({s['manifest']})")
    print(f"loop: {len(record['stages'])} stage(s) in {record['wall_s']:.1f} s; gathered results and plots: "
          f"{', '.join(record['files'][:2])}")
