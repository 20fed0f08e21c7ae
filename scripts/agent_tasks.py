#!/usr/bin/env python3
"""What an agent spends on realistic tasks: calls and reply text, against the budget targets below.

    python scripts/agent_tasks.py URL [--report] [--enforce-targets] [--calls]

URL is a running physics-mcp's `/mcp` endpoint whose workspace holds a copy of tests/fixtures
at `tests/fixtures/` (scripts/agent_tasks.sh starts such a server and runs this script).

The script is an agent: the Python `mcp` SDK's `Client` (streamable HTTP, the SDK's default
mode) and `call_tool`, nothing else. It runs fifteen tasks; the first ten written as a sensible agent calls
today's tools — the server's default arguments only (no detail switches; no `output_path`, no
`observe`, no `every`), one call per thing the agent wants to know, and the agent's own Python
for whatever the tools do not compute (how many boxes moved, when a box landed). The tasks
are the issue's: (1) a five-box tower knocked over by a thrown ball and looked back at
(the throw's result names the interval, get_trajectory of it); (2) a 100-box pile built in one
batch, stepped, and checked settled; (3) a sweep over four throwing speeds with run_sweep,
counting the boxes moved at each; (4) the KUKA iiwa14 (fixed base) moved to a target with
calculate_inverse_kinematics and set_joint_motor_control_array; (5) the wheeled base
driven forward by velocity motors on its wheels; (6) one undo, one fork, one get_history and
one verify_simulation on a small scene; (7) a pick-style reach to a target where the agent
also placed a marker sphere (`collides: false`: the arm passes through it);
(8) Gymnasium's MJCF reacher driven by per-joint motors; (9) boxes dropped from three heights,
and the moment the first one hit the ground found with get_trajectory; (10) the iiwa14 moved
through five poses in one call (calculate_inverse_kinematics ×5, set_joint_trajectory,
step_simulation) and where its gripper ended.

What is counted, per call (a refused call is counted the same way):
  * one call = one `tools/call` (a `batch` or `run_sweep` is one call, whatever it holds);
  * reply bytes = what a model reads of the CallToolResult: the UTF-8 bytes of every text
    content block (for this server: the compact-JSON text copy of `structuredContent`, or,
    when that is over 64 KB, the server's short summary of it; a refusal's sentence), plus
    every image or audio content block counted by the length of its base64 `data`, plus the
    text (or base64 blob) of any embedded resource. `structuredContent` itself is not added
    again (a host gives a model one copy, not both) but is measured beside it (compact JSON,
    UTF-8) and shown with `--calls`; a reply whose text copy was a summary is counted as
    "summarised" on its task's line, because there the text undercounts what the data costs;
  * the largest reply = the largest reply bytes of one call;
  * KB = 1000 bytes.
Counts of calls and bytes are deterministic: fixed positions and seeds, fixed step counts, no
call whose presence or size depends on wall time, and the number of calls never depends on an
outcome (a failed outcome check is recorded, the task goes on).

Tasks (11)-(15) are the answer tasks, written as an agent that asks for answers
(`measure`, run_sweep's `rank_by` a measure and `varied`) rather than series: a ball bouncing
on a box (when it hit, how high it bounced: free fall and e²), the KUKA reaching a point
(lower-case control mode), ten dominoes pushed over then undone and pushed half as hard (did
each fall, when), a box on a 20° ramp swept over five frictions (slides exactly below tan 20°),
and MuJoCo's ant standing (upright, torso off the floor, settled). Their targets together: at
most 30 calls, 60 KB of reply text, and no single reply over 16 KB.

The budget targets are checked on "the five tasks" — tower look-back (1), 100-box
pile (2), sweep (3), robots (4 and 5: KUKA and the wheeled base), timeline ops (6) — together:
no worse than they were before the answer tasks' changes — at most 38 calls and 61,641 B of
reply text (the first targets were 40 calls and 120 KB) — and no single default reply over
32 KB, checked over every task. Each target prints PASS or FAIL.

Exit status: 0 with `--report` (measurement only, whatever failed); otherwise 1 when any
task's physical outcome is wrong (or a call was refused), and, with `--enforce-targets`, when
a budget target fails too. `--calls` also prints one line per call.
"""

import argparse
import asyncio
import json
import math
import random
import sys

from mcp import Client

STEP_TIMEOUT_S = 600  # a debug build steps the 100-box pile slowly
KB = 1000
# The five tasks: no worse than they were before the answer tasks' changes (docs/benchmarks.md
# "An agent's budget": 38 calls, 61,641 B; the first targets were 40 calls and 120 KB).
TARGET_CALLS = 38
TARGET_BYTES = 61_641
TARGET_LARGEST = 32 * KB
# The answer tasks (11-15) together: calls, reply text, and no single reply over this.
ANSWER_CALLS = 30
ANSWER_BYTES = 60 * KB
ANSWER_LARGEST = 16 * KB
SUMMARY_OVER = 64 * 1024  # the server's text copy is a summary above this (docs/tools.md)

