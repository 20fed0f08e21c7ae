#!/usr/bin/env python3
"""Issue #14 benchmarks side by side in one run: MuJoCo itself vs physics-mcp on Gymnasium's
models (tests/fixtures/mjcf): loading humanoid.xml, and ms/step of ant.xml on its floor at its
own timestep (0.01 s, 1000 steps). MuJoCo is measured here; physics-mcp by
`cargo bench --bench mjcf` (release), whose REPORT lines are read back; each pair is printed
with its ratio.

    python3 -m venv /tmp/mj && /tmp/mj/bin/pip install mujoco
    /tmp/mj/bin/python scripts/mjcf_bench.py

Note: MuJoCo's ant uses its own RK4 integrator, soft contacts and solver; physics-mcp steps
rapier's (the `<option>` is listed in load_mjcf's `ignored`). The step figures compare the
cost of simulating the same model for the same simulated time, not identical physics.
"""
import pathlib
import re
import statistics
import subprocess
import sys
import time

import mujoco

ROOT = pathlib.Path(__file__).resolve().parent.parent
FIXTURES = ROOT / "tests" / "fixtures" / "mjcf"


def mujoco_load_ms(name, runs=20):
    path = str(FIXTURES / name)
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        mujoco.MjModel.from_xml_path(path)
        times.append(time.perf_counter() - t)
    return statistics.median(times) * 1e3


def mujoco_step_ms(name, steps=1000, runs=10):
    model = mujoco.MjModel.from_xml_path(str(FIXTURES / name))
    data = mujoco.MjData(model)
    times = []
    for _ in range(runs):
        mujoco.mj_resetData(model, data)
        t = time.perf_counter()
        for _ in range(steps):
            mujoco.mj_step(model, data)
        times.append((time.perf_counter() - t) / steps)
    return statistics.median(times) * 1e3, model.opt.timestep


def ours():
    out = subprocess.run(["cargo", "bench", "--locked", "--bench", "mjcf"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    load = float(re.search(r"REPORT mjcf load humanoid.xml: ([0-9.]+) ms", out).group(1))
    step = float(re.search(r"REPORT mjcf ant.xml step at 0.01 s: ([0-9.]+) ms/step", out).group(1))
    return load, step


def main():
    print(f"mujoco {mujoco.__version__}, python {sys.version.split()[0]}")
    mj_load = mujoco_load_ms("humanoid.xml")
    mj_step, dt = mujoco_step_ms("ant.xml")
    our_load, our_step = ours()
    print(f"load humanoid.xml: physics-mcp {our_load:.2f} ms, MuJoCo {mj_load:.2f} ms, ratio {our_load / mj_load:.2f}")
    print(f"ant.xml at {dt} s: physics-mcp {our_step:.4f} ms/step, MuJoCo {mj_step:.4f} ms/step, ratio {our_step / mj_step:.2f}")


if __name__ == "__main__":
    main()
