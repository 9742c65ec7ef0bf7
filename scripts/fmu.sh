#!/usr/bin/env bash
# Builds the FMU's shared library as shipped: the Cargo profile fmu (fat LTO,
# stripped) linked by zig through cargo-zigbuild against the symbol versions
# of glibc 2.17 (the manylinux2014 level), so that it loads on any x86_64
# Linux with glibc 2.17 or newer. Writes
# target/x86_64-unknown-linux-gnu/fmu/libplanetwear.so and checks it with
# scripts/check_glibc.sh. zig (ziglang) and cargo-zigbuild, both in .venv, are
# installed by scripts/setup.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
glibc=2.17
lib=target/x86_64-unknown-linux-gnu/fmu/libplanetwear.so
# cargo-zigbuild runs zig as `.venv/bin/python -m ziglang`.
export CARGO_ZIGBUILD_PYTHON_PATH=$root/.venv/bin/python
# Run from outside the work tree: zig names its own header directories
# relative to the current directory when they lie under it, and bindgen
# (fmi-sys's build script, which runs in its own directory) would then not
# find them ("'stddef.h' file not found").
(cd / && "$root/.venv/bin/cargo-zigbuild" zigbuild --quiet --manifest-path "$root/Cargo.toml" --profile fmu --lib \
    --target "x86_64-unknown-linux-gnu.$glibc")
bash scripts/check_glibc.sh "$lib" "$glibc"
