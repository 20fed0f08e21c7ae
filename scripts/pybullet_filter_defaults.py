#!/usr/bin/env python3
"""Empirically determine PyBullet's default collision filter group/mask for
static (mass 0) vs dynamic bodies, as seen by setCollisionFilterGroupMask.

PyBullet exposes no getter for a body's group/mask (there is no
getCollisionFilterGroupMask), so defaults are inferred from behaviour:

  * drop tests: a dynamic sphere (r=0.1, m=1) falls from z=1 onto a static
    support for 480 steps of the default 1/240 s; the sphere's group/mask is
    set explicitly and we see whether it rests (z ~= 0.1) or falls through.
  * stacked dynamic boxes: the top box's mask is changed.
  * bit probes: with gravity off, a probe sphere overlapping a target body
    gets group=-1/mask=(1<<k) (contact iff target.group has bit k) or
    group=(1<<k)/mask=-1 (contact iff target.mask has bit k);
    performCollisionDetection() + getContactPoints() reads the pair test.

Found (pybullet 3.2.7): PyBullet's world tests a pair *either* way,
(g0 & m1) != 0 or (g1 & m0) != 0 (B3_FILTER_GROUPAMASKB_OR_GROUPBMASKA; Bullet's
classic both-ways test only after setPhysicsEngineParameter(collisionFilterMode=0));
dynamic bodies default to group 1, mask all; static bodies (mass 0, fixed base)
to group 2, mask all but 2 (Bullet's StaticFilter).

Uses only the stdlib and pybullet. Prints a JSON document; with
`--fixture PATH` also writes the reference tests/physics/agent_calls.rs checks
the server against (default filter mode: drops onto plane.urdf and a static
box, and the stacked boxes):

  python scripts/pybullet_filter_defaults.py --fixture tests/fixtures/pybullet_filter_defaults.json
"""
import json
import sys

import pybullet as p
import pybullet_data

STEPS = 480
RADIUS = 0.1


def s32(v):
    """Convert an unsigned 32-bit pattern to the signed int PyBullet parses."""
    v &= 0xFFFFFFFF
    return v - (1 << 32) if v & 0x80000000 else v


def hex32(v):
    return "0x%08X" % (v & 0xFFFFFFFF)


# filter modes: None = PyBullet default (no call), 0 = AND, 1 = OR
MODES = {"default": None, "AND(0)": 0, "OR(1)": 1}


def new_world(gravity=-9.81, mode=None):
    cid = p.connect(p.DIRECT)
    p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=cid)
    p.setGravity(0, 0, gravity, physicsClientId=cid)
    if mode is not None:
        p.setPhysicsEngineParameter(collisionFilterMode=mode, physicsClientId=cid)
    return cid


def make_support(kind, cid):
    if kind == "plane.urdf":
        return p.loadURDF("plane.urdf", physicsClientId=cid)
    if kind in ("static_box", "static_box_maximal"):
        col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[2, 2, 0.05], physicsClientId=cid)
        return p.createMultiBody(
            baseMass=0,
            baseCollisionShapeIndex=col,
            basePosition=[0, 0, -0.05],
            useMaximalCoordinates=(kind == "static_box_maximal"),
            physicsClientId=cid,
        )
    raise ValueError(kind)


def make_sphere(cid, z, mass=1.0):
    col = p.createCollisionShape(p.GEOM_SPHERE, radius=RADIUS, physicsClientId=cid)
    return p.createMultiBody(baseMass=mass, baseCollisionShapeIndex=col,
                             basePosition=[0, 0, z], physicsClientId=cid)


def make_box(cid, z, mass=1.0, half=0.1):
    col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[half] * 3, physicsClientId=cid)
    return p.createMultiBody(baseMass=mass, baseCollisionShapeIndex=col,
                             basePosition=[0, 0, z], physicsClientId=cid)


