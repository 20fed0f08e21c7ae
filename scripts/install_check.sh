#!/usr/bin/env bash
# Builds the wheel (scripts/wheel.sh), installs it into a fresh virtualenv as a user's
# `pip install physics-mcp` would (no index, no Rust), and runs scripts/install_check.py: the
# installed `physics-mcp stdio` and `uvx --from <wheel> physics-mcp stdio` started with no
# flags from /, from a temporary directory and from a directory it cannot write. The installed
# binary stays at target/wheel-venv/bin/physics-mcp for the checks that follow in `.ci/run`.
#
#   scripts/install_check.sh
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/lib/packaging.sh

wheel=$(scripts/wheel.sh)
venv="${CARGO_TARGET_DIR:-target}/wheel-venv"
rm -rf "$venv"
python3 -m venv "$venv"
"$venv/bin/pip" install --quiet --disable-pip-version-check --no-index "$wheel"
python3 scripts/install_check.py "$venv/bin/physics-mcp" "$wheel" "$packaging_venv/bin/uvx"