IIWA = "tests/fixtures/iiwa14.urdf"
WHEELED = "tests/fixtures/wheeled_base.urdf"
REACHER = "tests/fixtures/mjcf/reacher.xml"


class Refused(Exception):
    """A tool call the agent needed was refused: the task cannot go on."""


def reply_bytes(result):
    """The bytes of one CallToolResult a model reads (see the module doc)."""
    n = 0
    for block in result.content:
        kind = getattr(block, "type", None)
        if kind == "text":
            n += len(block.text.encode("utf-8"))
        elif kind in ("image", "audio"):
            n += len(block.data)
        elif kind == "resource":
            res = block.resource
            n += len((getattr(res, "text", None) or getattr(res, "blob", None) or "").encode("utf-8"))
        else:  # a resource link: what a model reads of it is its JSON
            n += len(block.model_dump_json(by_alias=True, exclude_none=True).encode("utf-8"))
    return n


def json_bytes(value):
    if value is None:
        return 0
    return len(json.dumps(value, separators=(",", ":"), ensure_ascii=False).encode("utf-8"))


class Task:
    """One task's meter: every call it makes, and its outcome checks."""

    def __init__(self, client, number, name, show_calls):
        self.client = client
        self.number = number
        self.name = name
        self.show_calls = show_calls
        self.calls = []  # (tool, reply bytes, structured bytes, summarised)
        self.failures = []
        self.notes = []

    async def call(self, tool, args):
        result = await self.client.call_tool(tool, args, read_timeout_seconds=STEP_TIMEOUT_S)
        text = reply_bytes(result)
        structured = json_bytes(result.structured_content)
        summarised = structured > SUMMARY_OVER and text < structured
        self.calls.append((tool, text, structured, summarised))
        if self.show_calls:
            flag = "  (text is a summary)" if summarised else ""
            print(f"    {self.name}: {tool:<30} {text:>9,} B  structured {structured:>9,} B{flag}")
        if result.is_error:
            words = " ".join(getattr(b, "text", "") for b in result.content)
            raise Refused(f"{tool} was refused: {words}")
        return result.structured_content

    def check(self, cond, what):
        """An outcome check: recorded, never stops the task (so the calls stay the same)."""
        if not cond:
            self.failures.append(what)

    def note(self, what):
        self.notes.append(what)

    @property
    def n_calls(self):
        return len(self.calls)

    @property
    def total(self):
        return sum(c[1] for c in self.calls)

    @property
    def largest(self):
        return max(self.calls, key=lambda c: c[1]) if self.calls else ("-", 0, 0, False)

    @property
    def summarised(self):
        return sum(1 for c in self.calls if c[3])

    @property
    def ok(self):
        return not self.failures


def dist(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)))


def ids(created):
    return created["object_id"]


# ----------------------------------------------------------------------------------------
# The tasks. Each builds its own simulation and says in its checks what "right" means.

TOWER_BOXES = 5
BOX_HALF = 0.1
BALL_START = [-1.5, 0, 0.6]
THROW = [7, 0, 1.5]  # m/s; it meets the tower's third box
FOUND = {}  # what one task found that a later one checks against


async def tower_lookback(t):
    """Five stacked boxes, a ball thrown at them; then look back at the throw."""
    sim = (await t.call("create_simulation", {}))["simulation_id"]
    await t.call("load_urdf", {"sim_id": sim, "file_path": "plane.urdf"})
    boxes = []
    for k in range(TOWER_BOXES):
        z = BOX_HALF + 2 * BOX_HALF * k
        r = await t.call("add_box", {"sim_id": sim, "dimensions": [BOX_HALF] * 3, "position": [0, 0, z], "mass": 1})
        boxes.append(ids(r))
    ball = ids(await t.call("add_sphere", {"sim_id": sim, "radius": 0.1, "position": BALL_START, "mass": 2}))
    throw = await t.call("set_object_velocity", {"sim_id": sim, "object_id": ball, "linear_velocity": THROW})
    await t.call("step_simulation", {"sim_id": sim, "steps": 480})

    # Look back from the throw: its result says where it landed (head_seq).
    t.check("head_seq" in throw, "set_object_velocity does not say its seq")
    since = {"from_seq": throw["head_seq"]} if "head_seq" in throw else {}
    traj = await t.call("get_trajectory", {"sim_id": sim, **since})

    by_id = {o["object_id"]: o for o in traj["objects"]}
    moved = 0
    for b in boxes:
        if b not in by_id:  # listed in traj["unmoved"]: it did not move
            continue
        p = by_id[b]["positions"]
        if dist(p[0], p[-1]) > 0.05:
            moved += 1
    top = by_id[boxes[-1]]["positions"]
    drop = top[0][2] - top[-1][2]
    t.note(f"{moved} of {TOWER_BOXES} boxes moved; the top box fell {drop:.2f} m; {traj['samples']} samples")
    FOUND["tower moved"] = moved
    t.check(moved >= 3, f"only {moved} boxes moved")
    t.check(drop > 0.3, f"the top box fell only {drop:.2f} m: the tower was not knocked over")


