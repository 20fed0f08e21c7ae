#!/usr/bin/env python3
"""Robots at engine speed, in one run: physics-mcp against PyBullet on the KUKA iiwa
and the Franka Panda, and against MuJoCo on every Gymnasium model, measured the way a user
meets it (one step_simulation over MCP) and in process (`cargo bench --bench robot_steps`,
engine rules 2 and 3 by default), each beside the reference measured in the same run.

Dev-only (pybullet, mujoco and numpy are not dependencies of the project; cargo test never
runs this):

    python3 -m venv /tmp/rb && /tmp/rb/bin/pip install pybullet mujoco numpy
    cargo build --release --locked
    /tmp/rb/bin/python scripts/robot_bench.py [--bin target/release/physics-mcp] [--runs 3]

Scenes:
- `kuka`, `panda`: pybullet_data's kuka_iiwa/model.urdf and franka_panda/panda.urdf (copied
  into the server's workspace with their meshes), fixed base, on PyBullet's plane, every
  movable joint on a position motor holding 0.3 (rad, or m for the Panda's fingers) with
  force 100, 2,400 steps of 1/240 s. PyBullet: the same URDF, plane and motors
  (setJointMotorControlArray), `stepSimulation` in process. Ours over MCP: one
  step_simulation of 2,400 steps after loading and set_joint_motor_control_array.
- Gymnasium models (tests/fixtures/mjcf): 1,000 steps at the model's own timestep from qpos0,
  nothing driving the joints; the same simulated time on both sides, so the ratio per step is
  the ratio per simulated second. MuJoCo: `mj_step(model, data, nstep=1000)` (its C loop) and a
  Python loop of `mj_step` (what Gymnasium does). Ours over MCP: load_mjcf, set_timestep to the
  model's, one step_simulation of 1,000 steps.
Each figure is the best of --runs runs (each from a fresh world/model) in ms per step. Ratios are
ours / reference; below 1 = ours faster. ROBOT_BENCH_SCENES (comma-separated) narrows the run.
"""

import argparse
import datetime
import importlib.metadata
import os
import pathlib
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time

import mujoco
import pybullet as p
import pybullet_data

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts" / "lib"))
from mcp_http import Session, start  # noqa: E402

MJCF = ["ant", "half_cheetah", "hopper", "humanoid", "humanoidstandup", "inverted_double_pendulum",
        "inverted_pendulum", "pusher", "reacher", "swimmer", "walker2d"]
ROBOTS = {"kuka": "kuka_iiwa/model.urdf", "panda": "franka_panda/panda.urdf"}
ROBOT_STEPS, MJCF_STEPS = 2400, 1000
TARGET, FORCE = 0.3, 100.0


def wanted(name):
    only = os.environ.get("ROBOT_BENCH_SCENES")
    return not only or name in only.split(",")


def best(f, runs):
    """The smallest of `runs` results of f (ms per step)."""
    return min(f() for _ in range(runs))


# --- references -------------------------------------------------------------------------------

def pybullet_robot(urdf):
    """ms/step of PyBullet stepping the robot with every movable joint on a position motor."""
    p.resetSimulation()
    p.setGravity(0, 0, -9.81)
    p.setTimeStep(1 / 240)
    p.loadURDF("plane.urdf")
    robot = p.loadURDF(urdf, useFixedBase=True)
    joints = [j for j in range(p.getNumJoints(robot)) if p.getJointInfo(robot, j)[2] in (p.JOINT_REVOLUTE, p.JOINT_PRISMATIC)]
    p.setJointMotorControlArray(robot, joints, p.POSITION_CONTROL, targetPositions=[TARGET] * len(joints), forces=[FORCE] * len(joints))
    t = time.perf_counter()
    for _ in range(ROBOT_STEPS):
        p.stepSimulation()
    return (time.perf_counter() - t) * 1e3 / ROBOT_STEPS, len(joints)


def mujoco_model(name):
    """(timestep, C-loop ms/step, Python-loop ms/step) of MuJoCo stepping the model from qpos0."""
    model = mujoco.MjModel.from_xml_path(str(ROOT / "tests" / "fixtures" / "mjcf" / f"{name}.xml"))
    data = mujoco.MjData(model)
    t = time.perf_counter()
    mujoco.mj_step(model, data, nstep=MJCF_STEPS)
    c = (time.perf_counter() - t) * 1e3 / MJCF_STEPS
    mujoco.mj_resetData(model, data)
    t = time.perf_counter()
    for _ in range(MJCF_STEPS):
        mujoco.mj_step(model, data)
    py = (time.perf_counter() - t) * 1e3 / MJCF_STEPS
    return model.opt.timestep, c, py


# --- ours -------------------------------------------------------------------------------------

def ours_robot_mcp(s, urdf):
    sim = s.call("create_simulation", {})["simulation_id"]
    s.call("load_urdf", {"sim_id": sim, "file_path": "plane.urdf"})
    robot = s.call("load_urdf", {"sim_id": sim, "file_path": urdf, "use_fixed_base": True})["object_id"]
    n = s.call("get_num_joints", {"sim_id": sim, "object_id": robot})["num_joints"]
    joints = [j for j in range(n) if s.call("get_joint_info", {"sim_id": sim, "object_id": robot, "joint_index": j})["joint_type"] in ("revolute", "prismatic")]
    s.call("set_joint_motor_control_array", {"sim_id": sim, "object_id": robot, "joint_indices": joints, "control_mode": "POSITION_CONTROL",
                                             "target_positions": [TARGET] * len(joints), "forces": [FORCE] * len(joints)})
    t = time.perf_counter()
    s.call("step_simulation", {"sim_id": sim, "steps": ROBOT_STEPS})
    ms = (time.perf_counter() - t) * 1e3 / ROBOT_STEPS
    s.call("destroy_simulation", {"sim_id": sim})
    return ms


