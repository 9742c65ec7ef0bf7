"""Plots of a campaign's results: F^(rms) of planet 1's mesh forces against
speed per mesh (sun–planet, ring–planet) for every wear state and torque,
and their change relative to κ = 0.

One pair of figures per sun torque: `frms_T<torque>.png` (every κ, sweep up
solid, down dashed) and `frms_change_T<torque>.png` (100 (F − F_κ0)/F_κ0 at
the same speed and direction). Files are written atomically.

Layer 2 (with the FMU access): this module owns the figures of a results
table (`plot_results`). Of the package it imports only `files`
(`write_atomic`). It sits below the runner because `runner.consolidate`
draws the plots of every run; the command line (`campaign plot`) and the
loop reach it through the runner or directly.
"""

from __future__ import annotations

import io
from collections import defaultdict
from pathlib import Path

from .extras import require
from .files import write_atomic

MESHES = (("sun_frms_n_per_mm", "sun–planet mesh"), ("ring_frms_n_per_mm", "ring–planet mesh"))


def _curves(rows):
    """{torque: {(kappa, label, direction): [(speed, sun, ring)] sorted by speed}}."""
    out = defaultdict(lambda: defaultdict(list))
    for r in rows:
        out[r["sun_torque_nm"]][(r["kappa"], r["label"], r["direction"])].append(
            (r["speed_rpm"], r["sun_frms_n_per_mm"], r["ring_frms_n_per_mm"]))
    for per in out.values():
        for v in per.values():
            v.sort()
    return out


def _save(fig, path):
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    write_atomic(path, buf.getvalue())


def plot_results(table, directory):
    """Draws the figures of a results table (pyarrow) into `directory`;
    returns the files written."""
    require("plot", "drawing a campaign's plots")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    rows = table.select(["label", "kappa", "sun_torque_nm", "direction", "speed_rpm", "sun_frms_n_per_mm",
                         "ring_frms_n_per_mm"]).to_pylist()
    files = []
    cmap = plt.get_cmap("viridis")
    for torque, curves in sorted(_curves(rows).items()):
        kappas = sorted({k for k, _, _ in curves})
        colour = {k: cmap(i / max(1, len(kappas) - 1) * 0.9) for i, k in enumerate(kappas)}
        style = {"up": "-", "down": "--"}
        path = directory / f"frms_T{torque:g}.png"
        _two_meshes(curves, colour, style, lambda pts, j, d: [(p[0], p[j]) for p in pts],
                    lambda title: f"{title}, {torque:g} N·m on the sun", "F$^{(rms)}$ of planet 1 [N/mm]", path)
        files.append(path)

        # Change relative to κ = 0 (the lowest κ when no κ = 0 was run).
        k0 = 0 if 0 in kappas else kappas[0]
        base = {(d, p[0]): p for (k, _, d), pts in curves.items() if k == k0 for p in pts}
        if len(kappas) < 2 or not base:
            continue

        def change(pts, j, direction, base=base):
            return [(p[0], 100 * (p[j] - base[(direction, p[0])][j]) / base[(direction, p[0])][j])
                    for p in pts if (direction, p[0]) in base and base[(direction, p[0])][j] != 0]

        path = directory / f"frms_change_T{torque:g}.png"
        _two_meshes({key: pts for key, pts in curves.items() if key[0] != k0}, colour, style, change,
                    lambda title: f"{title}, {torque:g} N·m: change against κ = {k0}",
                    f"F$^{{(rms)}}$ change against κ = {k0} [%]", path, zero_line=True)
        files.append(path)
    return files


def plot_wear_against_hours(stages, path):
    """The loop's deepest wear and κ against operating hours (`stages`: the
    loop record's stages, each with `operating_hours`, `max_wear_um` and
    `kappa`), one point per stage; written to `path`, returned."""
    require("plot", "drawing the loop's wear against operating hours")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    hours = [s["operating_hours"] for s in stages]
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    ax.plot(hours, [s["max_wear_um"] for s in stages], "o-", color="tab:red")
    for s in stages:
        ax.annotate(f"κ = {s['kappa']}", (s["operating_hours"], s["max_wear_um"]), textcoords="offset points",
                    xytext=(-6, 6), ha="right", fontsize=8)
    ax.set_xlabel("operating hours (the stages' duty cycles) [h]")
    ax.set_ylabel("deepest wear [µm]")
    ax.set_title("Wear against operating hours (campaign loop)")
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    _save(fig, Path(path))
    plt.close(fig)
    return Path(path)


