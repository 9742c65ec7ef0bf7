"""The study end to end, after the wear model (docs/MODEL.md §4–5): speed sweeps up
and down of the planetwear FMU at the worn-profile states κ = 0, 2, 4, 6,
driven by fmpy (scripts/study_fmu.py), then the study's plots and a Markdown
report with its figures and how long each stage took.

Inputs: the packed FMU and the wear run's directory (`planetwear wear run`:
kappa-<κ>.json states and summary.json). The sweeps run in parallel, one
process per (κ, direction), each with its own FMU instance.

Run (scripts/study.sh does):
    .venv/bin/python scripts/study.py --fmu fmu/planetwear.fmu --wear out/wear --out out/study
"""

import argparse
import csv
import json
import math
import multiprocessing as mp
import os
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from fmpy import extract  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import study_fmu  # noqa: E402

COLORS = {0: "#1b9e77", 1: "#66a61e", 2: "#7570b3", 3: "#e6ab02", 4: "#d95f02", 5: "#a6761d", 6: "#e7298a"}


def write_atomic(path, text):
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def _task(args):
    fmu, unzipdir, kappa, state, speeds, direction, history_speeds, queue = args
    ordered = speeds if direction == "up" else list(reversed(speeds))

    def progress(i, n, row):
        queue.put((kappa, direction, i, n, row["speed_rpm"]))

    start = time.perf_counter()
    rows, histories = study_fmu.sweep(fmu, unzipdir, state, ordered, direction, history_speeds, progress,
                                      instance=f"kappa{kappa}-{direction}")
    for r in rows:
        r["kappa"] = kappa
    return kappa, direction, rows, histories, time.perf_counter() - start


def run_sweeps(fmu, wear_dir, kappas, speeds, history_speeds, workers):
    unzipdir = extract(str(fmu))
    manager = mp.Manager()
    queue = manager.Queue()
    tasks = []
    for kappa in kappas:
        state = "" if kappa == 0 else str((Path(wear_dir) / f"kappa-{kappa}.json").resolve())
        if state and not Path(state).exists():
            raise SystemExit(f"--wear {wear_dir}: no worn-profile state kappa-{kappa}.json (run `planetwear wear run`)")
        for direction in ("up", "down"):
            tasks.append((str(fmu), unzipdir, kappa, state, speeds, direction, history_speeds, queue))
    total = len(tasks) * len(speeds)
    done = 0
    results = []
    with mp.get_context("spawn").Pool(workers) as pool:
        pending = pool.map_async(_task, tasks)
        last_print = 0.0
        while not pending.ready() or not queue.empty():
            try:
                kappa, direction, i, n, rpm = queue.get(timeout=0.2)
            except Exception:
                continue
            done += 1
            now = time.perf_counter()
            if now - last_print > 2.0 or done == total:
                print(f"  sweeps: {done}/{total} points ({100 * done / total:.0f} %), last κ={kappa} {direction} "
                      f"{rpm:.0f} rpm", flush=True)
                last_print = now
        results = pending.get()
    return results


def plot_wear(summary, out):
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for ax, member in zip(axes, ("sun", "planet")):
        for state in summary["states"]:
            k = state["kappa"]
            flank = state["flanks"][member]
            ax.plot(flank["roll_deg"], flank["depth_um"], color=COLORS.get(k, "k"), label=f"κ = {k}")
        ax.axvline(summary["pitch_roll_deg"][member], color="0.6", ls=":", lw=1)
        ax.set_title(f"{member} flank (sun–planet mesh); dotted: pitch point")
        ax.set_xlabel("roll angle [deg]")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("wear depth [µm]")
    axes[1].legend()
    fig.tight_layout()
    fig.savefig(out / "wear_depth.png", dpi=130)
    plt.close(fig)


def plot_forced_response(rows, kappas, out, z_sun):
    fig, axes = plt.subplots(2, 1, figsize=(11, 7.5), sharex=True)
    for ax, mesh in zip(axes, ("sun", "ring")):
        for k in kappas:
            for direction, ls in (("up", "-"), ("down", "--")):
                sel = sorted((r for r in rows if r["kappa"] == k and r["direction"] == direction),
                             key=lambda r: r["speed_rpm"])
                x = [r["speed_rpm"] for r in sel]
                y = [r[f"{mesh}_frms"] for r in sel]
                ax.plot(x, y, ls, color=COLORS.get(k, "k"), lw=1.2,
                        label=f"κ = {k} {direction}" if mesh == "sun" else None)
                sep = [(r["speed_rpm"], r[f"{mesh}_frms"]) for r in sel if r[f"{mesh}_separation"] > 0]
                if sep:
                    ax.plot(*zip(*sep), "x", color=COLORS.get(k, "k"), ms=4)
        name = "sun–planet" if mesh == "sun" else "ring–planet"
        ax.set_ylabel(f"{name} F(rms) [N/mm]")
        ax.grid(alpha=0.3)
    axes[0].legend(ncol=4, fontsize=8)
    axes[0].set_title("Forced response, planet 1 (x: a tooth pair separates in the window)")
    axes[1].set_xlabel("input (sun) speed [rpm]")
    top = axes[0].secondary_xaxis("top", functions=(lambda r: r * z_sun / 60, lambda f: f * 60 / z_sun))
    top.set_xlabel("mesh frequency [Hz]")
    fig.tight_layout()
    fig.savefig(out / "forced_response.png", dpi=130)
    plt.close(fig)


