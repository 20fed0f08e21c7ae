# Sourced by the scripts that drive a real server (conformance.sh, python_sdk_check.sh): one
# way to get the binary, start it on a free loopback port with throwaway directories, and
# stop it however the script ends.
#
# Needs: $scratch (a temporary directory the caller owns) and $who (a name for messages).
# Gives: start_server (sets $server_pid and $url), and an EXIT trap that stops the server and
# removes $scratch. PHYSICS_MCP_BIN picks a binary already built; else a release build.

server_pid=""
cleanup() {
  if [[ -n "$server_pid" ]]; then
    kill "$server_pid" 2>/dev/null || true
    wait "$server_pid" 2>/dev/null || true
  fi
  rm -rf "$scratch"
}
trap cleanup EXIT

start_server() {
  local bin="${PHYSICS_MCP_BIN:-}"
  if [[ -z "$bin" ]]; then
    cargo build --release --locked --bin physics-mcp >&2
    bin="${CARGO_TARGET_DIR:-target}/release/physics-mcp"
  fi
  # Port 0: the server picks a free port and prints it (the log exists before it starts).
  : >"$scratch/server.log"
  "$bin" serve --bind 127.0.0.1:0 --data "$scratch/data" --workspace "$scratch/workspace" 2>"$scratch/server.log" &
  server_pid=$!
  url=""
  for _ in $(seq 1 600); do
    # Only a whole line counts: the address ends in /mcp (a line read while being written
    # would give a URL without its host).
    url=$(sed -n 's|^physics-mcp listening on \(http://[^ /]*/mcp\)$|\1|p' "$scratch/server.log" | head -n1)
    [[ -n "$url" ]] && break
    kill -0 "$server_pid" 2>/dev/null || { cat "$scratch/server.log" >&2; echo "$who: the server did not start" >&2; exit 1; }
    sleep 0.1
  done
  [[ -n "$url" ]] || { echo "$who: the server did not print its address" >&2; exit 1; }
}
