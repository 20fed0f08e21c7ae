"""Writes tests/fixtures/camera_matrices.json: pybullet's own view and projection matrices
for a spread of inputs, the reference the compute_* tools must match within 1e-5.

Dev-only (pybullet is not a dependency): python -m venv /tmp/pb && /tmp/pb/bin/pip install
pybullet==3.2.7 numpy && /tmp/pb/bin/python scripts/camera_fixtures.py
"""
import json
import random

import pybullet as p

rng = random.Random(7)
r = lambda a, b: round(rng.uniform(a, b), 3)
view, ypr, proj = [], [], []
for _ in range(40):
    eye = [r(-5, 5), r(-5, 5), r(0.1, 5)]
    target = [r(-1, 1), r(-1, 1), r(0, 1)]
    up = rng.choice([[0, 0, 1], [0, 1, 0], [r(-1, 1), r(-1, 1), 1]])
    view.append({"eye": eye, "target": target, "up": up,
                 "matrix": list(p.computeViewMatrix(eye, target, up))})
for _ in range(40):
    target = [r(-2, 2), r(-2, 2), r(0, 2)]
    d, yaw, pitch = r(0.5, 10), r(-360, 360), r(-89, 89)
    up = rng.choice([1, 2])
    ypr.append({"target": target, "distance": d, "yaw": yaw, "pitch": pitch, "up_axis_index": up,
                "matrix": list(p.computeViewMatrixFromYawPitchRoll(target, d, yaw, pitch, 0, up))})
for _ in range(40):
    fov, aspect, near, far = r(10, 170), r(0.3, 3), r(0.01, 1), r(2, 1000)
    proj.append({"fov": fov, "aspect": aspect, "near": near, "far": far,
                 "matrix": list(p.computeProjectionMatrixFOV(fov, aspect, near, far))})
with open("tests/fixtures/camera_matrices.json", "w") as f:
    json.dump({"pybullet": p.getAPIVersion(), "view": view, "yaw_pitch": ypr,
               "projection": proj}, f, indent=1)
