#!/usr/bin/env bash
# What an agent spends: the Python `mcp` SDK (pinned, from PyPI, in a venv) runs
# scripts/agent_tasks.py's fifteen tasks against a server with a copy of tests/fixtures in its
# workspace, and prints per task the calls, the reply bytes a model reads and whether the
# physical outcome is right, then the issue's budget targets. Arguments go to the script:
# --report (measurement only, exit 0), --enforce-targets (a missed target fails), --calls.
#
#   scripts/agent_tasks.sh --report
#   PHYSICS_MCP_BIN=target/debug/physics-mcp scripts/agent_tasks.sh   # skip the release build
set -euo pipefail
cd "$(dirname "$0")/.."

scratch=$(mktemp -d "${TMPDIR:-/tmp}/physics-mcp-agent-tasks.XXXXXX")
who=agent_tasks
source scripts/lib/server.sh

source scripts/lib/python_sdk.sh

# The fixtures where the tasks name them: tests/fixtures/… relative to the workspace.
mkdir -p "$scratch/workspace/tests"
cp -r tests/fixtures "$scratch/workspace/tests/fixtures"

start_server

"$venv/bin/python" scripts/agent_tasks.py "$url" "$@"
