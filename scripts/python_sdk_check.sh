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
server_pid=""
cleanup() {
  if [[ -n "$server_pid" ]]; then
    kill "$server_pid" 2>/dev/null || true
    wait "$server_pid" 2>/dev/null || true
  fi
  rm -rf "$scratch"
}
trap cleanup EXIT

if ! "$venv/bin/python" -c "import mcp, importlib.metadata as m; assert m.version('mcp') == '$MCP_VERSION'" 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet --disable-pip-version-check "mcp==$MCP_VERSION"
fi

bin="${PHYSICS_MCP_BIN:-}"
if [[ -z "$bin" ]]; then
  cargo build --release --locked --bin physics-mcp >&2
  bin="${CARGO_TARGET_DIR:-target}/release/physics-mcp"
fi
: >"$scratch/server.log"
"$bin" serve --bind 127.0.0.1:0 --data "$scratch/data" --workspace "$scratch/workspace" 2>"$scratch/server.log" &
server_pid=$!
url=""
for _ in $(seq 1 600); do
  url=$(sed -n 's/^physics-mcp listening on \(http[^ ]*\).*/\1/p' "$scratch/server.log" | head -n1)
  [[ -n "$url" ]] && break
  kill -0 "$server_pid" 2>/dev/null || { cat "$scratch/server.log" >&2; echo "python_sdk_check: the server did not start" >&2; exit 1; }
  sleep 0.1
done
[[ -n "$url" ]] || { echo "python_sdk_check: the server did not print its address" >&2; exit 1; }

status=0
"$venv/bin/python" scripts/python_sdk_check.py "$url" "$scratch/workspace" 2>"$scratch/stderr.txt" || status=$?
if [[ "$status" -ne 0 || -s "$scratch/stderr.txt" ]]; then
  echo "python_sdk_check: FAILED (exit $status); its stderr:" >&2
  cat "$scratch/stderr.txt" >&2
  exit 1
fi
