#!/usr/bin/env bash
# Every test of the project: formatting, lints, the Rust suites (unit,
# physics laws, published values, CLI) and the Python suites (peer check).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --tests
echo "== cargo fmt --check"
cargo fmt --check
echo "== cargo clippy"
cargo clippy --release --all-targets --quiet -- -D warnings
echo "== cargo doc: every intra-doc link resolves, public docs link no private item"
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --document-private-items --quiet
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --quiet
echo "== cargo test"
cargo test --release
echo "== build and pack the FMU (fmu/planetwear.fmu; its library from the stripped, LTO profile fmu)"
cargo build --release --quiet
cargo build --profile fmu --lib --quiet
target/release/planetwear fmu pack --out fmu/planetwear.fmu --library target/fmu/libplanetwear.so
echo "== cargo test: the packed FMU under the fmi crate"
cargo test --release --test fmu_import -- --include-ignored
echo "== fuzz under valgrind: the packed FMU's C interface, memcheck and leak check (docs/FUZZING.md)"
cargo build --release --quiet --example fmi_fuzz
valgrind --error-exitcode=1 --leak-check=full --errors-for-leak-kinds=definite --show-leak-kinds=definite \
    target/release/examples/fmi_fuzz --fmu fmu/planetwear.fmu --calls 30000 --builds 6 --torsional 1 \
    --leak-cycles 1000 --hang-seconds 900
echo "== pytest"
PLANETWEAR_BIN="$PWD/target/release/planetwear" PYTHONDONTWRITEBYTECODE=1 \
    .venv/bin/python -m pytest -p no:cacheprovider -s tests/python
