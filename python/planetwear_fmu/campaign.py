"""Campaigns of the planetwear FMU on Dask: wear states × sun torques ×
directions, one continuation sweep per task, every point written atomically,
an interrupted campaign resumed where it stopped.

    python -m planetwear_fmu.campaign run FILE [--scheduler tcp://HOST:8786] [--workers N]
    python -m planetwear_fmu.campaign check FILE
    python -m planetwear_fmu.campaign loop FILE --to-kappa K | --to-wear-um D
    python -m planetwear_fmu.campaign bench [--tasks N] [--workers-list 1,2]
    python -m planetwear_fmu.campaign plot OUTPUT_DIR

The campaign file is checked whole before any work starts (campaign_file,
fmu_check). Tasks run on a Dask LocalCluster (one process per core, one
thread each) or on the cluster whose scheduler address is given; each task
instantiates its own FMU, so instances are never shared. A task whose worker
dies is run again by Dask and continues from its last written point (sweep).
At the end the points are gathered into results.parquet and results.csv,
the F^(rms) plots are drawn and summary.json records the run. The file
format and the resume semantics are in docs/CAMPAIGNS.md.

Layer 5, the top (front end): this module owns the command line, `main`
(the `planetwear-campaign` script of python/pyproject.toml and
`python -m planetwear_fmu.campaign`), and nothing else. The runner itself
is `runner` (layer 3); its names are re-exported here, so
`planetwear_fmu.campaign.run_campaign` and the others still work. Every
module of the package is below it, so it may import any of them (it uses
`campaign_file`, `fmu_check`, `plots`, `runner`, `loop` and `bench`); no
module of the package may import it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .bench import add_arguments as add_bench_arguments
from .bench import run_bench
from .campaign_file import CampaignError
from .extras import MissingExtra, require
from .fmu_check import load_campaign
from .loop import LoopError, print_loop, run_loop
from .plots import plot_results
# The runner's names, importable from this module as before it was split off.
from .runner import (CampaignRunError, claim_task_directories, consolidate, dask_client, extract_fmu,
                     print_summary, read_points_of, run_campaign, task_specs)

__all__ = ["main", "CampaignRunError", "claim_task_directories", "consolidate", "dask_client", "extract_fmu",
           "print_summary", "read_points_of", "run_campaign", "task_specs"]


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m planetwear_fmu.campaign", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)

    def cluster_args(q):
        q.add_argument("--scheduler", help="address of a running Dask scheduler (tcp://host:8786); "
                                           "default: a local cluster")
        q.add_argument("--workers", type=int, help="processes of the local cluster (default: one per core)")
        q.add_argument("--out", help="output directory (default: the campaign file's output_dir)")
        q.add_argument("--no-progress", action="store_true", help="no progress bar")

    q = sub.add_parser("run", help="run or continue a campaign")
    q.add_argument("file")
    cluster_args(q)
    q.add_argument("--no-plots", action="store_true")
    q = sub.add_parser("check", help="check a campaign file (with the FMU) and print what it would run")
    q.add_argument("file")
    q = sub.add_parser("loop", help="campaign at κ, wear step, campaign at κ+1, … up to a κ or a wear depth")
    q.add_argument("file")
    cluster_args(q)
    q.add_argument("--to-kappa", type=int)
    q.add_argument("--to-wear-um", type=float, help="stop at the first state whose deepest wear reaches this [µm]")
    q.add_argument("--from-state", help="the state to start from (default: the last of wear.states)")
    q = sub.add_parser("bench", help="throughput on the local cluster: points/s per core, scaling, fmpy overhead")
    add_bench_arguments(q)
    q = sub.add_parser("plot", help="draw the plots of an output directory's results.parquet")
    q.add_argument("output_dir")
    a = p.parse_args(argv)
    if getattr(a, "out", None):
        # A directory given on the command line is relative to the working directory.
        a.out = str(Path(a.out).resolve())

    if getattr(a, "workers", None) is not None and a.workers < 1:
        p.error(f"--workers {a.workers}: must be at least 1")
    try:
        # What the command needs, checked before any work starts.
        if a.command in ("run", "loop", "bench"):
            require("dask", f"campaign {a.command}")
        if a.command == "plot" or (a.command in ("run", "loop") and not getattr(a, "no_plots", False)):
            require("plot", f"campaign {a.command}")
        if a.command == "check":
            c = load_campaign(a.file)
            print(f"{c.source}: {len(c.states)} wear state(s) ({', '.join(s.label for s in c.states)}), "
                  f"{len(c.torques)} torque(s), {len(c.directions)} direction(s), {len(c.speeds)} speeds: "
                  f"{len(c.tasks())} sweeps, {c.points()} points into {c.output_dir}")
        elif a.command == "run":
            c = load_campaign(a.file, output_dir=a.out)
            s = run_campaign(c, scheduler=a.scheduler, workers=a.workers, progress=not a.no_progress,
                             plots=not a.no_plots)
            print_summary(s)
        elif a.command == "loop":
            if a.to_kappa is None and a.to_wear_um is None:
                p.error("loop: give --to-kappa K or --to-wear-um D (or both: the first reached ends the loop)")
            c = load_campaign(a.file, output_dir=a.out)
            print_loop(run_loop(c, to_kappa=a.to_kappa, to_wear_um=a.to_wear_um, from_state=a.from_state,
                                scheduler=a.scheduler, workers=a.workers, progress=not a.no_progress))
        elif a.command == "bench":
            run_bench(a)
        elif a.command == "plot":
            import pyarrow.parquet as pq

            d = Path(a.output_dir)
            if not (d / "results.parquet").is_file():
                print(f"plot: output_dir = {d}: no results.parquet there; give the output directory of a "
                      "finished campaign (the campaign file's output_dir)", file=sys.stderr)
                return 2
            for f in plot_results(pq.read_table(d / "results.parquet"), d / "plots"):
                print(f)
    except (CampaignError, MissingExtra) as e:
        print(e, file=sys.stderr)
        return 2
    except CampaignRunError as e:
        print_summary(e.summary, out=sys.stderr)
        print(e, file=sys.stderr)
        return 1
    except LoopError as e:
        print(e, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
