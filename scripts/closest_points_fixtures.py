"""Writes tests/reference/pybullet_closest_points.json: what pybullet 3.2.7's getClosestPoints
reports, for the server's get_closest_points to be checked against:

- "primitives": pairs of boxes, spheres and capsules (capsule height = the cylindrical part,
  along local z, as add_capsule), seeded random poses, some apart and some overlapping; per
  pair the smallest contactDistance pybullet reports within 1 m and the normal on B with it,
  and "exact": the distance computed here from the geometry alone (numpy: closest features of
  boxes, segments and points), wherever that is simple — every pair apart, and a sphere in a
  box — since pybullet's GJK answers for boxes are off by up to ~1 mm (null elsewhere);
- "robot": the KUKA iiwa (kuka_iiwa/model.urdf, fixed at the origin) at a bent pose and a
  sphere beside it; per link the smallest contactDistance within 1 m (mesh links are convex
  hulls in both, and pybullet adds its collision margin there).

Dev-only (pybullet is not a dependency): /tmp/pb/bin/python scripts/closest_points_fixtures.py
"""
import itertools
import json
import math
import os
import random

import numpy as np

import pybullet as p
import pybullet_data

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "tests", "reference", "pybullet_closest_points.json")
POSE = [0.3, 0.6, -0.2, -1.1, 0.4, 0.8, 0.1]
BALL = {"radius": 0.1, "position": [0.35, 0.1, 0.9]}
RANGE = 1.0


def shape(rng, kind):
    if kind == "box":
        return {"kind": kind, "half_extents": [rng.uniform(0.05, 0.3) for _ in range(3)]}
    if kind == "sphere":
        return {"kind": kind, "radius": rng.uniform(0.05, 0.3)}
    return {"kind": kind, "radius": rng.uniform(0.05, 0.2), "height": rng.uniform(0.1, 0.5)}


def body(s, position, orientation):
    if s["kind"] == "box":
        c = p.createCollisionShape(p.GEOM_BOX, halfExtents=s["half_extents"])
    elif s["kind"] == "sphere":
        c = p.createCollisionShape(p.GEOM_SPHERE, radius=s["radius"])
    else:
        c = p.createCollisionShape(p.GEOM_CAPSULE, radius=s["radius"], height=s["height"])
    return p.createMultiBody(0, c, -1, position, orientation)


def unit_quat(rng):
    q = [rng.gauss(0, 1) for _ in range(4)]
    n = math.sqrt(sum(x * x for x in q))
    return [x / n for x in q]


def rot(q):
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def corners(b):
    h, r, p = np.array(b["half_extents"]), rot(b["orientation"]), np.array(b["position"])
    return [p + r @ (h * np.array(s)) for s in itertools.product([-1, 1], repeat=3)]


def box_edges(b):
    v = corners(b)
    return [(v[i], v[j]) for i in range(8) for j in range(i + 1, 8) if bin(i ^ j).count("1") == 1]


def point_box(pt, b):
    """Signed distance from a point to a box (negative inside: minus the depth to the nearest face)."""
    h, r, p = np.array(b["half_extents"]), rot(b["orientation"]), np.array(b["position"])
    local = r.T @ (pt - p)
    outside = np.linalg.norm(local - np.clip(local, -h, h))
    return outside if outside > 0 else -float(np.min(h - np.abs(local)))