def ours_mjcf_mcp(s, name, dt):
    sim = s.call("create_simulation", {})["simulation_id"]
    s.call("load_mjcf", {"sim_id": sim, "file_path": f"mjcf/{name}.xml"})
    s.call("set_timestep", {"sim_id": sim, "timestep": dt})
    t = time.perf_counter()
    s.call("step_simulation", {"sim_id": sim, "steps": MJCF_STEPS})
    ms = (time.perf_counter() - t) * 1e3 / MJCF_STEPS
    s.call("destroy_simulation", {"sim_id": sim})
    return ms


def ours_in_process(runs):
    """{(scene, rule): ms/step} from `cargo bench --bench robot_steps` (min of its runs)."""
    env = dict(os.environ, ROBOT_BENCH_DATA=pybullet_data.getDataPath(), ROBOT_BENCH_RUNS=str(runs))
    out = subprocess.run(["cargo", "bench", "--locked", "--bench", "robot_steps"], cwd=ROOT, env=env, capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"cargo bench --bench robot_steps failed:\n{out.stderr[-3000:]}")
    found = {}
    for m in re.finditer(r"REPORT robot_steps (\w+) rule (\d+): ([0-9.]+) ms/step \(min ([0-9.]+)", out.stdout):
        found[(m.group(1), int(m.group(2)))] = float(m.group(4))
    return found


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    target = os.environ.get("CARGO_TARGET_DIR", str(ROOT / "target"))
    ap.add_argument("--bin", default=os.environ.get("PHYSICS_MCP_BIN", f"{target}/release/physics-mcp"), help="release server binary")
    ap.add_argument("--runs", type=int, default=3, help="runs per figure (best of)")
    ap.add_argument("--no-in-process", action="store_true", help="skip cargo bench --bench robot_steps")
    a = ap.parse_args()
    if not os.access(a.bin, os.X_OK):
        raise SystemExit(f"no server binary at {a.bin}: cargo build --release --locked (or --bin)")
    git = lambda *args: subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    print(f"date: {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M UTC}; physics-mcp {git('rev-parse', '--short=12', 'HEAD')}; "
          f"pybullet {importlib.metadata.version('pybullet')}, mujoco {mujoco.__version__}, python {platform.python_version()}; "
          f"{os.cpu_count()} cores; load average {os.getloadavg()[0]:.1f}; best of {a.runs}", flush=True)
    inproc = {} if a.no_in_process else ours_in_process(a.runs)
    rows = []
    p.connect(p.DIRECT)
    p.setAdditionalSearchPath(pybullet_data.getDataPath())
    with tempfile.TemporaryDirectory() as tmp:
        ws = pathlib.Path(tmp) / "ws"
        ws.mkdir()
        for urdf in ROBOTS.values():
            d = urdf.split("/")[0]
            shutil.copytree(pathlib.Path(pybullet_data.getDataPath()) / d, ws / d)
        shutil.copytree(ROOT / "tests" / "fixtures" / "mjcf", ws / "mjcf")
        proc, hostport = start(a.bin, {}, tmp)
        try:
            s = Session(hostport)
            s.open("robot_bench")
            for name, urdf in ROBOTS.items():
                if not wanted(name):
                    continue
                ref = best(lambda: pybullet_robot(urdf)[0], a.runs)
                mcp = best(lambda: ours_robot_mcp(s, urdf), a.runs)
                rows.append((name, "PyBullet", mcp, inproc.get((name, 3)), inproc.get((name, 2)), ref, None))
                print(rows[-1], flush=True)
            for name in MJCF:
                if not wanted(name):
                    continue
                runs = [mujoco_model(name) for _ in range(a.runs)]
                dt = runs[0][0]
                ref, ref_py = min(r[1] for r in runs), min(r[2] for r in runs)
                mcp = best(lambda: ours_mjcf_mcp(s, name, dt), a.runs)
                rows.append((name, "MuJoCo", mcp, inproc.get((name, 3)), inproc.get((name, 2)), ref, ref_py))
                print(rows[-1], flush=True)
        finally:
            proc.terminate()
            proc.wait()
    print(f"load average at the end: {os.getloadavg()[0]:.1f}\n")
    f = lambda v: "–" if v is None else f"{v:.4f}"
    r = lambda a, b: "–" if a is None or b is None else f"{a / b:.2f}×"
    print("| scene | reference | ours over MCP (the server's rule, 4) | ours in process, rule 3 (rule 2) | reference ms/step (MuJoCo Python loop) | ratio over MCP | ratio in process, rule 3 (rule 2) |")
    print("|---|---|---|---|---|---|---|")
    for name, ref_name, mcp, rule3, rule2, ref, ref_py in rows:
        py = f" ({f(ref_py)})" if ref_py is not None else ""
        print(f"| {name} | {ref_name} | {f(mcp)} | {f(rule3)} ({f(rule2)}) | {f(ref)}{py} | **{r(mcp, ref)}** | {r(rule3, ref)} ({r(rule2, ref)}) |")


if __name__ == "__main__":
    main()