def plot_drive_cycle(cycle, path):
    """A drive cycle's record (`drive_cycle.run_loop`'s cycle.json: time, sun speed and
    torque, planet 1's dynamic factor and F^(rms) of both meshes) against time: three
    panels (speed and torque; dynamic factor; F^(rms)); written to `path`, returned."""
    require("plot", "drawing the drive cycle")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = cycle["time"]
    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    ax = axes[0]
    ax.plot(t, [w * 30.0 / 3.141592653589793 for w in cycle["sun.speed"]], color="tab:blue", lw=0.8)
    ax.set_ylabel("sun speed [rpm]", color="tab:blue")
    twin = ax.twinx()
    twin.plot(t, cycle["sun_torque"], color="tab:red", lw=0.6)
    twin.set_ylabel("sun torque [N·m]", color="tab:red")
    ax.set_title("Drive cycle through the FMU (steady fidelity)")
    axes[1].plot(t, cycle["dynamic_factor"], color="k", lw=0.6)
    axes[1].set_ylabel("dynamic factor\nF_max / F_mean (sun–planet)")
    axes[2].plot(t, cycle["window.sunMeshFrms"], lw=0.6, label="sun–planet")
    axes[2].plot(t, cycle["window.ringMeshFrms"], lw=0.6, label="ring–planet")
    axes[2].set_ylabel("F^(rms) [N]")
    axes[2].set_xlabel("time [s]")
    axes[2].legend(fontsize=8)
    for a in axes:
        a.grid(alpha=0.3)
    fig.tight_layout()
    _save(fig, Path(path))
    plt.close(fig)
    return Path(path)


def plot_duty_histogram(doc, path):
    """The duty-cycle document `doc`'s revolutions per load-torque × input-speed bin of
    planet 1's sun–planet mesh as an image; written to `path`, returned."""
    require("plot", "drawing the duty-cycle histogram")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    duty = doc["content"]["duty"]
    torque, speed = duty["bins"]["torque"], duty["bins"]["speed"]
    nt, ns = len(torque) - 1, len(speed) - 1
    counts = duty["revolutions"][: nt * ns]
    grid = [[counts[i * ns + j] for i in range(nt)] for j in range(ns)]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    image = ax.pcolormesh(torque, [w * 30.0 / 3.141592653589793 for w in speed], grid, cmap="viridis", shading="flat")
    fig.colorbar(image, ax=ax, label="input revolutions")
    ax.set_xlabel("load torque [N·m]")
    ax.set_ylabel("input speed [rpm]")
    outside = duty["outside"][0]
    ax.set_title(f"Load duty, planet 1 sun–planet mesh ({duty['total']:.0f} rev; {outside:.0f} outside the bins)",
                 fontsize=9)
    fig.tight_layout()
    _save(fig, Path(path))
    plt.close(fig)
    return Path(path)


def _two_meshes(curves, colour, style, series, title, ylabel, path, zero_line=False):
    """One figure, a panel per mesh (sun–planet, ring–planet), a line per
    (κ, direction): `series(points, column, direction)` gives its (x, y)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), sharex=True)
    for ax, (col, mesh_title) in zip(axes, MESHES):
        j = 1 if col.startswith("sun") else 2
        for (kappa, label, direction), pts in sorted(curves.items()):
            xy = series(pts, j, direction)
            ax.plot([x for x, _ in xy], [y for _, y in xy], style.get(direction, "-"), color=colour[kappa],
                    marker=".", ms=3, lw=1.2, label=f"{label} {direction}")
        if zero_line:
            ax.axhline(0, color="k", lw=0.6)
        ax.set_title(title(mesh_title))
        ax.set_xlabel("input speed [rpm]")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)