def plot_histories(histories, kappas, speeds, out):
    fig, axes = plt.subplots(len(speeds), 2, figsize=(11, 3.2 * len(speeds)), squeeze=False)
    for row, rpm in enumerate(speeds):
        for col, mesh in enumerate(("sun", "ring")):
            ax = axes[row][col]
            for k in kappas:
                h = histories.get((k, rpm))
                if h is None:
                    continue
                fm = 34 * rpm / 60
                cycles = np.array(h["time_s"]) * fm
                ax.plot(cycles, np.array(h[f"{mesh}_force_n"]) / 30.0, color=COLORS.get(k, "k"), label=f"κ = {k}")
            ax.set_title(f"{rpm:.0f} rpm, {'sun' if mesh == 'sun' else 'ring'}–planet mesh, planet 1")
            ax.set_xlabel("mesh cycles")
            ax.set_ylabel("mesh force [N/mm]")
            ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "time_histories.png", dpi=130)
    plt.close(fig)


def plot_harmonics(rows, kappas, speeds, out):
    fig, axes = plt.subplots(len(speeds), 2, figsize=(11, 3.2 * len(speeds)), squeeze=False)
    for row, rpm in enumerate(speeds):
        for col, mesh in enumerate(("sun", "ring")):
            ax = axes[row][col]
            for i in range(1, 7):
                y = []
                for k in kappas:
                    r = next(r for r in rows if r["kappa"] == k and r["direction"] == "up" and r["speed_rpm"] == rpm)
                    y.append(r[f"{mesh}_f{i}"])
                ax.plot(kappas, y, "o-", label=f"F({i})")
            ax.set_title(f"{rpm:.0f} rpm, {'sun' if mesh == 'sun' else 'ring'}–planet mesh")
            ax.set_xlabel("κ (worn-profile state)")
            ax.set_ylabel("harmonic amplitude [N/mm]")
            ax.grid(alpha=0.3)
    axes[0][1].legend(ncol=3, fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "harmonics_vs_kappa.png", dpi=130)
    plt.close(fig)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--fmu", required=True)
    p.add_argument("--wear", required=True, help="directory of `planetwear wear run` (kappa-<κ>.json, summary.json)")
    p.add_argument("--out", required=True)
    p.add_argument("--kappas", default="0,2,4,6")
    p.add_argument("--from", dest="start", type=float, default=500.0)
    p.add_argument("--to", dest="stop", type=float, default=15000.0)
    p.add_argument("--step", type=float, default=250.0)
    p.add_argument("--off-resonance", type=float, nargs=2, default=[1500.0, 3000.0],
                   help="two off-resonance speeds [rpm] for the change of F(rms) with wear")
    p.add_argument("--resonance", type=float, default=8250.0,
                   help="a resonant speed [rpm] (2×f_m on the first rotational mode of the example)")
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    p.add_argument("--timings", default="", help="JSON file of earlier stages' timings to include in the report")
    a = p.parse_args()

    fmu, out = Path(a.fmu), Path(a.out)
    if not fmu.is_file():
        raise SystemExit(f"--fmu {fmu}: no such file (run `planetwear fmu pack`)")
    kappas = [int(k) for k in a.kappas.split(",")]
    if any(k < 0 for k in kappas):
        raise SystemExit(f"--kappas {a.kappas}: κ must be whole numbers ≥ 0")
    if not (0 < a.start <= a.stop) or a.step <= 0:
        raise SystemExit(f"--from {a.start} --to {a.stop} --step {a.step}: need 0 < from <= to and step > 0")
    speeds = study_fmu.grid(a.start, a.stop, a.step)
    focus = sorted([*a.off_resonance, a.resonance])
    for s in focus:
        if s not in speeds:
            raise SystemExit(f"speed {s:.0f} rpm is not on the grid {a.start:.0f}:{a.step:.0f}:{a.stop:.0f}")
    summary_path = Path(a.wear) / "summary.json"
    if not summary_path.is_file():
        raise SystemExit(f"--wear {a.wear}: no summary.json (run `planetwear wear run`)")
    summary = json.loads(summary_path.read_text())
    out.mkdir(parents=True, exist_ok=True)
    timings = {k: v for k, v in json.loads(Path(a.timings).read_text()).items() if k != "_"} if a.timings else {}

    print(f"== sweeps through the FMU: κ = {kappas}, {len(speeds)} speeds, up and down, {a.workers} processes",
          flush=True)
    start = time.perf_counter()
    results = run_sweeps(fmu, a.wear, kappas, speeds, focus, a.workers)
    timings["FMU sweeps (fmpy)"] = time.perf_counter() - start
    rows, histories = [], {}
    for kappa, direction, r, h, _ in results:
        rows.extend(r)
        if direction == "up":
            for rpm, hist in h.items():
                histories[(kappa, rpm)] = hist
    keys = list(rows[0].keys())
    with open(out / "sweeps.csv.tmp", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    os.replace(out / "sweeps.csv.tmp", out / "sweeps.csv")

    start = time.perf_counter()
    plot_wear(summary, out)
    plot_forced_response(rows, kappas, out, 34)
    plot_histories(histories, kappas, focus, out)
    plot_harmonics(rows, kappas, focus, out)
    timings["plots"] = time.perf_counter() - start

    def at(k, rpm, mesh, direction="up"):
        return next(r[f"{mesh}_frms"] for r in rows
                    if r["kappa"] == k and r["speed_rpm"] == rpm and r["direction"] == direction)

    report = ["# planetwear study: the example with worn flanks", "",
              f"Scene: {summary.get('scene', 'example-2004')}. FMU: `{fmu}`. Sweeps {a.start:.0f}–{a.stop:.0f} rpm in "
              f"{a.step:.0f} rpm steps, up and down, at κ = {', '.join(map(str, kappas))}; one input revolution "
              "of run-in and two revolutions measured per speed, the state carried from speed to speed.", "",
              "## Wear (quasi-static Archard, docs/MODEL.md §4)", "",
              "| κ | cycles (sun tooth) | input revolutions | max wear sun [µm] at roll [deg] | "
              "max wear planet [µm] at roll [deg] |", "|---|---|---|---|---|"]
    for s in summary["states"]:
        report.append(f"| {s['kappa']} | {s['cycles_sun']:.4g} | {s['input_revolutions']:.4g} | "
                      f"{s['flanks']['sun']['max_um']:.2f} at {s['flanks']['sun']['max_roll_deg']:.1f} | "
                      f"{s['flanks']['planet']['max_um']:.2f} at {s['flanks']['planet']['max_roll_deg']:.1f} |")
    report += ["", "![wear depth](wear_depth.png)", "", "## Forced response", "",
               "![forced response](forced_response.png)", "",
               "Change of F(rms) (up sweep) from κ = 0 to each state:", "",
               "| speed | mesh | " + " | ".join(f"κ = {k} [N/mm]" for k in kappas) + f" | change κ {kappas[0]}→{kappas[-1]} |",
               "|---" * (len(kappas) + 3) + "|"]
    for rpm in focus:
        for mesh in ("sun", "ring"):
            vals = [at(k, rpm, mesh) for k in kappas]
            change = 100 * (vals[-1] / vals[0] - 1) if vals[0] else float("nan")
            kind = "resonant" if rpm == a.resonance else "off resonance"
            report.append(f"| {rpm:.0f} rpm ({kind}) | {mesh}–planet | " + " | ".join(f"{v:.3f}" for v in vals)
                          + f" | {change:+.1f} % |")
    report += ["", "![time histories](time_histories.png)", "", "![harmonics vs κ](harmonics_vs_kappa.png)", "",
               "## How long each stage took", "", "| stage | seconds |", "|---|---|"]
    for stage, sec in timings.items():
        report.append(f"| {stage} | {sec:.1f} |")
    pts = len(rows)
    sweep_time = timings["FMU sweeps (fmpy)"]
    report += ["", f"{pts} sweep points in {sweep_time:.1f} s on {a.workers} processes "
               f"({pts / sweep_time:.2f} points/s).", ""]
    write_atomic(out / "report.md", "\n".join(report))
    json_out = {"timings_s": timings, "points": pts,
                "frms_change_percent": {f"{rpm:.0f}": {m: 100 * (at(kappas[-1], rpm, m) / at(kappas[0], rpm, m) - 1)
                                                       for m in ("sun", "ring")} for rpm in focus}}
    write_atomic(out / "study.json", json.dumps(json_out, indent=2))
    print("\n".join(report))


if __name__ == "__main__":
    main()