def seg_seg(p1, q1, p2, q2):
    """Distance between two segments (Ericson, Real-Time Collision Detection 5.1.9)."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, e, f, c, b = d1 @ d1, d2 @ d2, d2 @ r, d1 @ r, d1 @ d2
    if a < 1e-12 or e < 1e-12:  # a point: the other segment's closest point to it
        s = 0.0 if a < 1e-12 else float(np.clip(-c / a, 0, 1))
        t = 0.0 if e < 1e-12 else float(np.clip(f / e, 0, 1))
        return float(np.linalg.norm(p1 + d1 * s - (p2 + d2 * t)))
    den = a * e - b * b
    s = float(np.clip((b * f - c * e) / den, 0, 1)) if den > 1e-12 else 0.0
    t = (b * s + f) / e
    if t < 0:
        t, s = 0.0, float(np.clip(-c / a, 0, 1))
    elif t > 1:
        t, s = 1.0, float(np.clip((b - c) / a, 0, 1))
    return float(np.linalg.norm(p1 + d1 * s - (p2 + d2 * t)))


def axis_segment(c):
    """A capsule's (or sphere's: a point's) segment and radius."""
    p = np.array(c["position"])
    if c["kind"] == "sphere":
        return (p, p), c["radius"]
    half = rot(c["orientation"]) @ np.array([0, 0, c["height"] / 2])
    return (p - half, p + half), c["radius"]


def exact(a, b):
    """The distance between a and b from their geometry, or None where that is not simple."""
    if a["kind"] == "box" and b["kind"] == "box":
        d = min([point_box(v, b) for v in corners(a)] + [point_box(v, a) for v in corners(b)]
                + [seg_seg(*e, *f) for e in box_edges(a) for f in box_edges(b)])
        return d if d > 0 else None
    if b["kind"] == "box":
        a, b = b, a
    if a["kind"] == "box":
        (p, q), r = axis_segment(b)
        if b["kind"] == "sphere":
            return point_box(p, a) - r
        d = min([point_box(p, a), point_box(q, a)] + [seg_seg(p, q, *e) for e in box_edges(a)])
        return d - r if d > 0 else None
    (p1, q1), r1 = axis_segment(a)
    (p2, q2), r2 = axis_segment(b)
    return seg_seg(p1, q1, p2, q2) - r1 - r2


def smallest(points):
    best = min(points, key=lambda c: c[8])
    return {"contact_distance": best[8], "contact_normal_on_b": list(best[7]),
            "position_on_a": list(best[5]), "position_on_b": list(best[6])}


def primitives(rng):
    kinds = ["box", "sphere", "capsule"]
    cases = []
    for ka in kinds:
        for kb in kinds:
            for _ in range(3):
                a, b = shape(rng, ka), shape(rng, kb)
                pa, qa = [rng.uniform(-0.2, 0.2) for _ in range(3)], unit_quat(rng)
                pb, qb = [rng.uniform(-0.6, 0.6) for _ in range(3)], unit_quat(rng)
                ia, ib = body(a, pa, qa), body(b, pb, qb)
                pts = p.getClosestPoints(ia, ib, RANGE)
                case = {"a": dict(a, position=pa, orientation=qa), "b": dict(b, position=pb, orientation=qb)}
                case.update(smallest(pts) if pts else {"contact_distance": None})
                case["exact"] = exact(case["a"], case["b"])
                cases.append(case)
                p.removeBody(ia)
                p.removeBody(ib)
    return cases


def robot():
    arm = p.loadURDF(os.path.join(pybullet_data.getDataPath(), "kuka_iiwa/model.urdf"), [0, 0, 0],
                     [0, 0, 0, 1], useFixedBase=True)
    for j, q in enumerate(POSE):
        p.resetJointState(arm, j, q)
    ball = body({"kind": "sphere", "radius": BALL["radius"]}, BALL["position"], [0, 0, 0, 1])
    links = []
    for link in range(-1, p.getNumJoints(arm)):
        pts = p.getClosestPoints(arm, ball, RANGE, linkIndexA=link)
        links.append({"link_index": link, **(smallest(pts) if pts else {"contact_distance": None})})
    return {"robot": "kuka_iiwa/model.urdf", "positions": POSE, "sphere": BALL, "links": links}


p.connect(p.DIRECT)
rng = random.Random(44)
out = {"pybullet": "3.2.7", "distance": RANGE, "primitives": primitives(rng), "robot": robot()}
with open(OUT, "w") as f:
    json.dump(out, f, indent=1)
    f.write("\n")
print("wrote", OUT)
