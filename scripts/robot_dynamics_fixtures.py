"""Writes tests/reference/pybullet_robot_dynamics.json: what pybullet 3.2.7 reports for the
built-in KUKA iiwa (kuka_iiwa/model.urdf) and Franka Panda (franka_panda/panda.urdf), fixed at
the origin, loaded with URDF_USE_INERTIA_FROM_FILE:

- "holding": the KUKA held at a bent pose by position motors under gravity, every joint's
  force/torque sensor on (enableJointForceTorqueSensor), after 2,000 steps of 1/240 s: each
  joint's reaction forces (getJointState item 2) and applied motor torque (item 3);
- "dynamics": per robot, 5 seeded random configurations with random velocities and
  accelerations: calculateJacobian (link = the last link, local position (0.01, 0.02, 0.03)
  in its URDF link frame, which is what pybullet uses though its docs say centre-of-mass
  frame), calculateMassMatrix and calculateInverseDynamics.

Dev-only (pybullet is not a dependency): python -m venv /tmp/pb && /tmp/pb/bin/pip install
pybullet==3.2.7 numpy && /tmp/pb/bin/python scripts/robot_dynamics_fixtures.py
"""
import json
import os
import random

import pybullet as p
import pybullet_data

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "tests", "reference", "pybullet_robot_dynamics.json")
ROBOTS = ["kuka_iiwa/model.urdf", "franka_panda/panda.urdf"]
HOLD = [0.3, 0.6, -0.2, -1.1, 0.4, 0.8, 0.1]
LOCAL = [0.01, 0.02, 0.03]


def load(name):
    """The robot, each link whose URDF inertial says 0 kg given the server's stand-in (1e-3 kg,
    1e-6 kg m^2: rapier cannot move a massless link; pybullet keeps the written inertia, 0.1 on
    the Panda's panda_link8 and panda_grasptarget), so the references compare the algorithms."""
    body = p.loadURDF(os.path.join(pybullet_data.getDataPath(), name), [0, 0, 0], [0, 0, 0, 1],
                      useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE)
    for j in range(p.getNumJoints(body)):
        if p.getDynamicsInfo(body, j)[0] == 0.0:
            p.changeDynamics(body, j, mass=1e-3, localInertiaDiagonal=[1e-6] * 3)
    return body


def movable(body):
    return [j for j in range(p.getNumJoints(body)) if p.getJointInfo(body, j)[2] != p.JOINT_FIXED]


def holding():
    body = load(ROBOTS[0])
    for j, q in enumerate(HOLD):
        p.resetJointState(body, j, q)
        p.enableJointForceTorqueSensor(body, j, 1)
    p.setJointMotorControlArray(body, list(range(7)), p.POSITION_CONTROL, targetPositions=HOLD,
                                forces=[500.0] * 7)
    for _ in range(2000):
        p.stepSimulation()
    joints = []
    for j in range(7):
        s = p.getJointState(body, j)
        joints.append({"joint_index": j, "joint_position": s[0], "reaction_forces": list(s[2]),
                       "motor_torque": s[3]})
    p.removeBody(body)
    return {"robot": ROBOTS[0], "positions": HOLD, "max_force": 500.0, "steps": 2000,
            "timestep": 1.0 / 240.0, "joints": joints}


def dynamics(name, rng):
    body = load(name)
    dofs = movable(body)
    link = p.getNumJoints(body) - 1
    cases = []
    for _ in range(5):
        q, qd, qdd = [], [], []
        for j in dofs:
            lo, hi = p.getJointInfo(body, j)[8:10]
            q.append(rng.uniform(lo, hi) if lo < hi else rng.uniform(-3, 3))
            qd.append(rng.uniform(-1, 1))
            qdd.append(rng.uniform(-1, 1))
        for j, x, v in zip(dofs, q, qd):
            p.resetJointState(body, j, x, v)
        lin, ang = p.calculateJacobian(body, link, LOCAL, q, qd, qdd)
        mass = p.calculateMassMatrix(body, q)
        tau = p.calculateInverseDynamics(body, q, qd, qdd)
        cases.append({"positions": q, "velocities": qd, "accelerations": qdd,
                      "linear_jacobian": [list(r) for r in lin], "angular_jacobian": [list(r) for r in ang],
                      "mass_matrix": [list(r) for r in mass], "joint_forces": list(tau)})
    p.removeBody(body)
    return {"robot": name, "link_index": link, "local_position": LOCAL, "cases": cases}


p.connect(p.DIRECT)
p.setGravity(0, 0, -9.81)
p.setTimeStep(1.0 / 240.0)
rng = random.Random(44)
out = {"pybullet": p.getAPIVersion() and "3.2.7", "gravity": [0, 0, -9.81], "holding": holding(),
       "dynamics": [dynamics(name, rng) for name in ROBOTS]}
with open(OUT, "w") as f:
    json.dump(out, f, indent=1)
    f.write("\n")
print("wrote", OUT)