def drop_case(support_kind, group, mask, mode=None):
    cid = new_world(mode=mode)
    sup = make_support(support_kind, cid)
    sph = make_sphere(cid, 1.0)
    if group is not None:
        p.setCollisionFilterGroupMask(sph, -1, collisionFilterGroup=group,
                                      collisionFilterMask=mask, physicsClientId=cid)
    for _ in range(STEPS):
        p.stepSimulation(physicsClientId=cid)
    z = p.getBasePositionAndOrientation(sph, physicsClientId=cid)[0][2]
    contacts = len(p.getContactPoints(sph, sup, physicsClientId=cid))
    p.disconnect(cid)
    return {
        "support": support_kind,
        "sphere_group": None if group is None else group,
        "sphere_mask": None if mask is None else mask,
        "sphere_group_hex": None if group is None else hex32(group),
        "sphere_mask_hex": None if mask is None else hex32(mask),
        "final_z": round(z, 4),
        "contacts_with_support": contacts,
        "resting": abs(z - RADIUS) < 0.01 and contacts > 0,
    }


def stack_case(top_group, top_mask, mode=None):
    """Bottom dynamic box on plane.urdf, top dynamic box on bottom box."""
    cid = new_world(mode=mode)
    plane = make_support("plane.urdf", cid)
    bottom = make_box(cid, 0.1)
    top = make_box(cid, 0.3)
    if top_mask is not None:
        p.setCollisionFilterGroupMask(top, -1, collisionFilterGroup=top_group,
                                      collisionFilterMask=top_mask, physicsClientId=cid)
    for _ in range(STEPS):
        p.stepSimulation(physicsClientId=cid)
    zt = p.getBasePositionAndOrientation(top, physicsClientId=cid)[0][2]
    zb = p.getBasePositionAndOrientation(bottom, physicsClientId=cid)[0][2]
    r = {
        "top_group": top_group,
        "top_mask": top_mask,
        "top_final_z": round(zt, 4),
        "bottom_final_z": round(zb, 4),
        "top_bottom_contacts": len(p.getContactPoints(top, bottom, physicsClientId=cid)),
        "top_plane_contacts": len(p.getContactPoints(top, plane, physicsClientId=cid)),
        "top_resting_on_bottom": abs(zt - 0.3) < 0.01
        and len(p.getContactPoints(top, bottom, physicsClientId=cid)) > 0,
    }
    p.disconnect(cid)
    return r


def probe_target(kind, mode):
    """Infer a target body's group and mask bit by bit.

    OR mode (1):  (pg & tm) || (tg & pm)
        probe group=0,     mask=bit -> touches iff tg has bit
        probe group=bit,   mask=0   -> touches iff tm has bit
    AND mode (0): (pg & tm) && (tg & pm)
        probe group=-1,    mask=bit -> touches iff tg has bit (tm != 0)
        probe group=bit,   mask=-1  -> touches iff tm has bit (tg != 0)
    """

    def touches(probe_group, probe_mask):
        cid = new_world(gravity=0.0, mode=mode)
        if kind == "dynamic_box":
            tgt = make_box(cid, 0.0, mass=1.0, half=0.5)
        elif kind == "dynamic_box_maximal":
            col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.5] * 3, physicsClientId=cid)
            tgt = p.createMultiBody(baseMass=1.0, baseCollisionShapeIndex=col,
                                    basePosition=[0, 0, 0], useMaximalCoordinates=True,
                                    physicsClientId=cid)
        elif kind == "dynamic_urdf_cube":
            tgt = p.loadURDF("cube.urdf", [0, 0, 0], physicsClientId=cid)
        else:
            tgt = make_support(kind, cid)
        # probe sphere overlapping the target's top surface (z=0 for the
        # static supports; within the 0.5 box / cube.urdf for dynamic targets)
        zs = 0.45 if kind.startswith("dynamic") else 0.05
        sph = make_sphere(cid, zs)
        p.setCollisionFilterGroupMask(sph, -1, collisionFilterGroup=probe_group,
                                      collisionFilterMask=probe_mask, physicsClientId=cid)
        p.performCollisionDetection(physicsClientId=cid)
        n = len(p.getContactPoints(sph, tgt, physicsClientId=cid))
        p.disconnect(cid)
        return n > 0

    other = 0 if mode == 1 else -1
    group_bits = 0
    mask_bits = 0
    for k in range(32):
        bit = s32(1 << k)
        if touches(other, bit):
            group_bits |= 1 << k
        if touches(bit, other):
            mask_bits |= 1 << k
    sanity_all = touches(-1, -1)
    return {
        "target": kind,
        "filter_mode": {0: "AND(0)", 1: "OR(1)"}[mode],
        "inferred_group": hex32(group_bits),
        "inferred_mask": hex32(mask_bits),
        "sanity_probe_all_all_touches": sanity_all,
    }


