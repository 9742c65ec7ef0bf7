#!/usr/bin/env bash
# The main job: the published example (docs/PARAMETERS.md) end to end, with plots.
# Stages: scene, loaded tooth contact analysis, natural modes, the periodic
# states by continuation with their folds and unstable stretches (6000-15000 rpm),
# the Archard wear model to κ = 6, the validation against the study (its
# forced response from the continuation's branches, spot-checked by
# marching) with the example on deformable-tooth contact beside it (rewrites
# docs/VALIDATION.md and docs/validation/), the FMU packed
# with the example's worn states, speed sweeps up and down at κ = 0, 2, 4, 6
# through the FMU driven by fmpy, the study's plots and report
# (out/study/report.md), a drive cycle through the FMU in its steady fidelity with
# the wear loop it drives (out/drive_cycle/), and the drivetrain co-simulation example.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo build --release --quiet
bash scripts/fmu.sh
mkdir -p out/plots
bin=target/release/planetwear
built=$(date +%s)
timings=out/timings.json.tmp
echo "{" > "$timings"
stage() { # name, then the command
    local name=$1; shift
    local start end
    start=$(date +%s%N)
    "$@"
    end=$(date +%s%N)
    printf '  "%s": %s,\n' "$name" "$(awk "BEGIN {print ($end - $start) / 1e9}")" >> "$timings"
    echo "-- $name took $(( (end - start) / 1000000 )) ms"
}
echo "== scene example-2004 (out/example-2004.toml)"
"$bin" scene show example-2004 > out/example-2004.toml.tmp && mv out/example-2004.toml.tmp out/example-2004.toml
echo "== loaded tooth contact analysis (out/ltca.json, out/plots/)"
stage "loaded tooth contact analysis" "$bin" ltca --scene example-2004 --out out/ltca.json --plots out/plots
echo "== natural modes (out/modes.txt, out/modes.json)"
"$bin" modes --scene example-2004 | tee out/modes.txt
"$bin" modes --scene example-2004 --json > out/modes.json.tmp && mv out/modes.json.tmp out/modes.json
echo "== periodic states by continuation, up and down, 6000-15000 rpm at a nominal 50 rpm step, unworn (out/continuation/: CSV, plots with the unstable stretches dashed)"
stage "continuation (unworn)" "$bin" sweep --scene example-2004 --from 6000 --to 15000 --step 50 \
    --method continuation --solver condensed --join --out out/continuation
echo "== wear model to kappa = 6 (out/wear/: states, summary.json, plots)"
stage "wear model to κ = 6" "$bin" wear run --scene example-2004 --to-kappa 6 --out out/wear
echo "== validation against the study, full grid, beside the example on deformable-tooth contact (docs/VALIDATION.md, docs/validation/)"
stage "validation" "$bin" validate --out docs --compare example-2004-deformable
echo "== FMU: pack fmu/planetwear.fmu (with the example's worn states)"
stage "FMU pack" "$bin" fmu pack --out fmu/planetwear.fmu --library target/x86_64-unknown-linux-gnu/fmu/libplanetwear.so
bash scripts/check_glibc.sh fmu/planetwear.fmu 2.17
echo "== sweeps through the FMU at kappa = 0, 2, 4, 6 (out/study/)"
echo '  "_": 0}' >> "$timings"
mv "$timings" out/timings.json
.venv/bin/python scripts/study.py --fmu fmu/planetwear.fmu --wear out/wear --out out/study \
    --timings out/timings.json
echo "== drive cycle: WLTC class 3b (its first 20 s) through the FMU in its steady fidelity, the wear loop to kappa = 6 (out/drive_cycle/, docs/DRIVE_CYCLE.md)"
PLANETWEAR_BIN="$PWD/$bin" .venv/bin/python -m planetwear_fmu.drive_cycle --fmu fmu/planetwear.fmu \
    --out out/drive_cycle --seconds 20 --to-kappa 6 --hours-per-stage 1500
echo "== drivetrain co-simulation with fmpy (out/cosim.png)"
.venv/bin/python examples/drivetrain_cosim.py --out out/cosim.png
echo "== the main job took $(( $(date +%s) - built )) s after the build"
echo "== done: docs/VALIDATION.md (the study beside ours), out/study/report.md (the study), out/wear/, out/continuation/, out/ltca.json, out/modes.txt, out/drive_cycle/, out/cosim.png, out/plots/"
