#!/usr/bin/env bash
# Re-records replays/*.sqlite from replays/scripts/*.txt. Run this on purpose, after a change
# that is meant to alter physics or the log encoding, and commit the new files:
#   cargo build --release && bash replays/record.sh [replays/scripts/ONE.txt ...]
# Each script runs against a fresh server; every simulation it creates is saved as
# replays/<script>[-<n>].sqlite (compacted to 4 KB pages, no WAL).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
bin="${PHYSICS_MCP_BIN:-$here/../target/release/physics-mcp}"
call="${MCP_CALL:-$here/../../shared/tools/mcp-call}"
port=18765
scripts=("$@")
[ ${#scripts[@]} -eq 0 ] && scripts=("$here"/scripts/*.txt)
for script in "${scripts[@]}"; do
  name="$(basename "$script" .txt)"
  tmp="$(mktemp -d)"
  "$bin" serve --bind "127.0.0.1:$port" --data "$tmp/data" --workspace "$tmp/ws" 2>"$tmp/log" &
  pid=$!
  sleep 1
  python3 "$call" "http://127.0.0.1:$port/mcp" script "$script" --quiet >/dev/null || true
  kill -TERM "$pid"; wait "$pid" || true
  rm -f "$here/$name"*.sqlite
  python3 - "$tmp/data" "$here" "$name" <<'PY'
import glob, os, shutil, sqlite3, sys
data, out, name = sys.argv[1:]
def inherited(path):
    con = sqlite3.connect(path)
    n = con.execute("SELECT COUNT(*) FROM events WHERE inherited = 1").fetchone()[0]
    con.close()
    return n
for i, path in enumerate(sorted(glob.glob(os.path.join(data, "*.sqlite")), key=inherited)):
    dest = os.path.join(out, f"{name}.sqlite" if i == 0 else f"{name}-{i}.sqlite")
    con = sqlite3.connect(path)
    con.execute("PRAGMA journal_mode=DELETE")
    con.execute("PRAGMA page_size=4096")
    con.execute("VACUUM")
    con.close()
    shutil.copy(path, dest)
    print(dest, os.path.getsize(dest))
PY
  rm -rf "$tmp"
done
