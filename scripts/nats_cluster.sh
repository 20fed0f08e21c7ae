#!/usr/bin/env bash
# A three-server NATS JetStream cluster on loopback for `.ci/run` (and by hand), so the test
# suites that make sense for both log backends can run with every server a cluster node
# (PHYSICS_TEST_CLUSTER, docs/cluster.md).
#
#   scripts/nats_cluster.sh start DIR   # prints the client URLs (nats://…,nats://…,nats://…)
#   scripts/nats_cluster.sh stop DIR
#
# nats-server: $NATS_SERVER, else on PATH.
set -euo pipefail
cmd="${1:?start or stop}"
dir="${2:?a directory for the server stores}"
bin="${NATS_SERVER:-$(command -v nats-server || true)}"

# Nine free loopback ports (client, route and monitor for each server).
free_ports() {
  python3 -c 'import socket
ss = [socket.socket() for _ in range(9)]
for s in ss: s.bind(("127.0.0.1", 0))
print(" ".join(str(s.getsockname()[1]) for s in ss))'
}

# The JetStream meta leader a server's monitor port reports ("" if none yet).
meta_leader() {
  curl -fsS "http://127.0.0.1:$1/jsz" 2>/dev/null |
    python3 -c 'import json, sys; print(json.load(sys.stdin).get("meta_cluster", {}).get("leader", ""))' 2>/dev/null || true
}
if [[ "$cmd" == start ]]; then
    [[ -x "$bin" ]] || { echo "nats_cluster.sh: nats-server not found (set NATS_SERVER)" >&2; exit 2; }
    mkdir -p "$dir"
    read -r -a ports <<<"$(free_ports)"
    routes="nats://127.0.0.1:${ports[3]},nats://127.0.0.1:${ports[4]},nats://127.0.0.1:${ports[5]}"
    urls=""
    for i in 0 1 2; do
      client=${ports[$i]} route=${ports[$((i + 3))]} monitor=${ports[$((i + 6))]}
      "$bin" -js -a 127.0.0.1 -sd "$dir/n$i" -p "$client" -m "$monitor" --cluster_name ci \
        --cluster "nats://127.0.0.1:$route" --routes "$routes" -n "n$i" >"$dir/n$i.log" 2>&1 &
      echo $! >"$dir/n$i.pid"
      echo "$monitor" >"$dir/n$i.monitor"
      urls="${urls:+$urls,}nats://127.0.0.1:$client"
    done
    # Ready when every server reports the same JetStream meta leader.
    for _ in $(seq 1 300); do
      leaders=$(for i in 0 1 2; do meta_leader "$(cat "$dir/n$i.monitor")"; done | sort -u)
      if [[ -n "$leaders" && "$(echo "$leaders" | wc -l)" == 1 ]]; then
        echo "$urls"
        exit 0
      fi
      sleep 0.2
    done
    echo "nats_cluster.sh: no JetStream meta leader within 60 s" >&2
    exit 1
elif [[ "$cmd" == stop ]]; then
    # Stopped and gone before this returns: a server still writing its store would make the
    # caller's removal of the directory fail.
    for f in "$dir"/n*.pid; do
      [[ -f "$f" ]] && kill "$(cat "$f")" 2>/dev/null || true
    done
    for f in "$dir"/n*.pid; do
      [[ -f "$f" ]] || continue
      pid="$(cat "$f")"
      for _ in $(seq 1 100); do
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.1
      done
      kill -9 "$pid" 2>/dev/null || true
    done
else
  echo "nats_cluster.sh: start or stop" >&2
  exit 2
fi