PILE = 100


async def box_pile(t):
    """A 100-box pile built in one batch, stepped 3 s, checked settled (all at rest, above ground)."""
    sim = (await t.call("create_simulation", {}))["simulation_id"]
    rng = random.Random(24)
    calls = [{"tool": "load_urdf", "arguments": {"file_path": "plane.urdf"}}]
    for i in range(PILE):
        layer, cell = divmod(i, 25)
        row, col = divmod(cell, 5)
        shift = 0.1 if layer % 2 else 0.0  # odd layers sit across the gaps: a pile, not columns
        pos = [
            (col - 2) * 0.25 + shift + rng.uniform(-0.02, 0.02),
            (row - 2) * 0.25 + shift + rng.uniform(-0.02, 0.02),
            0.15 + 0.25 * layer,
        ]
        calls.append({"tool": "add_box", "arguments": {"dimensions": [BOX_HALF] * 3, "position": pos, "mass": 1}})
    built = await t.call("batch", {"sim_id": sim, "calls": calls})
    box_ids = [r["object_id"] for r in built["results"][1:]]
    t.check(len(box_ids) == PILE, f"the batch made {len(box_ids)} boxes")
    await t.call("step_simulation", {"sim_id": sim, "steps": 720})

    reads = [{"tool": "get_object_state", "arguments": {"object_id": b}} for b in box_ids]
    states = (await t.call("batch", {"sim_id": sim, "calls": reads}))["results"]
    speeds = [math.sqrt(sum(v * v for v in s["linear_velocity"])) for s in states]
    lowest = min(s["position"][2] for s in states)
    t.note(f"fastest box {max(speeds):.4f} m/s, lowest centre z {lowest:.3f} m")
    t.check(max(speeds) < 0.05, f"not settled: a box still moves at {max(speeds):.3f} m/s")
    t.check(lowest > BOX_HALF - 0.01, f"a box sank to z {lowest:.3f} (below the ground)")


SPEEDS = [1.0, 3.0, 5.0, 7.0]  # 7 m/s is task 1's throw


async def speed_sweep(t):
    """The tower and ball again, thrown at four speeds in one run_sweep; boxes moved per speed."""
    sim = (await t.call("create_simulation", {}))["simulation_id"]
    placed = {}
    calls = [{"tool": "load_urdf", "arguments": {"file_path": "plane.urdf"}}]
    for k in range(TOWER_BOXES):
        calls.append({"tool": "add_box", "arguments": {"dimensions": [BOX_HALF] * 3, "position": [0, 0, BOX_HALF + 2 * BOX_HALF * k], "mass": 1}})
    calls.append({"tool": "add_sphere", "arguments": {"radius": 0.1, "position": BALL_START, "mass": 2}})
    built = (await t.call("batch", {"sim_id": sim, "calls": calls}))["results"]
    for k, r in enumerate(built[1 : 1 + TOWER_BOXES]):
        placed[r["object_id"]] = [0, 0, BOX_HALF + 2 * BOX_HALF * k]
    ball = built[-1]["object_id"]

    variants = [
        [{"tool": "set_object_velocity", "arguments": {"object_id": ball, "linear_velocity": [v, 0, THROW[2]]}}]
        for v in SPEEDS
    ]
    sweep = await t.call("run_sweep", {"sim_id": sim, "variants": variants, "steps": 480})
    counts = []
    for variant in sorted(sweep["variants"], key=lambda v: v["index"]):
        final = {o["object_id"]: o["position"] for o in variant["objects"]}
        counts.append(sum(1 for b, p in placed.items() if dist(p, final[b]) > 0.05))
    t.note("boxes moved per speed: " + ", ".join(f"{v:g} m/s → {c}" for v, c in zip(SPEEDS, counts)))
    t.check(len(counts) == len(SPEEDS), f"{len(counts)} variants answered, not {len(SPEEDS)}")
    t.check(counts[0] == 0, f"a {SPEEDS[0]:g} m/s throw, which falls short, moved {counts[0]} boxes")
    t.check(max(counts) >= 3, f"no throw moved 3 or more boxes: {counts}")
    # A variant is the same scene thrown the same way as task 1 did by hand: the same boxes move.
    if "tower moved" in FOUND:
        by_hand = FOUND["tower moved"]
        t.check(counts[-1] == by_hand, f"the {SPEEDS[-1]:g} m/s variant moved {counts[-1]} boxes; by hand (task 1) {by_hand}")


IIWA_EE = 7  # iiwa_link_ee: the child of the fixed joint iiwa_joint_ee (the URDF's last joint)
IIWA_MOVABLE = 7  # joints 0-6 are revolute, in PyBullet order
REACH_TARGET = [0.5, 0.2, 0.6]


