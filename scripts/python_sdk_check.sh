#!/usr/bin/env bash
# The Python `mcp` SDK (pinned, from PyPI, in a venv) against the release server (issue #12,
# `.ci/run`): runs scripts/python_sdk_check.py and fails on its failure or on any line it
# writes to stderr (the SDK reports protocol trouble as warnings, not errors).
#
#   scripts/python_sdk_check.sh
#   PHYSICS_MCP_BIN=target/debug/physics-mcp scripts/python_sdk_check.sh   # skip the release build
set -euo pipefail
cd "$(dirname "$0")/.."

MCP_VERSION=2.3.0
venv="${PYTHON_SDK_VENV:-${CARGO_TARGET_DIR:-target}/python-sdk-venv}"
scratch=$(mktemp -d "${TMPDIR:-/tmp}/physics-mcp-python-sdk.XXXXXX")
who=python_sdk_check
source scripts/lib/server.sh

if ! "$venv/bin/python" -c "import mcp, importlib.metadata as m; assert m.version('mcp') == '$MCP_VERSION'" 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet --disable-pip-version-check "mcp==$MCP_VERSION"
fi

start_server

status=0
"$venv/bin/python" scripts/python_sdk_check.py "$url" "$scratch/workspace" 2>"$scratch/stderr.txt" || status=$?
if [[ "$status" -ne 0 || -s "$scratch/stderr.txt" ]]; then
  echo "python_sdk_check: FAILED (exit $status); its stderr:" >&2
  cat "$scratch/stderr.txt" >&2
  exit 1
fi
