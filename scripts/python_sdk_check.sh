#!/usr/bin/env bash
# The Python `mcp` SDK (pinned, from PyPI, in a venv) against the release server
# (`.ci/run`): runs scripts/python_sdk_check.py and fails on its failure or on any line it
# writes to stderr (the SDK reports protocol trouble as warnings, not errors).
#
#   scripts/python_sdk_check.sh
#   PHYSICS_MCP_BIN=target/debug/physics-mcp scripts/python_sdk_check.sh   # skip the release build
set -euo pipefail
cd "$(dirname "$0")/.."

scratch=$(mktemp -d "${TMPDIR:-/tmp}/physics-mcp-python-sdk.XXXXXX")
who=python_sdk_check
source scripts/lib/server.sh

source scripts/lib/python_sdk.sh

start_server

status=0
"$venv/bin/python" scripts/python_sdk_check.py "$url" "$scratch/workspace" 2>"$scratch/stderr.txt" || status=$?
if [[ "$status" -ne 0 || -s "$scratch/stderr.txt" ]]; then
  echo "python_sdk_check: FAILED (exit $status); its stderr:" >&2
  cat "$scratch/stderr.txt" >&2
  exit 1
fi