async def reach(t, sim, arm, target):
    """IK, the position motors of every joint in one call, 3 s, and where the end effector ended."""
    ik = await t.call(
        "calculate_inverse_kinematics",
        {"sim_id": sim, "object_id": arm, "end_effector_link_index": IIWA_EE, "target_position": target},
    )
    qs = ik["joint_positions"][:IIWA_MOVABLE]
    await t.call(
        "set_joint_motor_control_array",
        {"sim_id": sim, "object_id": arm, "joint_indices": list(range(len(qs))), "control_mode": "POSITION_CONTROL", "target_positions": qs},
    )
    await t.call("step_simulation", {"sim_id": sim, "steps": 720})
    link = await t.call("get_link_state", {"sim_id": sim, "object_id": arm, "link_index": IIWA_EE})
    return ik, link["link_world_position"]


async def kuka_reach(t):
    """The KUKA iiwa14, fixed base: end effector to a target within 1 cm."""
    sim = (await t.call("create_simulation", {}))["simulation_id"]
    arm = ids(await t.call("load_urdf", {"sim_id": sim, "file_path": IIWA, "use_fixed_base": True}))
    ik, ee = await reach(t, sim, arm, REACH_TARGET)
    miss = dist(ee, REACH_TARGET)
    t.note(f"IK position_error {ik['position_error']:.2e} m; the end effector ended {miss * 100:.2f} cm from the target")
    t.check(miss <= 0.01, f"the end effector ended {miss * 100:.2f} cm from the target (> 1 cm)")


async def wheeled_drive(t):
    """The wheeled base driven forward (+x) by velocity motors on both wheels for 2 s."""
    sim = (await t.call("create_simulation", {}))["simulation_id"]
    await t.call("load_urdf", {"sim_id": sim, "file_path": "plane.urdf"})
    start = [0, 0, 0.16]  # wheels (radius 0.1, 0.05 below the chassis) and caster touch z = 0
    robot = ids(await t.call("load_urdf", {"sim_id": sim, "file_path": WHEELED, "position": start}))
    # left_wheel_joint, right_wheel_joint (the URDF's header lists them)
    await t.call(
        "set_joint_motor_control_array",
        {"sim_id": sim, "object_id": robot, "joint_indices": [0, 1], "control_mode": "VELOCITY_CONTROL", "target_velocities": [5, 5]},
    )
    await t.call("step_simulation", {"sim_id": sim, "steps": 480})
    pos = (await t.call("get_object_state", {"sim_id": sim, "object_id": robot}))["position"]
    dx, dy = pos[0] - start[0], pos[1] - start[1]
    t.note(f"moved {dx:.3f} m forward, {dy:.3f} m sideways (wheels 5 rad/s × 0.1 m for 2 s: at most 1 m)")
    t.check(dx > 0.5, f"moved only {dx:.3f} m forward")
    t.check(abs(dy) < 0.1, f"drifted {dy:.3f} m sideways")


async def timeline_ops(t):
    """A sphere dropped on the ground: undo the drop, fork there, read the history, verify."""
    sim = (await t.call("create_simulation", {}))["simulation_id"]
    await t.call("load_urdf", {"sim_id": sim, "file_path": "plane.urdf"})
    await t.call("add_sphere", {"sim_id": sim, "radius": 0.1, "position": [0, 0, 1]})
    await t.call("step_simulation", {"sim_id": sim, "steps": 240})
    undone = await t.call("undo", {"sim_id": sim})
    fork = await t.call("fork_simulation", {"sim_id": sim})
    history = await t.call("get_history", {"sim_id": sim})
    verified = await t.call("verify_simulation", {"sim_id": sim})
    kinds = [e["kind"] for e in history["events"]]
    t.note(f"undo back to t = {undone['current_time']}; history {len(kinds)} events; verify checked {verified['events_checked']}")
    t.check(undone["current_time"] == 0, f"undo left time at {undone['current_time']}")
    t.check([u["tool"] for u in undone["undone"]] == ["step_simulation"], f"undo took back {undone['undone']}")
    t.check(fork["state_hash"] == undone["state_hash"], "the fork's state differs from the head it was taken at")
    t.check("move" in kinds, "get_history does not show the undo")
    t.check(verified["ok"] is True, f"verify_simulation: {verified}")


PICK_TARGET = [0.55, 0.0, 0.35]


async def pick_reach(t):
    """A reach to where the agent placed a marker (a static sphere touching nothing): 1 cm, honestly."""
    sim = (await t.call("create_simulation", {}))["simulation_id"]
    arm = ids(await t.call("load_urdf", {"sim_id": sim, "file_path": IIWA, "use_fixed_base": True}))
    marker = ids(await t.call("add_sphere", {"sim_id": sim, "radius": 0.02, "position": PICK_TARGET, "mass": 0, "color": [1, 0, 0, 1], "collides": False}))
    ik, ee = await reach(t, sim, arm, PICK_TARGET)
    contacts = (await t.call("get_collisions_for_pair", {"sim_id": sim, "obj_a": arm, "obj_b": marker}))["contacts"]
    miss = dist(ee, PICK_TARGET)
    force = sum(c["normal_force"] for c in contacts)
    t.note(
        f"IK position_error {ik['position_error']:.2e} m; the end effector ended {miss * 100:.2f} cm from the target; "
        f"{len(contacts)} arm-marker contacts, {force:.1f} N in all"
    )
    t.check(miss <= 0.01, f"the end effector ended {miss * 100:.2f} cm from the marked target (> 1 cm); {len(contacts)} contacts with the marker, {force:.0f} N")


