"""Writes tests/reference/pybullet_link_state.json: what pybullet 3.2.7 reports through
getLinkState (computeLinkVelocity=1, computeForwardKinematics=1) for every link of the URDF
robot fixtures after resetJointState has set every movable joint to a fixed position and
velocity — the reference get_link_state after reset_joint_state must match.

Field names are ours (SPEC "Robots"): link_world_position/orientation is pybullet's
worldLinkFrame (tuple items 4, 5: the URDF link frame), com_world_position/orientation its
linkWorld (items 0, 1: the inertial frame), linear/angular_velocity items 6, 7.

Dev-only (pybullet is not a dependency): python -m venv /tmp/pb && /tmp/pb/bin/pip install
pybullet==3.2.7 numpy && /tmp/pb/bin/python scripts/link_state_fixtures.py
"""
import json
import os

import pybullet as p

HERE = os.path.dirname(os.path.abspath(__file__))
FIXTURES = os.path.join(HERE, "..", "tests", "fixtures")
OUT = os.path.join(HERE, "..", "tests", "reference", "pybullet_link_state.json")
FILES = ["two_link_arm.urdf", "iiwa14.urdf", "wheeled_base.urdf", "continuous_limits.urdf"]
BASE_POSITION = [0.1, -0.2, 0.5]
BASE_ORIENTATION = [0.0, 0.0, 0.38268343236508984, 0.9238795325112867]  # 45 degrees about z


def target(info, j):
    """A position inside the joint's limits (any value when it has none) and a velocity."""
    lower, upper = info[8], info[9]
    q = 0.3 + 0.17 * j
    if lower <= upper:
        q = lower + (upper - lower) * (0.2 + 0.13 * (j % 5))
    return q, 0.1 * (j + 1)


p.connect(p.DIRECT)
out = {"pybullet": "3.2.7", "base_position": BASE_POSITION, "base_orientation": BASE_ORIENTATION,
       "use_fixed_base": True, "robots": {}}
for name in FILES:
    body = p.loadURDF(os.path.join(FIXTURES, name), BASE_POSITION, BASE_ORIENTATION,
                      useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE)
    resets = []
    for j in range(p.getNumJoints(body)):
        info = p.getJointInfo(body, j)
        if info[2] == p.JOINT_FIXED:
            continue
        q, v = target(info, j)
        p.resetJointState(body, j, q, v)
        resets.append({"joint_index": j, "target_value": q, "target_velocity": v})
    links = []
    for link in range(p.getNumJoints(body)):
        s = p.getLinkState(body, link, computeLinkVelocity=1, computeForwardKinematics=1)
        links.append({"link_index": link, "com_world_position": list(s[0]),
                      "com_world_orientation": list(s[1]), "link_world_position": list(s[4]),
                      "link_world_orientation": list(s[5]), "linear_velocity": list(s[6]),
                      "angular_velocity": list(s[7])})
    joints = [{"joint_index": j, "joint_position": p.getJointState(body, j)[0],
               "joint_velocity": p.getJointState(body, j)[1]} for j in range(p.getNumJoints(body))]
    out["robots"][name] = {"resets": resets, "links": links, "joints": joints}
    p.removeBody(body)

os.makedirs(os.path.dirname(OUT), exist_ok=True)
with open(OUT, "w") as f:
    json.dump(out, f, indent=1)
print("wrote", OUT)
