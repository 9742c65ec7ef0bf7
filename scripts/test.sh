#!/usr/bin/env bash
# Every test of the project: formatting, lints, the Rust suites (unit,
# physics laws, published values, CLI) and the Python suites (peer check).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
echo "== cargo fmt --check"
cargo fmt --check
echo "== cargo clippy"
cargo clippy --release --all-targets --quiet -- -D warnings
echo "== cargo test"
cargo test --release
echo "== build and pack the FMU (fmu/planetwear.fmu)"
cargo build --release --quiet
target/release/planetwear fmu pack --out fmu/planetwear.fmu
echo "== cargo test: the packed FMU under the fmi crate"
cargo test --release --test fmu_import -- --include-ignored
echo "== pytest"
PLANETWEAR_BIN="$PWD/target/release/planetwear" PYTHONDONTWRITEBYTECODE=1 \
    .venv/bin/python -m pytest -p no:cacheprovider -s tests/python