REACHER_TARGETS = {0: 1.0, 1: -1.0}  # joint0 (unlimited hinge), joint1 (range ±3 rad)


async def mjcf_reacher(t):
    """Gymnasium's reacher (MJCF) driven by one position motor per arm joint for 2 s."""
    sim = (await t.call("create_simulation", {}))["simulation_id"]
    robot = ids(await t.call("load_mjcf", {"sim_id": sim, "file_path": REACHER}))
    await t.call(
        "set_joint_motor_control_array",
        {"sim_id": sim, "object_id": robot, "joint_indices": list(REACHER_TARGETS), "control_mode": "POSITION_CONTROL", "target_positions": list(REACHER_TARGETS.values())},
    )
    await t.call("step_simulation", {"sim_id": sim, "steps": 480})
    reached = []
    for j, q in REACHER_TARGETS.items():
        s = await t.call("get_joint_state", {"sim_id": sim, "object_id": robot, "joint_index": j})
        reached.append((j, q, s["joint_position"]))
    t.note("; ".join(f"joint {j} at {p:.4f} rad (target {q:g}, from 0)" for j, q, p in reached))
    for j, q, p in reached:
        t.check(abs(p - q) < 0.1 * abs(q), f"joint {j} at {p:.4f} rad did not come within 10 % of its target {q}")


DROP_HEIGHTS = [1.0, 2.0, 3.0]  # box centres; box 0 lands first


async def first_landing(t):
    """Boxes dropped from three heights; the seq and time when the first one hit the ground."""
    sim = (await t.call("create_simulation", {}))["simulation_id"]
    await t.call("load_urdf", {"sim_id": sim, "file_path": "plane.urdf"})
    boxes = []
    for i, z in enumerate(DROP_HEIGHTS):
        r = await t.call("add_box", {"sim_id": sim, "dimensions": [BOX_HALF] * 3, "position": [i * 1.0, 0, z], "mass": 1})
        boxes.append(ids(r))
    await t.call("step_simulation", {"sim_id": sim, "steps": 480})
    traj = await t.call("get_trajectory", {"sim_id": sim})  # default interval: what the last step did

    lowest = next(o for o in traj["objects"] if o["object_id"] == boxes[0])
    zs = [p[2] for p in lowest["positions"]]
    rest = zs[-1]
    k = next(i for i, z in enumerate(zs) if z <= rest + 0.002)
    seq, time, step = traj["seqs"][k], traj["times"][k], traj["steps"][k]
    fall = math.sqrt(2 * (DROP_HEIGHTS[0] - BOX_HALF) / 9.81)
    resolution = (traj["times"][1] - traj["times"][0]) if len(traj["times"]) > 1 else 0
    t.note(
        f"first landing: seq {seq}, step {step}, t = {time:.4f} s (free fall {fall:.4f} s; samples every "
        f"{resolution * 1000:.1f} ms); rest z {rest:.4f}"
    )
    t.check(abs(time - fall) <= resolution + 0.02, f"found the landing at {time:.4f} s; free fall takes {fall:.4f} s")


FIVE_POSES = [[0.5, 0.0, 0.6], [0.4, 0.3, 0.7], [0.2, 0.4, 0.9], [0.3, -0.3, 0.8], [0.5, -0.1, 0.5]]
POSE_TIMES = [0.6, 1.2, 1.8, 2.4, 3.0]


async def five_poses(t):
    """The KUKA iiwa14 moved through five IK poses in 3 s with one set_joint_trajectory; where the gripper ends."""
    sim = (await t.call("create_simulation", {}))["simulation_id"]
    arm = ids(await t.call("load_urdf", {"sim_id": sim, "file_path": IIWA, "use_fixed_base": True}))
    poses, rest = [], None
    for target in FIVE_POSES:
        args = {"sim_id": sim, "object_id": arm, "end_effector_link_index": IIWA_EE, "target_position": target}
        if rest is not None:
            args["rest_poses"] = rest
        rest = (await t.call("calculate_inverse_kinematics", args))["joint_positions"][:IIWA_MOVABLE]
        poses.append(rest)
    await t.call(
        "set_joint_trajectory",
        {"sim_id": sim, "object_id": arm, "joint_indices": list(range(IIWA_MOVABLE)), "times": POSE_TIMES, "positions": poses,
         "position_gains": [0.3] * IIWA_MOVABLE},
    )
    await t.call("step_simulation", {"sim_id": sim, "steps": 960})
    link = await t.call("get_link_state", {"sim_id": sim, "object_id": arm, "link_index": IIWA_EE})
    miss = dist(link["link_world_position"], FIVE_POSES[-1])
    t.note(f"the gripper ended {miss * 100:.2f} cm from the last pose's target, 1 s after the trajectory's 3 s")
    t.check(miss <= 0.01, f"the gripper ended {miss * 100:.2f} cm from the last target (> 1 cm)")


