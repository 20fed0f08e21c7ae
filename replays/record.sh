#!/usr/bin/env bash
# Re-records replays/*.sqlite from replays/scripts/*.txt. Run this on purpose, after a change
# that is meant to alter physics or the log encoding, and commit the new files:
#   bash replays/record.sh [replays/scripts/ONE.txt ...]
# The recorder is the ignored test `record_replays` in tests/time_machine/record_replays.rs: each script runs
# against a fresh server (the project's own binary and MCP client); every simulation it creates
# is saved as replays/<script>[-<n>].sqlite (compacted to 4 KB pages, no WAL) and must pass
# `physics-mcp replay`. A call that is refused fails the recording unless its line starts
# with `!` (an intended refusal); a `!` call that is accepted fails it too. RECORD_OUT=DIR
# writes somewhere else than replays/.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
scripts=()
for s in "$@"; do scripts+=("$(cd "$(dirname "$s")" && pwd)/$(basename "$s")"); done
cd "$here/.."
RECORD_SCRIPTS="${scripts[*]:-}" cargo test --test time_machine -- --ignored --exact record_replays::record_replays --nocapture
