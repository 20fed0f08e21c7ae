#!/usr/bin/env bash
# Every recorded run (replays/*.sqlite) exports to an MCAP file that Foxglove can open
# (`.ci/run`): runs scripts/mcap_check.py with the `mcap` reader and `jsonschema` against
# Foxglove's published JSON schemas (all pinned: scripts/lib/mcap_tools.sh).
#
#   scripts/mcap_check.sh
#   PHYSICS_MCP_BIN=target/debug/physics-mcp scripts/mcap_check.sh   # skip the release build
set -euo pipefail
cd "$(dirname "$0")/.."

bin="${PHYSICS_MCP_BIN:-}"
if [[ -z "$bin" ]]; then
  cargo build --release --locked --bin physics-mcp >&2
  bin="${CARGO_TARGET_DIR:-target}/release/physics-mcp"
fi

source scripts/lib/mcap_tools.sh

scratch=$(mktemp -d "${TMPDIR:-/tmp}/physics-mcp-mcap-check.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
"$mcap_venv/bin/python" scripts/mcap_check.py "$bin" "$mcap_schemas_tgz" "$scratch"