# ----------------------------------------------------------------------------------------
# The answer tasks: an agent asks for answers (`measure`), not series. Each
# physics answer is checked against analytic physics or a plain physical bound.

G = 9.81
DT = 1.0 / 240.0


def answers(result):
    """`measures` of a reply as (value, time) pairs, in the order asked."""
    return [(m.get("value"), m.get("time")) for m in (result or {}).get("measures", [])]


async def bounce(t):
    """A ball (restitution 0.9) dropped on a box (restitution 1): when it hits, how high it bounces."""
    sim = (await t.call("create_simulation", {}))["simulation_id"]
    built = (await t.call("batch", {"sim_id": sim, "calls": [
        {"tool": "add_box", "arguments": {"dimensions": [0.25, 0.25, 0.25], "position": [0, 0, 0.25], "mass": 0}},
        {"tool": "add_sphere", "arguments": {"radius": 0.1, "position": [0, 0, 1.5]}},
    ]}))["results"]
    box, ball = built[0]["object_id"], built[1]["object_id"]
    await t.call("batch", {"sim_id": sim, "calls": [
        {"tool": "change_dynamics", "arguments": {"object_id": box, "restitution": 1.0}},
        {"tool": "change_dynamics", "arguments": {"object_id": ball, "restitution": 0.9, "linear_damping": 0}},
    ]})
    hit = answers(await t.call("step_simulation", {"sim_id": sim, "steps": 120, "measure": [{"pair": [ball, box], "what": "first_contact"}]}))
    up = answers(await t.call("step_simulation", {"sim_id": sim, "steps": 120, "measure": [{"object_id": ball, "what": "peak_height"}]}))
    fall = math.sqrt(2 * 0.9 / G)  # its bottom from 1.4 m to the box's top at 0.5 m
    when, peak = hit[0][1], up[0][0]
    rebound = 0.6 + 0.9 ** 2 * 0.9  # centre height: e² of the drop above where it touched
    t.note(f"hit the box at {when} s (free fall {fall:.4f} s); bounced to {peak} m (e² × drop: {rebound:.3f} m)")
    t.check(when is not None and abs(when - fall) <= 3 * DT, f"hit at {when} s; free fall says {fall:.4f} s")
    t.check(peak is not None and abs(peak - rebound) <= 0.1 * (rebound - 0.6), f"bounced to {peak} m; e = 0.9 says {rebound:.3f} m")


BOUNCE_REACH = [0.4, -0.3, 0.5]


async def reach_point(t):
    """The KUKA iiwa14 (fixed base) to a point: IK, position motors (lower-case mode), where the end effector is."""
    sim = (await t.call("create_simulation", {}))["simulation_id"]
    arm = ids(await t.call("load_urdf", {"sim_id": sim, "file_path": IIWA, "use_fixed_base": True}))
    ik = await t.call("calculate_inverse_kinematics", {"sim_id": sim, "object_id": arm, "end_effector_link_index": IIWA_EE, "target_position": BOUNCE_REACH})
    qs = ik["joint_positions"][:IIWA_MOVABLE]
    await t.call("set_joint_motor_control_array", {"sim_id": sim, "object_id": arm, "joint_indices": list(range(len(qs))), "control_mode": "position", "target_positions": qs})
    await t.call("step_simulation", {"sim_id": sim, "steps": 720})
    ee = (await t.call("get_link_state", {"sim_id": sim, "object_id": arm, "link_index": IIWA_EE}))["link_world_position"]
    miss = dist(ee, BOUNCE_REACH)
    t.note(f"the end effector is {miss * 100:.2f} cm from the target")
    t.check(miss <= 0.01, f"the end effector ended {miss * 100:.2f} cm from the target (> 1 cm)")


DOMINOES = 10
DOMINO_HALF = [0.02, 0.1, 0.2]
DOMINO_GAP = 0.25
PUSH = 3.0  # rad/s about y: the first domino tips towards the others


async def dominoes(t):
    """Ten dominoes pushed over; did every one fall, and when? Then undo, push half as hard, ask again."""
    sim = (await t.call("create_simulation", {}))["simulation_id"]
    calls = [{"tool": "load_urdf", "arguments": {"file_path": "plane.urdf"}}]
    calls += [{"tool": "add_box", "arguments": {"dimensions": DOMINO_HALF, "position": [i * DOMINO_GAP, 0, DOMINO_HALF[2]], "mass": 0.2}} for i in range(DOMINOES)]
    made = [r["object_id"] for r in (await t.call("batch", {"sim_id": sim, "calls": calls}))["results"][1:]]
    fell = [{"object_id": d, "what": "first", "when": {"tilt_above": 45}} for d in made]

    async def push(speed):
        await t.call("set_object_velocity", {"sim_id": sim, "object_id": made[0], "angular_velocity": [0, speed, 0]})
        return [tm for _, tm in answers(await t.call("step_simulation", {"sim_id": sim, "steps": 720, "measure": fell}))]

    full = await push(PUSH)
    await t.call("undo", {"sim_id": sim, "count": 2})
    half = await push(PUSH / 2)
    fallen = [tm for tm in full if tm is not None]
    half_fallen = [tm for tm in half if tm is not None]
    t.note(f"full push: {len(fallen)} of {DOMINOES} fell, the last at {fallen[-1] if fallen else None} s; half push: {len(half_fallen)} fell")
    t.check(len(fallen) == DOMINOES, f"only {len(fallen)} of {DOMINOES} dominoes fell")
    t.check(fallen == sorted(fallen), f"they did not fall in order: {full}")
    t.check(len(half_fallen) < DOMINOES or all(h > f for h, f in zip(half, full)), f"half the push felled them as fast: {half} vs {full}")


