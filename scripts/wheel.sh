#!/usr/bin/env bash
# Builds the Python wheel that carries the server binary (pyproject.toml: maturin, bindings
# "bin", release profile, Cargo.lock as committed, symbols stripped) into dist/, then checks
# what the binary needs from the system against its manylinux_2_34 tag: no glibc symbol
# version newer than 2.34 and no shared library beyond libc, libm, libgcc_s and the loader.
# Prints the wheel's path and sizes. Linux x86_64 only: macOS and Windows wheels need those
# systems (or their SDKs) to build, which this script does not pretend to have.
#
#   scripts/wheel.sh          # dist/physics_mcp-<version>-py3-none-manylinux_2_34_x86_64.whl
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/lib/packaging.sh

GLIBC_MAX=2.34
ALLOWED_LIBS="libc.so.6 libm.so.6 libgcc_s.so.1 ld-linux-x86-64.so.2"
version=$(python3 -c 'import tomllib; print(tomllib.load(open("Cargo.toml", "rb"))["workspace"]["package"]["version"])')

mkdir -p dist
rm -f dist/physics_mcp-*.whl
"$packaging_venv/bin/maturin" build --release --out dist >&2
wheel="dist/physics_mcp-$version-py3-none-manylinux_2_34_x86_64.whl"
[[ -f "$wheel" ]] || { echo "wheel: maturin did not write $wheel:" >&2; ls dist >&2; exit 1; }

scratch=$(mktemp -d "${TMPDIR:-/tmp}/physics-mcp-wheel.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
python3 -m zipfile -e "$wheel" "$scratch"
bin="$scratch/physics_mcp-$version.data/scripts/physics-mcp"
[[ -f "$bin" ]] || { echo "wheel: $wheel holds no physics-mcp in its scripts" >&2; exit 1; }

newest=$(objdump -T "$bin" | grep -o 'GLIBC_[0-9.]*' | sed 's/GLIBC_//' | sort -uV | tail -n1)
if [[ "$(printf '%s\n%s\n' "$newest" "$GLIBC_MAX" | sort -V | tail -n1)" != "$GLIBC_MAX" ]]; then
  echo "wheel: the binary needs glibc $newest, newer than its manylinux_${GLIBC_MAX/./_} tag allows" >&2
  exit 1
fi
needed=$(objdump -p "$bin" | awk '$1 == "NEEDED" {print $2}' | sort | tr '\n' ' ')
for lib in $needed; do
  [[ " $ALLOWED_LIBS " == *" $lib "* ]] || { echo "wheel: the binary links $lib, which manylinux does not promise" >&2; exit 1; }
done
if readelf -S "$bin" | grep -q '\.symtab'; then
  echo "wheel: the binary still has its symbol table (pyproject.toml strips it)" >&2
  exit 1
fi

size() { du -k "$1" | awk '{printf "%.1f MB", $1 / 1024}'; }
echo "wheel: $wheel ($(size "$wheel"); binary $(size "$bin"), stripped; needs glibc >= $newest and $needed)" >&2
echo "$wheel"
