"""Writes tests/fixtures/pybullet_urdf.json: what pybullet itself reports for every robot
fixture under tests/fixtures/ — joint count, getJointInfo per joint and getDynamicsInfo per
link — the reference load_urdf, get_joint_info and get_dynamics_info must match.

Inertia: we use the file's `<inertial>` as written — pybullet does so only with
URDF_USE_INERTIA_FROM_FILE (by default it replaces the tensor by its collision shapes') — and a
link without one gets pybullet's default-flags stand-in (1 kg, its collision shapes' inertia;
with the flag pybullet would give such a link 1 kg·m² on every axis). So each link's reference
comes from the load that matches: with the flag for links with an `<inertial>`, without it
for links that have none (`"inertial_in_file"` says which).

Motion: pybullet reports a continuous joint's `<limit lower upper>` but does it enforce them?
For continuous_limits.urdf every joint gets a velocity motor past its limits; `"motion"` records
the joint positions pybullet reaches and whether each stayed within its reported limits.

Dev-only (pybullet is not a dependency): python -m venv /tmp/pb && /tmp/pb/bin/pip install
pybullet==3.2.7 && /tmp/pb/bin/python scripts/urdf_fixtures.py
"""
import json
import os
import xml.etree.ElementTree as ET

import pybullet as p

HERE = os.path.dirname(os.path.abspath(__file__))
FIXTURES = os.path.join(HERE, "..", "tests", "fixtures")
FILES = ["two_link_arm.urdf", "iiwa14.urdf", "wheeled_base.urdf", "mesh_bot/urdf/mesh_bot.urdf",
         "continuous_limits.urdf"]
MOTION_FILE = "continuous_limits.urdf"
MOTION = {"target_velocity": 1.0, "force": 10.0, "steps": 240}
TYPES = {p.JOINT_REVOLUTE: "revolute", p.JOINT_PRISMATIC: "prismatic", p.JOINT_SPHERICAL: "spherical",
         p.JOINT_PLANAR: "planar", p.JOINT_FIXED: "fixed"}

p.connect(p.DIRECT)
out = {"pybullet": "3.2.7", "inertia": "URDF_USE_INERTIA_FROM_FILE for links with <inertial>, default flags for links without", "robots": {}}
for name in FILES:
    path = os.path.join(FIXTURES, name)
    body = p.loadURDF(path, flags=p.URDF_USE_INERTIA_FROM_FILE)
    default_flags = p.loadURDF(path, flags=0)
    root = ET.parse(path).getroot()
    with_inertial = {l.get("name") for l in root.iter("link") if l.find("inertial") is not None}
    file_types = {j.get("name"): j.get("type") for j in root.findall("joint")}
    joints = []
    for j in range(p.getNumJoints(body)):
        info = p.getJointInfo(body, j)
        kind = TYPES[info[2]]
        # pybullet reports a continuous joint as revolute (with the limits its <limit> gives,
        # else the "no limit" pair 0, -1): it cannot tell the two apart, the file can.
        if kind == "revolute" and file_types[info[1].decode()] == "continuous":
            kind = "revolute_or_continuous"
        joints.append({"joint_index": info[0], "joint_name": info[1].decode(), "joint_type": kind,
                       "lower_limit": info[8], "upper_limit": info[9], "max_force": info[10],
                       "max_velocity": info[11], "link_name": info[12].decode(),
                       "joint_axis": list(info[13]), "parent_index": info[16]})
    links = []
    for link in range(-1, p.getNumJoints(body)):
        link_name = (p.getBodyInfo(body)[0] if link < 0 else p.getJointInfo(body, link)[12]).decode()
        in_file = link_name in with_inertial
        d = p.getDynamicsInfo(body if in_file else default_flags, link)
        links.append({"link_index": link, "link_name": link_name, "inertial_in_file": in_file,
                      "mass": d[0], "local_inertia_diagonal": list(d[2]),
                      "local_inertia_pos": list(d[3])})
    out["robots"][name] = {"num_joints": p.getNumJoints(body), "joints": joints, "links": links}
    p.removeBody(body)
    p.removeBody(default_flags)

# Drive every joint of MOTION_FILE with a velocity motor for 1 s: a continuous joint passes
# its <limit lower upper>, the revolute control stops at its upper limit.
body = p.loadURDF(os.path.join(FIXTURES, MOTION_FILE), useFixedBase=True)
for j in range(p.getNumJoints(body)):
    p.setJointMotorControl2(body, j, p.VELOCITY_CONTROL, targetVelocity=MOTION["target_velocity"],
                            force=MOTION["force"])
for _ in range(MOTION["steps"]):
    p.stepSimulation()
joints = []
for j in range(p.getNumJoints(body)):
    info, q = p.getJointInfo(body, j), p.getJointState(body, j)[0]
    lower, upper = info[8], info[9]
    enforced = lower <= upper and q <= upper + 1e-3
    joints.append({"joint_index": j, "joint_name": info[1].decode(), "lower_limit": lower,
                   "upper_limit": upper, "joint_position": q, "limits_enforced": enforced})
out["motion"] = dict(MOTION, file=MOTION_FILE, control_mode="VELOCITY_CONTROL", timestep=1 / 240,
                     use_fixed_base=True, joints=joints)
p.removeBody(body)

path = os.path.join(FIXTURES, "pybullet_urdf.json")
with open(path, "w") as f:
    json.dump(out, f, indent=1)
print("wrote", path)