RAMP_DEG = 20.0
FRICTIONS = [0.1, 0.2, 0.3, 0.5, 0.7]  # tan 20° = 0.364: the first three slide


async def ramp_sweep(t):
    """A box on a 20° ramp, five frictions in one run_sweep ranked by how far it slid: where does it stop sliding?"""
    sim = (await t.call("create_simulation", {}))["simulation_id"]
    a = math.radians(RAMP_DEG)
    q = [0, math.sin(-a / 2), 0, math.cos(-a / 2)]  # about -y: the ramp falls towards +x
    normal = [math.sin(a), 0, math.cos(a)]
    centre = [0, 0, 1.0]
    on_ramp = [centre[k] + normal[k] * (0.05 + 0.1 + 0.001) for k in range(3)]
    built = (await t.call("batch", {"sim_id": sim, "calls": [
        {"tool": "add_box", "arguments": {"dimensions": [2.0, 0.5, 0.05], "position": centre, "orientation": q, "mass": 0}},
        {"tool": "add_box", "arguments": {"dimensions": [0.1, 0.1, 0.1], "position": on_ramp, "orientation": q}},
    ]}))["results"]
    ramp, box = built[0]["object_id"], built[1]["object_id"]
    await t.call("change_dynamics", {"sim_id": sim, "object_id": ramp, "lateral_friction": 1.0})
    variants = [[{"tool": "change_dynamics", "arguments": {"object_id": box, "lateral_friction": mu}}] for mu in FRICTIONS]
    sweep = await t.call("run_sweep", {"sim_id": sim, "variants": variants, "steps": 240,
                                       "observe": {"object_ids": [box], "measure": [{"object_id": box, "what": "travel"}]}, "rank_by": {"measure": 0}})
    slid = {v["varied"]["change_dynamics.lateral_friction"]: v["measures"][0]["value"] for v in sweep["variants"]}
    stays = min((mu for mu, d in slid.items() if d < 0.05), default=None)
    t.note(f"slid (m) by friction: {slid}; it stays from mu = {stays} (tan 20° = {math.tan(a):.3f})")
    t.check(all((d > 0.05) == (mu < math.tan(a)) for mu, d in slid.items()), f"slides where mu < tan 20°, stays where above: {slid}")
    # Sliding for 1 s: ½ g (sin θ − μ cos θ) t², within 5 cm (the landing on the ramp adds ~3 cm).
    for mu, d in slid.items():
        if mu < math.tan(a):
            want = 0.5 * G * (math.sin(a) - mu * math.cos(a))
            t.check(abs(d - want) <= 0.05, f"mu = {mu}: slid {d} m in 1 s; ½ g (sin θ − μ cos θ) t² = {want:.3f} m")
    t.check(sweep["ranking"][0] == 0, f"the slipperiest box did not slide furthest: ranking {sweep['ranking']}")


async def ant_stands(t):
    """MuJoCo's ant on its legs (released 0.75 m up, as the model places it): upright, torso off the floor, settled?"""
    sim = (await t.call("create_simulation", {}))["simulation_id"]
    ant = ids(await t.call("load_mjcf", {"sim_id": sim, "file_path": "mujoco/ant.xml"}))  # torso 0.75 m above its floor
    got = answers(await t.call("step_simulation", {"sim_id": sim, "steps": 720, "measure": [
        {"object_id": ant, "what": "final_tilt"},
        {"object_id": ant, "what": "lowest_height"},
        {"object_id": ant, "what": "settled", "when": {"speed_below": 0.01}},
    ]}))
    (tilt, _), (low, _), (_, settled) = got
    t.note(f"final tilt {tilt}°, torso never below {low} m, settled at {settled} s")
    t.check(tilt is not None and tilt < 20, f"it ended tilted {tilt}°")
    t.check(low is not None and low > 0.2, f"its torso came down to {low} m (on the floor)")
    t.check(settled is not None and settled > 0, f"it did not come to rest after landing (settled at {settled} s)")


