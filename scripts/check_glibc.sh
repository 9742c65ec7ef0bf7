#!/usr/bin/env bash
# Fails when a shared library needs a newer glibc than MAX: reads the GLIBC_*
# versions of its dynamic symbols (objdump -T), prints the highest, and on
# failure names every symbol above MAX with its version.
# Usage: check_glibc.sh LIBRARY|FMU MAX  (an .fmu: its binaries/linux64/*.so)
set -euo pipefail
file=$1
max=$2
lib=$file
if [[ $file == *.fmu ]]; then
    tmp=$(mktemp -d)
    trap 'rm -rf "$tmp"' EXIT
    python3 - "$file" "$tmp/lib.so" <<'PY'
import sys, zipfile
with zipfile.ZipFile(sys.argv[1]) as z:
    names = [n for n in z.namelist() if n.startswith("binaries/linux64/") and n.endswith(".so")]
    if len(names) != 1:
        sys.exit(f"{sys.argv[1]}: expected one binaries/linux64/*.so, found {names}")
    with open(sys.argv[2], "wb") as f:
        f.write(z.read(names[0]))
PY
    lib=$tmp/lib.so
fi
symbols=$(objdump -T "$lib")
highest=$(grep -o 'GLIBC_[0-9.]*' <<<"$symbols" | sort -Vu | tail -1)
if [ -z "$highest" ]; then
    echo "$file: no GLIBC symbol versions found (objdump -T)" >&2
    exit 1
fi
echo "$file: highest GLIBC symbol version needed: $highest (limit GLIBC_$max)"
# Version fields of objdump -T: "(GLIBC_2.34) name" or " GLIBC_2.34  name".
above=$(grep -oE 'GLIBC_[0-9.]+\)? +[^ ]+$' <<<"$symbols" | tr -d ')' | awk '{print $1, $2}' |
    while read -r version name; do
        if [ "$(printf '%s\n%s\n' "GLIBC_$max" "$version" | sort -V | tail -1)" != "GLIBC_$max" ]; then
            echo "  $name needs $version"
        fi
    done | sort -u | sort -k3,3V)
if [ -n "$above" ]; then
    echo "$file needs a glibc newer than $max:" >&2
    echo "$above" >&2
    exit 1
fi