def main():
    drop_filters = [
        ("no setCollisionFilterGroupMask call", None, None),
        ("group=1 mask=1", 1, 1),
        ("group=1 mask=2", 1, 2),
        ("group=2 mask=2", 2, 2),
        ("group=1 mask=0xFFFF^2 (=65533)", 1, 0xFFFF ^ 2),
        ("group=1 mask=-1 (all)", 1, -1),
        ("group=2 mask=-1 (all)", 2, -1),
        ("group=2 mask=1", 2, 1),
        ("group=4 mask=2", 4, 2),
        ("group=3 mask=2", 3, 2),
    ]
    drops = []
    for mode_name, mode in MODES.items():
        for support in ("plane.urdf", "static_box", "static_box_maximal"):
            for label, g, m in drop_filters:
                r = drop_case(support, g, m, mode)
                r["case"] = label
                r["filter_mode"] = mode_name
                drops.append(r)

    stacks = []
    for mode_name, mode in MODES.items():
        for label, g, m in [("no call", None, None), ("top group=1 mask=1", 1, 1),
                            ("top group=1 mask=2", 1, 2), ("top group=1 mask=0", 1, 0),
                            ("top group=0 mask=0", 0, 0)]:
            r = stack_case(g, m, mode)
            r["case"] = label
            r["filter_mode"] = mode_name
            stacks.append(r)

    probes = [probe_target(k, mode) for mode in (1, 0)
              for k in ("plane.urdf", "static_box", "static_box_maximal",
                        "dynamic_box", "dynamic_box_maximal", "dynamic_urdf_cube")]

    getter = [n for n in dir(p) if "filter" in n.lower() or "groupmask" in n.lower()]
    out = {
        "pybullet_api_version": p.getAPIVersion(),
        "python": sys.version.split()[0],
        "steps": STEPS,
        "timestep": "default (1/240)",
        "filter_related_api": getter,
        "has_getCollisionFilterGroupMask": hasattr(p, "getCollisionFilterGroupMask"),
        "drop_tests": drops,
        "stacked_dynamic_boxes": stacks,
        "bit_probes": probes,
    }
    print(json.dumps(out, indent=1))
    if "--fixture" in sys.argv:
        path = sys.argv[sys.argv.index("--fixture") + 1]
        keep = ("case", "sphere_group", "sphere_mask", "final_z", "resting", "support",
                "top_group", "top_mask", "top_final_z", "top_resting_on_bottom")
        trim = lambda r: {k: v for k, v in r.items() if k in keep}
        fixture = {
            "made_by": "scripts/pybullet_filter_defaults.py --fixture",
            "pybullet_api_version": out["pybullet_api_version"],
            "steps": STEPS,
            "drop_tests": [trim(r) for r in drops if r["filter_mode"] == "default"
                           and r["support"] in ("plane.urdf", "static_box")],
            "stacked_dynamic_boxes": [trim(r) for r in stacks if r["filter_mode"] == "default"],
        }
        with open(path, "w") as f:
            json.dump(fixture, f, indent=1)
            f.write("\n")


if __name__ == "__main__":
    main()
