"""E_h of the FMU against its shipped regression references, per case, for
other internal step counts and communication steps than the protocol's:
the measurement behind the window-interpolation term of the tolerance
budget (docs/REGRESSION.md).

    .venv/bin/python scripts/regression_budget.py --steps 120,1920 --comm 1,0.822,0.37

E_h = max over planet 1's two meshes of max_k |F_k − F_k,ref| / F_1,ref
(k = 1..6); --comm gives communication steps in mesh periods.
"""

import argparse
import copy
import dataclasses
import time
from pathlib import Path

from fmpy import extract

from planetwear_fmu.regression import compare, load_references, run_reference_case


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--fmu", default=str(Path(__file__).resolve().parents[1] / "fmu" / "planetwear.fmu"))
    p.add_argument("--steps", default="1920", help="stepsPerMeshCycle values, comma-separated")
    p.add_argument("--comm", default="1", help="communication steps in mesh periods, comma-separated")
    p.add_argument("--relative-tolerance", type=float, default=None,
                   help="the FMU's relativeTolerance (default: the protocol's)")
    a = p.parse_args()
    refs = load_references(a.fmu)
    unzipdir = extract(a.fmu)
    comms = [float(c) for c in a.comm.split(",")]
    print(f"{'case':<18} {'steps':>6} " + " ".join(f"{'comm ' + format(c, 'g'):>12}" for c in comms)
          + f" {'CPU s/run':>10}")
    for steps in [int(s) for s in a.steps.split(",")]:
        protocol = copy.deepcopy(refs.protocol)
        protocol["parameters"]["stepsPerMeshCycle"] = steps
        if a.relative_tolerance is not None:
            protocol["parameters"]["relativeTolerance"] = a.relative_tolerance
        variant = dataclasses.replace(refs, protocol=protocol)
        for case in refs.cases:
            errors, cpu = [], 0.0
            for c in comms:
                start = time.process_time()
                measured = run_reference_case(a.fmu, case, references=variant, unzipdir=unzipdir,
                                              communication_step=c / case.mesh_frequency_hz)
                cpu += time.process_time() - start
                errors.append(compare(case, measured).worst_fraction_of_f1())
            print(f"{case.name:<18} {steps:>6} " + " ".join(f"{e:>12.2e}" for e in errors)
                  + f" {cpu / len(comms):>10.2f}", flush=True)


if __name__ == "__main__":
    main()