TASKS = [
    (1, "tower look-back", tower_lookback),
    (2, "100-box pile (batch)", box_pile),
    (3, "4-speed sweep", speed_sweep),
    (4, "KUKA reach (IK)", kuka_reach),
    (5, "wheeled base drive", wheeled_drive),
    (6, "undo/fork/history/verify", timeline_ops),
    (7, "pick reach + marker", pick_reach),
    (8, "MJCF reacher motors", mjcf_reacher),
    (9, "first box to land", first_landing),
    (10, "arm through five poses", five_poses),
    (11, "ball bounce (measures)", bounce),
    (12, "KUKA reach a point", reach_point),
    (13, "dominoes + undo", dominoes),
    (14, "ramp friction sweep", ramp_sweep),
    (15, "MuJoCo ant stands", ant_stands),
]
THE_ANSWERS = {11, 12, 13, 14, 15}  # the answer tasks: bounce, reach, dominoes, ramp sweep, ant
THE_FIVE = {1, 2, 3, 4, 5, 6}  # tower, pile, sweep, robots (4 and 5 together), timeline ops


async def run(url, show_calls):
    done = []
    async with Client(url) as client:
        for number, name, task in TASKS:
            t = Task(client, number, name, show_calls)
            try:
                await task(t)
            except Refused as e:
                t.failures.append(str(e))
            done.append(t)
    return done


def totals(tasks):
    """(calls, reply bytes, (largest reply, its tool, its task)) of some tasks together."""
    biggest = max(((t.largest[1], t.largest[0], t.name) for t in tasks), default=(0, "-", "-"))
    return sum(t.n_calls for t in tasks), sum(t.total for t in tasks), biggest


def budget_targets(who, measured, limits, largest_what):
    """The three budget targets (calls, reply text, largest reply) of a group: (what, met, figure)."""
    (calls, total, biggest), (max_calls, max_bytes, max_largest) = measured, limits
    return [
        (f"{who} in <= {max_calls} calls", calls <= max_calls, f"{calls} calls"),
        (f"{who} in <= {f'{max_bytes // KB} KB' if max_bytes % KB == 0 else f'{max_bytes:,} B'} of reply text", total <= max_bytes, f"{total:,} B"),
        (largest_what, biggest[0] <= max_largest, f"largest {biggest[0] / KB:.1f} KB: {biggest[1]} in {biggest[2]}"),
    ]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("url")
    ap.add_argument("--report", action="store_true", help="measurement only: exit 0 whatever failed")
    ap.add_argument("--enforce-targets", action="store_true", help="a failed budget target fails the run")
    ap.add_argument("--calls", action="store_true", help="print one line per call")
    args = ap.parse_args()

    done = asyncio.run(run(args.url, args.calls))

    print(f"{'task':<28} {'calls':>5} {'reply bytes':>12} {'largest':>10}  {'(tool)':<30} outcome")
    for t in done:
        tool, largest = t.largest[0], t.largest[1]
        extra = f"  [{t.summarised} summarised]" if t.summarised else ""
        print(f"{t.number}. {t.name:<25} {t.n_calls:>5} {t.total:>12,} {largest:>10,}  {tool:<30} {'PASS' if t.ok else 'FAIL'}{extra}")
        for n in t.notes:
            print(f"       {n}")
        for f in t.failures:
            print(f"       FAILED: {f}")

    five = [t for t in done if t.number in THE_FIVE]
    calls, total, _ = totals(five)
    targets = budget_targets("the five tasks", (calls, total, totals(done)[2]), (TARGET_CALLS, TARGET_BYTES, TARGET_LARGEST),
                             f"no single default reply over {TARGET_LARGEST // KB} KB (all tasks)")
    a_calls, a_total, a_big = totals([t for t in done if t.number in THE_ANSWERS])
    answer_targets = budget_targets("the answer tasks", (a_calls, a_total, a_big), (ANSWER_CALLS, ANSWER_BYTES, ANSWER_LARGEST),
                                    f"no answer-task reply over {ANSWER_LARGEST // KB} KB")
    targets += answer_targets
    print()
    print("the answer tasks (bounce, reach, dominoes + undo, ramp sweep, ant), asking for measures:")
    print(f"  {a_calls} calls, {a_total:,} B ({a_total / KB:.1f} KB) of reply text")
    for what, ok, figure in answer_targets:
        print(f"  target: {what:<52} {'PASS' if ok else 'FAIL'}  ({figure})")
    print()
    print("the five tasks (tower look-back, 100-box pile, sweep, robots = KUKA + wheeled base, timeline ops):")
    print(f"  {calls} calls, {total:,} B ({total / KB:.1f} KB) of reply text")
    for what, ok, figure in targets[: len(targets) - len(answer_targets)]:
        print(f"  target: {what:<52} {'PASS' if ok else 'FAIL'}  ({figure})")

    outcomes_ok = all(t.ok for t in done)
    targets_ok = all(ok for _, ok, _ in targets)
    print()
    print(f"outcomes: {sum(t.ok for t in done)} of {len(done)} right; targets: {sum(ok for _, ok, _ in targets)} of {len(targets)} met")
    if args.report:
        return 0
    if not outcomes_ok:
        return 1
    if args.enforce_targets and not targets_ok:
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
