#!/usr/bin/env python3
"""Issue #29 benchmarks side by side in one run: MuJoCo itself vs physics-mcp on every Gymnasium
model in tests/fixtures/mjcf, and loading humanoid.xml. Per model: ms per step at the model's own
`<option timestep>` (MuJoCo's default 0.002 s when absent), from qpos0, for the same number of
steps (so the same simulated time), single thread, median of several runs, each from a fresh
model. MuJoCo is measured here twice: a Python loop of `mj_step` (what Gymnasium does, with the
binding's per-call overhead) and `mj_step(model, data, nstep=N)` (the same N steps in MuJoCo's
C loop). physics-mcp is measured by `cargo bench --bench mjcf` (release, in-process
`World::apply` of one step_simulation, no MCP round trip), whose REPORT lines are read back.
The ratio is ours / MuJoCo's C loop: both are then a compiled loop with no per-step call
overhead, the fairer pair; the Python-loop ratio is printed beside it.

    python3 -m venv /tmp/mj && /tmp/mj/bin/pip install mujoco
    /tmp/mj/bin/python scripts/mjcf_bench.py            # MJCF_BENCH_STEPS / _RUNS / _MODELS pass through

Note: MuJoCo steps its own integrator (RK4 for most of these models), soft contacts and solver;
physics-mcp steps rapier's (the `<option>` is listed in load_mjcf's `ignored`). The figures
compare the cost of simulating the same model for the same simulated time, not identical physics.
"""
import os
import pathlib
import platform
import re
import statistics
import subprocess
import sys
import time

import mujoco

ROOT = pathlib.Path(__file__).resolve().parent.parent
FIXTURES = ROOT / "tests" / "fixtures" / "mjcf"
MODELS = ["ant", "half_cheetah", "hopper", "humanoid", "humanoidstandup", "inverted_double_pendulum",
          "inverted_pendulum", "pusher", "reacher", "swimmer", "walker2d"]
STEPS = int(os.environ.get("MJCF_BENCH_STEPS", "1000"))
RUNS = int(os.environ.get("MJCF_BENCH_RUNS", "7"))


def mujoco_load_ms(name, runs=20):
    path = str(FIXTURES / name)
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        mujoco.MjModel.from_xml_path(path)
        times.append(time.perf_counter() - t)
    return statistics.median(times) * 1e3


def mujoco_step_ms(name, steps=STEPS, runs=RUNS):
    """(timestep, Python-loop median ms/step, C-loop median ms/step, C-loop min)."""
    model = mujoco.MjModel.from_xml_path(str(FIXTURES / f"{name}.xml"))
    data = mujoco.MjData(model)
    py, c = [], []
    for _ in range(runs):
        mujoco.mj_resetData(model, data)
        t = time.perf_counter()
        for _ in range(steps):
            mujoco.mj_step(model, data)
        py.append((time.perf_counter() - t) / steps)
        mujoco.mj_resetData(model, data)
        t = time.perf_counter()
        mujoco.mj_step(model, data, nstep=steps)
        c.append((time.perf_counter() - t) / steps)
    return model.opt.timestep, statistics.median(py) * 1e3, statistics.median(c) * 1e3, min(c) * 1e3


def ours():
    out = subprocess.run(["cargo", "bench", "--locked", "--bench", "mjcf"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    load = re.search(r"REPORT mjcf load humanoid.xml: ([0-9.]+) ms", out)
    steps = {}
    for m in re.finditer(r"REPORT mjcf (\w+) step at ([0-9.e-]+) s: ([0-9.]+) ms/step \(min ([0-9.]+)", out):
        steps[m.group(1)] = (float(m.group(2)), float(m.group(3)), float(m.group(4)))
    return (float(load.group(1)) if load else None), steps


def main():
    print(f"mujoco {mujoco.__version__}, python {sys.version.split()[0]}, {platform.machine()}, "
          f"{os.cpu_count()} cpus, load average {os.getloadavg()[0]:.2f}; {STEPS} steps, median of {RUNS} runs")
    only = os.environ.get("MJCF_BENCH_MODELS")
    models = [m for m in MODELS if not only or m in only.split(",")]
    mj = {m: mujoco_step_ms(m) for m in models}
    mj_load = mujoco_load_ms("humanoid.xml") if not only else None
    our_load, our = ours()
    if our_load and mj_load:
        print(f"load humanoid.xml: physics-mcp {our_load:.2f} ms, MuJoCo {mj_load:.2f} ms, ratio {our_load / mj_load:.2f}")
    print("| model (timestep) | physics-mcp ms/step (min) | MuJoCo C loop ms/step (min) | MuJoCo Python loop ms/step | ratio ours/C loop | ratio ours/Python loop |")
    print("|---|---|---|---|---|---|")
    for m in models:
        dt, py, c, cmin = mj[m]
        if m not in our:
            print(f"| {m} ({dt:g}) | missing | {c:.4f} ({cmin:.4f}) | {py:.4f} | | |")
            continue
        our_dt, med, omin = our[m]
        assert abs(our_dt - dt) < 1e-9, f"{m}: timesteps differ ({our_dt} vs {dt})"
        print(f"| {m} ({dt:g}) | {med:.4f} ({omin:.4f}) | {c:.4f} ({cmin:.4f}) | {py:.4f} | {med / c:.2f}× | {med / py:.2f}× |")


if __name__ == "__main__":
    main()
