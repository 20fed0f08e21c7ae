#!/usr/bin/env python3
"""Robots at engine speed counted in instructions: callgrind's instruction counts per
step are repeatable on a shared machine where seconds are not. In one run, for each scene:
physics-mcp's step under the engine rules asked for (`--rules`, default 2,3: rule 2 the tree path
of crates/rapier3d/PATCHES.md patch 1, rule 3 patch 3's mass matrices once per step; rule 1 is
rapier 0.36.1's arithmetic), and the reference engine on the same model:

- `iiwa14`, `panda`: tests/fixtures/iiwa14.urdf and panda_dynamics.urdf (meshless), fixed base,
  no ground, every movable joint on a position motor holding 0.3 with force 100 (position gain
  0.1, velocity gain 1), steps of 1/240 s. Reference: PyBullet 3.2.7 (DIRECT), the same URDF
  and motors (setJointMotorControlArray), `stepSimulation`: instructions of N steps minus those
  of none, over N.
- `kuka`, `panda` (with `--data`, pybullet_data's directory): pybullet_data's
  kuka_iiwa/model.urdf and franka_panda/panda.urdf with their meshes (each link's collision
  shape the convex hull of its mesh), fixed base, on pybullet_data's plane, the same motors:
  the scenes `scripts/robot_bench.py` times over MCP. Ours: `benches/robot_steps.rs` (build it
  with `cargo bench --bench robot_steps --no-run`), counted inside `World::step_here`;
  reference: PyBullet as above with the plane loaded first.
- Gymnasium models (tests/fixtures/mjcf): steps at the model's own timestep from qpos0, nothing
  driving them. Reference: MuJoCo, `mj_step` counted alone (`--toggle-collect=mj_step`); the
  same simulated time per step, so the ratio per step is the ratio per simulated second.

Ours: `crates/physics-core/examples/rule_steps.rs`, counted inside `World::step_here` (the
step loop, one thread). Dev-only (valgrind, pybullet, mujoco are not project dependencies):

    cargo build --release -p physics-core --example rule_steps
    python3 -m venv /tmp/rb && /tmp/rb/bin/pip install pybullet mujoco
    /tmp/rb/bin/python scripts/robot_callgrind.py [--steps 480] [--rules 2,3] [scene ...]

Prints one markdown table row per scene: instructions per step under each rule, the last rule
over the first, the reference's instructions per step and ours (the last rule) / reference.
"""

import argparse
import os
import pathlib
import re
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
FIXTURES = ROOT / "tests" / "fixtures"
EXAMPLE = ROOT / "target" / "release" / "examples" / "rule_steps"
ROBOTS = {"iiwa14": "iiwa14.urdf", "panda": "panda_dynamics.urdf"}
MESHED = {"kuka": "kuka_iiwa/model.urdf", "panda": "franka_panda/panda.urdf"}
DEFAULT_SCENES = ["iiwa14", "panda", "half_cheetah", "pusher", "humanoid"]


def callgrind(cmd, toggle=None, env=None):
    """Instructions callgrind counts for `cmd` (inside `toggle` only, when given)."""
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "cg.out")
        args = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}"]
        if toggle:
            args.append(f"--toggle-collect={toggle}")
        subprocess.run(args + cmd, check=True, capture_output=True, text=True, env=env)
        text = open(out).read()
    return int(re.search(r"^totals: (\d+)", text, re.M).group(1))


def ours(scene, steps, rule, data=None):
    if data and scene in MESHED:
        built = [f for f in (ROOT / "target" / "release" / "deps").glob("robot_steps-*") if f.suffix != ".d"]
        bench = max(built, key=lambda f: f.stat().st_mtime)
        env = dict(os.environ, ROBOT_BENCH_DATA=data, ROBOT_BENCH_SCENES=scene, ROBOT_BENCH_RULES=str(rule),
                   ROBOT_BENCH_STEPS=str(steps), ROBOT_BENCH_RUNS="1")
        return callgrind([str(bench)], "*step_here*", env) / steps
    return callgrind([str(EXAMPLE), scene, str(steps), str(rule)], "*step_here*") / steps


PYBULLET = """
import sys, pybullet as p
steps = int(sys.argv[2])
p.connect(p.DIRECT)
p.setGravity(0, 0, -9.81)
p.setTimeStep(1 / 240)
if len(sys.argv) > 3:
    p.setAdditionalSearchPath(sys.argv[3])
    p.loadURDF("plane.urdf")
robot = p.loadURDF(sys.argv[1], useFixedBase=True)
joints = [j for j in range(p.getNumJoints(robot)) if p.getJointInfo(robot, j)[2] in (p.JOINT_REVOLUTE, p.JOINT_PRISMATIC)]
n = len(joints)
p.setJointMotorControlArray(robot, joints, p.POSITION_CONTROL, targetPositions=[0.3] * n, forces=[100] * n,
                            positionGains=[0.1] * n, velocityGains=[1.0] * n)
for _ in range(steps):
    p.stepSimulation()
"""

MUJOCO = """
import sys, mujoco
m = mujoco.MjModel.from_xml_path(sys.argv[1])
d = mujoco.MjData(m)
for _ in range(int(sys.argv[2])):
    mujoco.mj_step(m, d)
"""


def pybullet(scene, steps, data=None):
    meshed = data and scene in MESHED
    urdf = str(pathlib.Path(data) / MESHED[scene]) if meshed else str(FIXTURES / ROBOTS[scene])
    extra = [data] if meshed else []
    run = lambda n: callgrind([sys.executable, "-c", PYBULLET, urdf, str(n)] + extra)
    return (run(steps) - run(0)) / steps


def mujoco(scene, steps):
    xml = str(FIXTURES / "mjcf" / f"{scene}.xml")
    return callgrind([sys.executable, "-c", MUJOCO, xml, str(steps)], "mj_step") / steps


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=480)
    ap.add_argument("--rules", default="2,3", help="engine rules to count, comma-separated (the first is the baseline, the last is compared)")
    ap.add_argument("--data", help="pybullet_data's directory: `kuka` and `panda` become the meshed robots on a plane")
    ap.add_argument("scenes", nargs="*", default=DEFAULT_SCENES)
    a = ap.parse_args()
    rules = [int(r) for r in a.rules.split(",")]
    first, last = rules[0], rules[-1]
    head = " | ".join(f"rule {r} Ir/step" for r in rules)
    print(f"| scene | {head} | rule {last} / rule {first} | reference | reference Ir/step | rule {last} / reference |")
    print("|---|" + "---|" * (len(rules) + 4))
    for scene in a.scenes:
        counts = [ours(scene, a.steps, r, a.data) for r in rules]
        robot = scene in ROBOTS or (a.data and scene in MESHED)
        name, ref = ("PyBullet", pybullet(scene, a.steps, a.data)) if robot else ("MuJoCo", mujoco(scene, a.steps))
        cells = " | ".join(f"{c:,.0f}" for c in counts)
        print(f"| {scene} | {cells} | {counts[-1] / counts[0]:.2f} | {name} | {ref:,.0f} | {counts[-1] / ref:.2f} |", flush=True)


if __name__ == "__main__":
    main()
