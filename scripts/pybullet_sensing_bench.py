"""PyBullet's side of benches/sensing.rs, on the same scenes, for same-run ratios.

Dev-only (pybullet is not a dependency):
  python -m venv /tmp/pb && /tmp/pb/bin/pip install pybullet==3.2.7 numpy
  /tmp/pb/bin/python scripts/pybullet_sensing_bench.py
Prints REPORT lines like the Rust bench: a 10,000-ray batch over a collapsed 1000-box pile
(1 and 2 threads) and TinyRenderer images of the 100-object scene at 320x240 and 640x480.
"""
import math
import random
import statistics
import time

import pybullet as p


def median_ms(f, runs=15):
    out = []
    for _ in range(runs):
        t = time.perf_counter()
        f()
        out.append((time.perf_counter() - t) * 1e3)
    return statistics.median(out)


def box(half, pos, mass, orn=(0, 0, 0, 1), color=None):
    col = p.createCollisionShape(p.GEOM_BOX, halfExtents=half)
    vis = p.createVisualShape(p.GEOM_BOX, halfExtents=half, rgbaColor=color) if color else -1
    return p.createMultiBody(mass, col, vis, pos, orn)


def pile():
    p.resetSimulation()
    p.setGravity(0, 0, -9.81)
    box([20, 20, 0.5], [0, 0, -0.5], 0)
    rng = random.Random(20261122)
    for i in range(10):
        for j in range(10):
            for k in range(10):
                jit = lambda: rng.uniform(-0.02, 0.02)
                axis = [rng.uniform(-1, 1) for _ in range(3)]
                n = max(math.sqrt(sum(a * a for a in axis)), 1e-6)
                ang = rng.uniform(0, 2 * math.pi)
                s, c = math.sin(ang / 2), math.cos(ang / 2)
                box([0.1] * 3, [i * 0.25 + jit(), j * 0.25 + jit(), 0.5 + k * 0.25 + jit()], 1,
                    [axis[0] / n * s, axis[1] / n * s, axis[2] / n * s, c])
    for _ in range(400):
        p.stepSimulation()


def rays():
    rng = random.Random(7)
    frm, to = [], []
    for _ in range(10000):
        x, y = rng.uniform(-0.5, 3.0), rng.uniform(-0.5, 3.0)
        frm.append([x, y, 5.0])
        to.append([x + rng.uniform(-0.3, 0.3), y + rng.uniform(-0.3, 0.3), -1.0])
    return frm, to


def scene_100():
    p.resetSimulation()
    box([10, 10, 0.1], [0, 0, -0.1], 0, color=[0.6, 0.6, 0.6, 1])
    for i in range(99):
        pos = [(i % 10) * 0.6 - 2.7, (i // 10) * 0.6 - 2.7, 0.25]
        color = [(i % 3) / 2, ((i // 3) % 3) / 2, 1 - (i % 5) / 4, 1]
        kind = i % 4
        if kind == 0:
            col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.2] * 3)
            vis = p.createVisualShape(p.GEOM_BOX, halfExtents=[0.2] * 3, rgbaColor=color)
        elif kind == 1:
            col = p.createCollisionShape(p.GEOM_SPHERE, radius=0.2)
            vis = p.createVisualShape(p.GEOM_SPHERE, radius=0.2, rgbaColor=color)
        elif kind == 2:
            col = p.createCollisionShape(p.GEOM_CYLINDER, radius=0.2, height=0.4)
            vis = p.createVisualShape(p.GEOM_CYLINDER, radius=0.2, length=0.4, rgbaColor=color)
        else:
            col = p.createCollisionShape(p.GEOM_CAPSULE, radius=0.15, height=0.2)
            vis = p.createVisualShape(p.GEOM_CAPSULE, radius=0.15, length=0.2, rgbaColor=color)
        p.createMultiBody(1, col, vis, pos)


p.connect(p.DIRECT)
pile()
frm, to = rays()
for threads in (1, 2):
    ms = median_ms(lambda: p.rayTestBatch(frm, to, numThreads=threads))
    hits = sum(1 for r in p.rayTestBatch(frm, to, numThreads=threads) if r[0] >= 0)
    print(f"REPORT pybullet rays: 10000-ray batch over the collapsed 1000-box pile: {ms:.2f} ms on {threads} thread(s) ({hits} hits)")
scene_100()
for w, h in ((320, 240), (640, 480)):
    view = p.computeViewMatrix([5, -5, 4], [0, 0, 0], [0, 0, 1])
    proj = p.computeProjectionMatrixFOV(60, w / h, 0.1, 100)
    ms = median_ms(lambda: p.getCameraImage(w, h, view, proj, renderer=p.ER_TINY_RENDERER))
    print(f"REPORT pybullet camera: 100-object scene {w}x{h}: {ms:.2f} ms (TinyRenderer)")
