"""Writes tests/fixtures/pybullet_joint_limits.json: what pybullet 3.2.7 reports and does for
tests/fixtures/joint_limits.urdf, revolute and prismatic joints whose <limit> leaves out lower
and/or upper — the reference for load_urdf's limits.

For each joint: getJointInfo's lower/upper, and the position a velocity motor reaches in 1 s
(240 steps, no gravity) driving it up (+1) and, from a fresh load, down (-1). A limit that is
enforced stops the joint there; a missing one lets it run to about +-1.

Dev-only (pybullet is not a dependency): python -m venv /tmp/pb && /tmp/pb/bin/pip install
pybullet==3.2.7 && /tmp/pb/bin/python scripts/urdf_joint_limits.py
"""
import json
import os

import pybullet as p

HERE = os.path.dirname(os.path.abspath(__file__))
FIXTURES = os.path.join(HERE, "..", "tests", "fixtures")
FILE = "joint_limits.urdf"
MOTION = {"force": 10.0, "steps": 240}

p.connect(p.DIRECT)
p.setGravity(0, 0, 0)
out = dict(MOTION, pybullet="3.2.7", file=FILE, control_mode="VELOCITY_CONTROL", timestep=1 / 240,
           gravity=[0, 0, 0], use_fixed_base=True, joints=[])
reached = {}
for velocity in (1.0, -1.0):
    body = p.loadURDF(os.path.join(FIXTURES, FILE), useFixedBase=True)
    for j in range(p.getNumJoints(body)):
        p.setJointMotorControl2(body, j, p.VELOCITY_CONTROL, targetVelocity=velocity, force=MOTION["force"])
    for _ in range(MOTION["steps"]):
        p.stepSimulation()
    reached[velocity] = [p.getJointState(body, j)[0] for j in range(p.getNumJoints(body))]
    p.removeBody(body)
body = p.loadURDF(os.path.join(FIXTURES, FILE), useFixedBase=True)
for j in range(p.getNumJoints(body)):
    info = p.getJointInfo(body, j)
    out["joints"].append({"joint_index": j, "joint_name": info[1].decode(), "lower_limit": info[8],
                          "upper_limit": info[9], "max_force": info[10], "max_velocity": info[11],
                          "position_after_velocity_up": reached[1.0][j],
                          "position_after_velocity_down": reached[-1.0][j]})

path = os.path.join(FIXTURES, "pybullet_joint_limits.json")
with open(path, "w") as f:
    json.dump(out, f, indent=1)
print("wrote", path)
