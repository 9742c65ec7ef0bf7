#!/usr/bin/env bash
# Every test of the project: formatting, lints, the Rust suites (unit,
# physics laws, published values, CLI) and the Python suites (peer check).
#
# Steps that leave a core idle run beside others, their output kept in
# target/ci/ and shown when they are waited for: the Python environment
# (mostly downloads) beside the Rust checks, the FMU's build (one long
# link-time optimization) beside the Rust tests, the fuzzing under valgrind
# (one thread) beside pytest. The time from a clean clone on 2 cores: README.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --tests --system
mkdir -p target/ci
# Background steps run in their own process groups; whatever is left running
# when the script ends (a step before failed) is stopped with its children.
set -m
declare -A running=()
trap 'for pid in "${running[@]}"; do kill -- "-$pid" 2>/dev/null || true; done' EXIT
# `beside NAME COMMAND...`: runs the command in the background, its output to target/ci/NAME.log.
beside() {
    local name=$1
    shift
    echo "== $name (in the background: target/ci/$name.log)"
    "$@" >"target/ci/$name.log" 2>&1 &
    running[$name]=$!
}
# `await NAME`: waits for it and shows its output; its failure fails the run.
await() {
    local name=$1 status=0
    wait "${running[$name]}" || status=$?
    unset "running[$name]"
    echo "== $name (its output)"
    cat "target/ci/$name.log"
    if [ "$status" != 0 ]; then
        echo "== $name failed (exit status $status)" >&2
        exit "$status"
    fi
}
beside python-environment bash scripts/setup.sh --python
echo "== cargo fmt --check"
cargo fmt --check
echo "== cargo clippy"
cargo clippy --release --all-targets --quiet -- -D warnings
echo "== cargo doc: every intra-doc link resolves, public docs link no private item"
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --document-private-items --quiet
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --quiet
echo "== cargo test"
# Also builds target/release/planetwear (the CLI tests run it), which the
# steps below use. No `cargo build --release` here: a normal build resolves
# the dependencies' features without the dev-dependencies' and so rebuilds the
# crate, and the next `cargo test` rebuilds it again (about 1.5 minutes each
# on 2 cores).
cargo test --release --no-run
await python-environment
# The FMU's build and pack (fmu/planetwear.fmu; its library from the stripped,
# LTO profile fmu, linked by zig for glibc 2.17). No test of `cargo test` reads
# the packed file.
beside fmu bash -c 'bash scripts/fmu.sh && target/release/planetwear fmu pack --out fmu/planetwear.fmu \
    --library target/x86_64-unknown-linux-gnu/fmu/libplanetwear.so'
cargo test --release
await fmu
echo "== the packed library needs no glibc newer than 2.17: its highest GLIBC symbol version (objdump -T)"
bash scripts/check_glibc.sh fmu/planetwear.fmu 2.17
# The check can fail: the natively linked executable needs this machine's
# newer glibc (pthread_key_create@GLIBC_2.34 since glibc 2.34).
if [ "$(printf '%s\n' 2.34 "$(getconf GNU_LIBC_VERSION | cut -d' ' -f2)" | sort -V | head -1)" = 2.34 ] &&
    bash scripts/check_glibc.sh target/release/planetwear 2.17 >/dev/null 2>&1; then
    echo "scripts/check_glibc.sh passed target/release/planetwear, linked against glibc $(getconf GNU_LIBC_VERSION)" >&2
    exit 1
fi
echo "== cargo test: the packed FMU under the fmi crate"
cargo test --release --test fmu_import -- --include-ignored
echo "== fuzz under valgrind: the packed FMU's C interface, memcheck and leak check (docs/FUZZING.md)"
cargo build --release --quiet --example fmi_fuzz
beside fuzz valgrind --error-exitcode=1 --leak-check=full --errors-for-leak-kinds=definite --show-leak-kinds=definite \
    target/release/examples/fmi_fuzz --fmu fmu/planetwear.fmu --calls 30000 --builds 6 --torsional 1 \
    --leak-cycles 1000 --hang-seconds 900
echo "== pytest"
PLANETWEAR_BIN="$PWD/target/release/planetwear" PYTHONDONTWRITEBYTECODE=1 \
    .venv/bin/python -m pytest -p no:cacheprovider -s tests/python
await fuzz
