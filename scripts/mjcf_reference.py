"""Writes tests/reference/mjcf_mujoco.json: what MuJoCo itself reports for every MJCF fixture
under tests/fixtures/mjcf/ (Gymnasium's MuJoCo models, MIT, see LICENSE.gymnasium there) —
the reference load_mjcf, get_joint_info, get_dynamics_info and get_link_state must match.

Per model: the joints in file order (name, type, range when limited, ref, damping, armature,
qpos address), the bodies (name, parent, mass — compare masses, not inertias: rapier folds
`armature` into the link inertia; the principal inertia `body_inertia` is there for models
without armature), and the world position (`xpos`), orientation (`xquat`, converted to
[x, y, z, w]) and centre of mass (`xipos`) of every body after `mj_forward` at qpos0 and at 5 random
configurations (numpy's default_rng(14); each hinge/slide uniform inside its range, an
unlimited hinge inside [-pi, pi], free joints kept at qpos0). Configurations are given as
qpos per hinge/slide joint — MuJoCo's qpos, `ref` included — as reset_joint_state takes them.

Dev-only (mujoco is not a dependency): python -m venv /tmp/mj && /tmp/mj/bin/pip install
mujoco numpy && /tmp/mj/bin/python scripts/mjcf_reference.py
"""
import json
import math
import os
import struct

import mujoco
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
FIXTURES = os.path.join(HERE, "..", "tests", "fixtures", "mjcf")
OUT = os.path.join(HERE, "..", "tests", "reference", "mjcf_mujoco.json")
MODELS = ["ant", "half_cheetah", "hopper", "humanoid", "humanoidstandup", "inverted_pendulum",
          "inverted_double_pendulum", "pusher", "reacher", "swimmer", "walker2d", "mesh_robot"]
TYPES = {int(mujoco.mjtJoint.mjJNT_FREE): "free", int(mujoco.mjtJoint.mjJNT_BALL): "ball",
         int(mujoco.mjtJoint.mjJNT_SLIDE): "slide", int(mujoco.mjtJoint.mjJNT_HINGE): "hinge"}
CONFIGURATIONS = 5


def name(m, kind, i):
    return mujoco.mj_id2name(m, kind, i) or ""


def frames(m, d):
    """World frame of every body but the world: xpos, xquat as [x, y, z, w], and xipos."""
    return [{"body": name(m, mujoco.mjtObj.mjOBJ_BODY, b), "xpos": d.xpos[b].tolist(),
             "xquat": [*d.xquat[b][1:].tolist(), float(d.xquat[b][0])],
             "xipos": d.xipos[b].tolist()} for b in range(1, m.nbody)]


def write_meshes():
    """The meshes of mesh_robot.xml (our own fixture): a tetrahedron as binary STL and an
    L-shaped prism (non-convex) as OBJ, faces outward."""
    out = os.path.join(FIXTURES, "meshes")
    os.makedirs(out, exist_ok=True)
    v = [(0, 0, 0), (0.2, 0, 0), (0, 0.2, 0), (0, 0, 0.2)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    with open(os.path.join(out, "tetra.stl"), "wb") as f:
        f.write(b"physics-mcp test tetrahedron".ljust(80, b" "))
        f.write(struct.pack("<I", len(faces)))
        for t in faces:
            f.write(struct.pack("<3f", 0, 0, 0))
            for i in t:
                f.write(struct.pack("<3f", *v[i]))
            f.write(struct.pack("<H", 0))
    ell = [(0, 0), (0.2, 0), (0.2, 0.1), (0.1, 0.1), (0.1, 0.3), (0, 0.3)]
    verts = [(x, y, 0) for x, y in ell] + [(x, y, 0.1) for x, y in ell]
    fan = [(0, 1, 2), (0, 2, 3), (0, 3, 4), (0, 4, 5)]  # counter-clockwise seen from +z
    tris = [(a, c, b) for a, b, c in fan] + [(a + 6, b + 6, c + 6) for a, b, c in fan]
    for i in range(6):
        j = (i + 1) % 6
        tris += [(i, j, j + 6), (i, j + 6, i + 6)]
    with open(os.path.join(out, "lshape.obj"), "w") as f:
        f.write("# L-shaped prism, non-convex\no lshape\n")
        for p in verts:
            f.write("v %g %g %g\n" % p)
        for a, b, c in tris:
            f.write("f %d %d %d\n" % (a + 1, b + 1, c + 1))


write_meshes()
rng = np.random.default_rng(14)
out = {"mujoco": mujoco.__version__, "seed": 14, "models": {}}
for model in MODELS:
    m = mujoco.MjModel.from_xml_path(os.path.join(FIXTURES, model + ".xml"))
    d = mujoco.MjData(m)
    joints = []
    for j in range(m.njnt):
        limited = bool(m.jnt_limited[j])
        joints.append({"name": name(m, mujoco.mjtObj.mjOBJ_JOINT, j), "type": TYPES[int(m.jnt_type[j])],
                       "limited": limited, "range": m.jnt_range[j].tolist() if limited else None,
                       "ref": float(m.qpos0[m.jnt_qposadr[j]]) if int(m.jnt_type[j]) in
                       (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)) else None,
                       "damping": float(m.dof_damping[m.jnt_dofadr[j]]),
                       "armature": float(m.dof_armature[m.jnt_dofadr[j]]),
                       "body": name(m, mujoco.mjtObj.mjOBJ_BODY, m.jnt_bodyid[j]),
                       "qposadr": int(m.jnt_qposadr[j])})
    bodies = [{"name": name(m, mujoco.mjtObj.mjOBJ_BODY, b),
               "parent": name(m, mujoco.mjtObj.mjOBJ_BODY, m.body_parentid[b]),
               "mass": float(m.body_mass[b]), "inertia": m.body_inertia[b].tolist()}
              for b in range(1, m.nbody)]
    mujoco.mj_resetData(m, d)
    mujoco.mj_forward(m, d)
    configurations = [{"qpos": {}, "frames": frames(m, d)}]
    for _ in range(CONFIGURATIONS):
        mujoco.mj_resetData(m, d)
        qpos = {}
        for j in joints:
            if j["type"] not in ("hinge", "slide"):
                continue
            lo, hi = j["range"] if j["limited"] else (-math.pi, math.pi)
            if not j["limited"] and j["type"] == "slide":
                lo, hi = -0.5, 0.5
            q = float(rng.uniform(lo, hi))
            d.qpos[j["qposadr"]] = q
            qpos[j["name"]] = q
        mujoco.mj_forward(m, d)
        configurations.append({"qpos": qpos, "frames": frames(m, d)})
    out["models"][model] = {"timestep": float(m.opt.timestep), "gravity": m.opt.gravity.tolist(),
                            "nq": int(m.nq), "joints": joints, "bodies": bodies,
                            "configurations": configurations}

os.makedirs(os.path.dirname(OUT), exist_ok=True)
with open(OUT, "w") as f:
    json.dump(out, f, indent=1)
print("wrote", OUT)
