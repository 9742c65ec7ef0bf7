#!/usr/bin/env bash
# The main job: the published example (MODEL.md §1) end to end, with plots.
# Output: out/ (JSON and report) and out/plots/ (SVG and PNG).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo build --release --quiet
mkdir -p out/plots
bin=target/release/planetwear
echo "== scene example-2004 (out/example-2004.toml)"
"$bin" scene show example-2004 > out/example-2004.toml.tmp && mv out/example-2004.toml.tmp out/example-2004.toml
echo "== loaded tooth contact analysis (out/ltca.json, out/plots/)"
start=$(date +%s%N)
"$bin" ltca --scene example-2004 --out out/ltca.json --plots out/plots
end=$(date +%s%N)
echo "LTCA took $(( (end - start) / 1000000 )) ms"
echo "== natural modes (out/modes.json)"
"$bin" modes --scene example-2004 | tee out/modes.txt
"$bin" modes --scene example-2004 --json > out/modes.json.tmp && mv out/modes.json.tmp out/modes.json
echo "== speed sweep up and down, 500-15000 rpm in 250 rpm steps (out/sweep/)"
start=$(date +%s%N)
"$bin" sweep --scene example-2004 --from 500 --to 15000 --step 250 --direction both \
    --histories 3000,5000 --out out/sweep
end=$(date +%s%N)
echo "sweep took $(( (end - start) / 1000000 )) ms"
echo "== FMU: pack fmu/planetwear.fmu and co-simulate it in a drivetrain with fmpy (out/cosim.png)"
"$bin" fmu pack --out fmu/planetwear.fmu
.venv/bin/python examples/drivetrain_cosim.py --out out/cosim.png
echo "== done: see out/ltca.json, out/modes.txt, out/sweep/, out/cosim.png and out/plots/*.png"
