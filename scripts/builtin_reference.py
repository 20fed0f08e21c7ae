"""Writes tests/reference/pybullet_builtins.json: what pybullet 3.2.7 reports for every URDF
built-in model — the reference a built-in loaded by name must match (tests/physics/builtins.rs).
The library's files (crates/physics-models/models/, the bytes the server embeds) are first
checked to be pybullet_data's own, byte for byte; pybullet then loads its own copies, which
still have the visual meshes the library leaves out (pybullet refuses a URDF without them).

Per model, loaded with useFixedBase=True at BASE_POSITION / BASE_ORIENTATION and
URDF_USE_INERTIA_FROM_FILE (the server uses a file's <inertial> as written):
- the joint table: getJointInfo of every joint (name, type — a continuous joint is reported
  as revolute, "revolute_or_continuous" here — limits, effort and velocity limits, axis, child
  link, parent index), and the child link's inertial frame in its link frame (getDynamicsInfo's
  local inertial orientation): pybullet reports the axis in that frame, which is the file's
  <inertial> frame turned to the principal axes when the file's tensor is not diagonal (a1);
  `inertia_off_diagonal` says whether it is;
- each link's mass (getDynamicsInfo of a second load with a free base and default flags, so
  the base has its own mass too; a link without <inertial> gets pybullet's stand-in, 1 kg);
- the link frames: getLinkState(computeForwardKinematics=1) of every link — link frame and
  centre-of-mass frame in the world — with every movable joint at 0 and after resetJointState
  has set each to a position inside its limits (`target`, as scripts/link_state_fixtures.py).

Dev-only (pybullet is not a dependency): python -m venv /tmp/pb && /tmp/pb/bin/pip install
pybullet==3.2.7 numpy && /tmp/pb/bin/python scripts/builtin_reference.py
"""
import json
import os
import xml.etree.ElementTree as ET

import pybullet as p
import pybullet_data

HERE = os.path.dirname(os.path.abspath(__file__))
MODELS = os.path.join(HERE, "..", "crates", "physics-models", "models")
OUT = os.path.join(HERE, "..", "tests", "reference", "pybullet_builtins.json")
# The URDF built-ins of crates/physics-models/src/catalog.rs.
FILES = ["kuka_iiwa/model.urdf", "franka_panda/panda.urdf", "r2d2.urdf", "racecar/racecar.urdf",
         "husky/husky.urdf", "a1/a1.urdf", "cartpole.urdf", "table/table.urdf",
         "table_square/table_square.urdf", "tray/traybox.urdf", "lego/lego.urdf",
         "domino/domino.urdf", "jenga/jenga.urdf", "cube_small.urdf", "sphere_small.urdf",
         "sphere2.urdf"]
BASE_POSITION = [0.1, -0.2, 0.5]
BASE_ORIENTATION = [0.0, 0.0, 0.38268343236508984, 0.9238795325112867]  # 45 degrees about z
TYPES = {p.JOINT_REVOLUTE: "revolute", p.JOINT_PRISMATIC: "prismatic", p.JOINT_SPHERICAL: "spherical",
         p.JOINT_PLANAR: "planar", p.JOINT_FIXED: "fixed"}


def target(info, j):
    """A position inside the joint's limits (any value when it has none)."""
    lower, upper = info[8], info[9]
    q = 0.3 + 0.17 * j
    if lower <= upper:
        q = lower + (upper - lower) * (0.2 + 0.13 * (j % 5))
    return q


def frames(body):
    out = []
    for link in range(p.getNumJoints(body)):
        s = p.getLinkState(body, link, computeForwardKinematics=1)
        out.append({"link_index": link, "com_world_position": list(s[0]), "com_world_orientation": list(s[1]),
                    "link_world_position": list(s[4]), "link_world_orientation": list(s[5])})
    return out


p.connect(p.DIRECT)
out = {"pybullet": "3.2.7", "base_position": BASE_POSITION, "base_orientation": BASE_ORIENTATION,
       "use_fixed_base": True, "models": {}}
for root, _, names in os.walk(MODELS):
    for f in names:
        rel = os.path.relpath(os.path.join(root, f), MODELS)
        with open(os.path.join(MODELS, rel), "rb") as a, open(os.path.join(pybullet_data.getDataPath(), rel), "rb") as b:
            assert a.read() == b.read(), f"{rel} differs from pybullet_data's"
for name in FILES:
    path = os.path.join(pybullet_data.getDataPath(), name)
    body = p.loadURDF(path, BASE_POSITION, BASE_ORIENTATION, useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE)
    default_flags = p.loadURDF(path, [0, 0, 10], flags=0)
    root = ET.parse(path).getroot()
    with_inertial = {l.get("name") for l in root.iter("link") if l.find("inertial") is not None}
    file_types = {j.get("name"): j.get("type") for j in root.findall("joint")}
    off_diagonal = {}
    for l in root.iter("link"):
        inertia = l.find("inertial/inertia")
        off_diagonal[l.get("name")] = inertia is not None and any(
            float(inertia.get(k, "0")) != 0.0 for k in ("ixy", "ixz", "iyz"))
    joints = []
    for j in range(p.getNumJoints(body)):
        info = p.getJointInfo(body, j)
        kind = TYPES[info[2]]
        if kind == "revolute" and file_types[info[1].decode()] == "continuous":
            kind = "revolute_or_continuous"
        joints.append({"joint_index": info[0], "joint_name": info[1].decode(), "joint_type": kind,
                       "lower_limit": info[8], "upper_limit": info[9], "max_force": info[10],
                       "max_velocity": info[11], "link_name": info[12].decode(),
                       "joint_axis": list(info[13]), "parent_index": info[16],
                       "local_inertial_orientation": list(p.getDynamicsInfo(body, j)[4]),
                       "inertia_off_diagonal": off_diagonal[info[12].decode()]})
    masses = []
    for link in range(-1, p.getNumJoints(body)):
        link_name = (p.getBodyInfo(body)[0] if link < 0 else p.getJointInfo(body, link)[12]).decode()
        in_file = link_name in with_inertial
        masses.append({"link_index": link, "link_name": link_name, "inertial_in_file": in_file,
                       "mass": p.getDynamicsInfo(default_flags, link)[0]})
    at_zero = frames(body)
    resets = []
    for j in range(p.getNumJoints(body)):
        info = p.getJointInfo(body, j)
        if info[2] == p.JOINT_FIXED:
            continue
        q = target(info, j)
        p.resetJointState(body, j, q, 0.0)
        resets.append({"joint_index": j, "target_value": q})
    out["models"][name] = {"num_joints": p.getNumJoints(body), "joints": joints, "masses": masses,
                           "configurations": [{"resets": [], "links": at_zero},
                                              {"resets": resets, "links": frames(body)}]}
    p.removeBody(body)
    p.removeBody(default_flags)

os.makedirs(os.path.dirname(OUT), exist_ok=True)
with open(OUT, "w") as f:
    json.dump(out, f, indent=1)
print("wrote", OUT)
