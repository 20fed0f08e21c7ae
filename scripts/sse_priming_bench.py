#!/usr/bin/env python3
"""What SSE priming events cost a small call: get_object_state p50/p90 over streamable HTTP,
with priming off (the default) and on (PHYSICS_MCP_SSE_RETRY_MS=3000, rmcp's default retry).

    python3 scripts/sse_priming_bench.py target/release/physics-mcp [CALLS]

Starts the server twice on free loopback ports with throwaway directories and talks raw
JSON-RPC over one kept-alive HTTP connection (Python's standard library only), so what is
measured is the server and its framing, not a client library. README "Connecting a client"
quotes the result.
"""

import pathlib
import statistics
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent / "lib"))
from mcp_http import Session, start  # noqa: E402


def measure(binary, env_extra, calls):
    with tempfile.TemporaryDirectory() as tmp:
        proc, hostport = start(binary, env_extra, tmp)
        try:
            s = Session(hostport)
            s.open("bench")
            sim = s.call("create_simulation", {})["simulation_id"]
            obj = s.call("add_box", {"sim_id": sim, "dimensions": [1, 1, 1], "mass": 1, "position": [0, 0, 1]})["object_id"]
            for _ in range(50):  # warm up
                s.call("get_object_state", {"sim_id": sim, "object_id": obj})
            times = []
            for _ in range(calls):
                t = time.perf_counter()
                s.call("get_object_state", {"sim_id": sim, "object_id": obj})
                times.append((time.perf_counter() - t) * 1e3)
            q = statistics.quantiles(times, n=10)
            return statistics.median(times), q[8]
        finally:
            proc.terminate()
            proc.wait()


def main():
    if len(sys.argv) not in (2, 3):
        raise SystemExit(__doc__)
    binary = sys.argv[1]
    calls = int(sys.argv[2]) if len(sys.argv) == 3 else 2000
    # Alternate the two settings to spread any drift in machine load over both.
    runs = {"priming off": [], "priming on": []}
    for _ in range(3):
        runs["priming off"].append(measure(binary, {}, calls))
        runs["priming on"].append(measure(binary, {"PHYSICS_MCP_SSE_RETRY_MS": "3000"}, calls))
    for name, results in runs.items():
        p50 = statistics.median(r[0] for r in results)
        p90 = statistics.median(r[1] for r in results)
        print(f"{name}: get_object_state p50 {p50:.3f} ms, p90 {p90:.3f} ms ({calls} calls x {len(results)} runs)")


if __name__ == "__main__":
    main()
