#!/usr/bin/env python3
"""physics-mcp side by side with PyBullet, in one process and one run:
every pair on the same scene, printed with its ratio (ours / PyBullet; below 1 = ours faster).

Dev-only (pybullet and numpy are not dependencies of the project; cargo test never runs this):

    python3 -m venv /tmp/pb && /tmp/pb/bin/pip install pybullet numpy
    cargo build --release --locked
    /tmp/pb/bin/python scripts/compare_pybullet.py [--bin target/release/physics-mcp]

(pybullet may build from source on a Python without a wheel: a few minutes.) The script also
runs `cargo run --release --locked --example compare_pile` (the in-process figure, and the
pile's exact boxes), so run it from a checkout with cargo on PATH; CARGO_TARGET_DIR is honoured
for both the example and the default --bin.

The scene is the 1000-box collapsing pile of benches/pile.rs (half-extent 0.1 m boxes on a
10×10×10 grid, 0.25 m apart from z = 0.5, jittered and turned by a seeded generator, on a
static 40×40×1 m ground), its boxes taken from the example so all sides build the very same
numbers. PyBullet runs at its defaults (dt 1/240, gravity set to -9.81, sleeping on as in
ours). Rows:
- stepping: ms/step of steps 100–400, median of --runs runs: PyBullet with maximal coordinates
  (createMultiBody(useMaximalCoordinates=True): btRigidBody) and as multibodies (=False, the
  default), ours in-process (`World::apply`) and over MCP (one step_simulation(300) call), the
  latter also with the viewer's contact overlay off (enable_debug_visualization).
- pile build over MCP: 1,001 add_box calls on one kept-alive connection vs one `batch` call
  (skipped with a note while the server's tools/list has no `batch`).
- 10,000 rays over the collapsed pile: ray_test_batch (with output_path, as more than ~4,300
  results do not fit an MCP reply) vs rayTestBatch.
- camera 320×240 and 640×480 of the pile: get_camera_image (PNG inline) vs getCameraImage
  with ER_TINY_RENDERER, the same view and projection matrices.
- save/restore of the 1000-body pile: save_simulation / load_simulation (files) vs saveBullet /
  restoreState(fileName) and saveState / restoreState(stateId) (memory).
- KUKA iiwa IK (pybullet_data's kuka_iiwa/model.urdf, copied into the server's workspace):
  calculate_inverse_kinematics over MCP vs calculateInverseKinematics, both from all joints at
  zero, position targets reached by random joint configurations; each answer's error is
  measured by PyBullet's forward kinematics (link frame).
Each figure is a wall time and, in brackets, a CPU time: this process's for PyBullet, the client's
plus the server's (all threads, Linux schedstat) for ours over MCP, the stepping thread's for ours
in-process — on a machine busy with other work the CPU times are the steadier comparison. MCP
figures are the client's time per call (Python stdlib client over one kept-alive connection,
scripts/lib/mcp_http.py), so they include HTTP, JSON and the event log's commit.
"""

import argparse
import datetime
import importlib.metadata
import json
import math
import os
import pathlib
import platform
import random
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import pybullet as p
import pybullet_data

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts" / "lib"))
from mcp_http import Session, start  # noqa: E402

WARM, TIMED = 100, 300  # steps before the timed ones, steps timed (benches/physics.rs's 100–400)
ROWS = []  # (what, ours, pybullet, ratio, note) as printed
SERVER = {"pid": None}  # the server's process id, for its CPU time


def server_cpu_s():
    """The server's time on a CPU so far, all threads (s; Linux's schedstat)."""
    total = 0
    task = pathlib.Path(f"/proc/{SERVER['pid']}/task")
    for t in task.iterdir():
        try:
            total += int((t / "schedstat").read_text().split()[0])
        except (OSError, ValueError, IndexError):
            pass  # a thread that ended meanwhile
    return total / 1e9


def cpu_s(ours, end=False):
    """CPU seconds so far of the side that does the work: this process (PyBullet, or our
    client's share of an MCP call), plus the server's for ours. This process's clock is read
    last at a start and first at an end, so reading the server's clock is never counted."""
    if not ours:
        return time.process_time()
    if end:
        mine = time.process_time()
        return mine + server_cpu_s()
    server = server_cpu_s()
    return server + time.process_time()


class Timed:
    """A measurement: median wall time and median CPU time (both processes for ours), so a
    machine busy with other work — its waits for a core — can be told from the work itself."""

    def __init__(self, wall, cpu):
        self.wall, self.cpu = wall, cpu


def measure(f, runs, ours, per=1):
    """Median wall and CPU ms of `runs` calls of f (divided by `per`, e.g. steps per call)."""
    walls, cpus = [], []
    for _ in range(runs):
        c, t = cpu_s(ours), time.perf_counter()
        f()
        walls.append((time.perf_counter() - t) * 1e3 / per)
        cpus.append((cpu_s(ours, end=True) - c) * 1e3 / per)
    return Timed(statistics.median(walls), statistics.median(cpus))


def fmt(v, unit):
    return f"{v:.3f} {unit}" if v < 10 else f"{v:.1f} {unit}" if v < 1000 else f"{v:.0f} {unit}"


def row(what, ours, theirs, unit="ms", note=""):
    """One pair, printed at once and kept for the closing table: wall time (CPU time) and the
    ratio ours / PyBullet of each."""
    cell = lambda t: f"{fmt(t.wall, unit)} ({fmt(t.cpu, unit)})"
    ratio = f"{ours.wall / theirs.wall:.2f} ({ours.cpu / theirs.cpu:.2f})"
    ROWS.append((what, cell(ours), cell(theirs), ratio, note))
    print(f"{what}: ours {cell(ours)}, pybullet {cell(theirs)}, ratio {ratio}" + (f"; {note}" if note else ""), flush=True)


# --- the header -------------------------------------------------------------------------------

def header(binary):
    cpu = "unknown"
    try:
        cpu = next(l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name"))
    except (OSError, StopIteration):
        pass
    git = lambda *a: subprocess.run(["git", *a], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    commit = git("rev-parse", "--short=12", "HEAD") + (" (uncommitted changes)" if git("status", "--porcelain", "--untracked-files=no") else "")
    lock = (ROOT / "Cargo.lock").read_text()
    rapier = lock.split('name = "rapier3d"\nversion = "', 1)[1].split('"', 1)[0] if 'name = "rapier3d"' in lock else "?"
    return [
        f"date: {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M UTC}",
        f"machine: {cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}",
        f"versions: pybullet {importlib.metadata.version('pybullet')}, numpy {importlib.metadata.version('numpy')}, "
        f"python {platform.python_version()}, physics-mcp {commit}, rapier3d {rapier}",
        f"server: {binary}",
    ]


# --- ours in-process --------------------------------------------------------------------------

def ours_in_process(runs):
    """The example's JSON: ms_per_step, state_hash_after and the pile's boxes."""
    cmd = ["cargo", "run", "--release", "--locked", "--quiet", "--example", "compare_pile", str(runs)]
    out = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{out.stderr}")
    return json.loads(out.stdout)


# --- PyBullet ---------------------------------------------------------------------------------

def unit(q):
    n = math.sqrt(sum(c * c for c in q))
    return [c / n for c in q]


def pb_pile(boxes, maximal):
    """The pile in the connected PyBullet client (grey visual shapes, for the camera)."""
    p.resetSimulation()
    p.setGravity(0, 0, -9.81)
    p.setTimeStep(1 / 240)
    for b in boxes:
        col = p.createCollisionShape(p.GEOM_BOX, halfExtents=b["half_extents"])
        vis = p.createVisualShape(p.GEOM_BOX, halfExtents=b["half_extents"], rgbaColor=[0.8, 0.8, 0.8, 1])
        p.createMultiBody(b["mass"], col, vis, b["position"], unit(b["orientation"]), useMaximalCoordinates=maximal)


def pb_step(boxes, maximal, runs):
    """Steps 100–400 per step, median of runs, each on a freshly built pile (a restored state
    would not restore Bullet's contact caches)."""
    walls, cpus = [], []
    for _ in range(runs):
        pb_pile(boxes, maximal)
        for _ in range(WARM):
            p.stepSimulation()
        c, t = cpu_s(False), time.perf_counter()
        for _ in range(TIMED):
            p.stepSimulation()
        walls.append((time.perf_counter() - t) * 1e3 / TIMED)
        cpus.append((cpu_s(False) - c) * 1e3 / TIMED)
    return Timed(statistics.median(walls), statistics.median(cpus))


# --- over MCP ---------------------------------------------------------------------------------

def add_box_args(b, sim=None):
    a = {"dimensions": b["half_extents"], "position": b["position"], "orientation": b["orientation"], "mass": b["mass"]}
    return dict(a, sim_id=sim) if sim else a


def mcp_build(s, boxes):
    """A new simulation with the pile, one add_box call per box; (sim, ms)."""
    sim = s.call("create_simulation", {})["simulation_id"]
    t = time.perf_counter()
    for b in boxes:
        s.call("add_box", add_box_args(b, sim))
    return sim, (time.perf_counter() - t) * 1e3


def mcp_batch_build(s, boxes):
    """A new simulation with the pile from one batch call; (sim, ms)."""
    sim = s.call("create_simulation", {})["simulation_id"]
    calls = [{"tool": "add_box", "arguments": add_box_args(b)} for b in boxes]
    t = time.perf_counter()
    s.call("batch", {"sim_id": sim, "calls": calls})
    return sim, (time.perf_counter() - t) * 1e3


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    target = os.environ.get("CARGO_TARGET_DIR", str(ROOT / "target"))
    ap.add_argument("--bin", default=os.environ.get("PHYSICS_MCP_BIN", f"{target}/release/physics-mcp"), help="release server binary")
    ap.add_argument("--runs", type=int, default=3, help="runs of the pile's steps 100–400 per side (median)")
    ap.add_argument("--reps", type=int, default=10, help="repetitions of each smaller measurement (median)")
    ap.add_argument("--ik-targets", type=int, default=200)
    a = ap.parse_args()
    if not os.access(a.bin, os.X_OK):
        raise SystemExit(f"no server binary at {a.bin}: cargo build --release --locked (or --bin)")
    for line in header(a.bin):
        print(line, flush=True)

    inproc = ours_in_process(a.runs)
    boxes = inproc["boxes"]
    assert len(boxes) == 1001  # the static ground, then the 1000 boxes

    with tempfile.TemporaryDirectory() as tmp:
        (pathlib.Path(tmp) / "ws").mkdir()
        shutil.copytree(pathlib.Path(pybullet_data.getDataPath()) / "kuka_iiwa", pathlib.Path(tmp) / "ws" / "kuka_iiwa")
        proc, hostport = start(a.bin, {}, tmp)
        SERVER["pid"] = proc.pid
        try:
            run_all(a, inproc, boxes, Session(hostport), pathlib.Path(tmp))
        finally:
            proc.terminate()
            proc.wait()

    print(f"load average at the end: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    print("\nwall time (CPU time: this process for PyBullet; client + server for ours over MCP)")
    print("| what | physics-mcp | PyBullet | ratio | note |\n|---|---|---|---|---|")
    for r in ROWS:
        print("| " + " | ".join(r) + " |")


def run_all(a, inproc, boxes, s, tmp):
    s.open("compare_pybullet")
    tools = s.tools()
    p.connect(p.DIRECT)

    # Stepping the pile.
    pb_multi = pb_step(boxes, False, a.runs)
    pb_max = pb_step(boxes, True, a.runs)  # leaves PyBullet's pile (maximal) at step 400
    sim, build_ms = mcp_build(s, boxes)
    s.call("step_simulation", {"sim_id": sim, "steps": WARM})
    walls, cpus = [], []
    for i in range(a.runs):
        t = measure(lambda: s.call("step_simulation", {"sim_id": sim, "steps": TIMED}), 1, True, TIMED)
        walls.append(t.wall)
        cpus.append(t.cpu)
        if i + 1 < a.runs:
            s.call("undo", {"sim_id": sim, "count": 1})
    mcp = Timed(statistics.median(walls), statistics.median(cpus))
    inp = Timed(inproc["ms_per_step"], inproc["cpu_ms_per_step"] or float("nan"))
    row("pile step (ms/step): ours in-process vs PyBullet maximal coordinates", inp, pb_max)
    row("pile step: ours in-process vs PyBullet multibody", inp, pb_multi)
    row(f"pile step: ours over MCP (step_simulation({TIMED})) vs PyBullet maximal", mcp, pb_max)
    row("pile step: ours over MCP vs PyBullet multibody", mcp, pb_multi)
    # While a step runs the server publishes the scene for the live viewer every 100 ms, with
    # the contact overlay when show_contacts is on (the default), gui or not: the same steps
    # with it off tell what that costs.
    vsim, _ = mcp_build(s, boxes)
    s.call("enable_debug_visualization", {"sim_id": vsim, "show_contacts": False})
    s.call("step_simulation", {"sim_id": vsim, "steps": WARM})
    walls, cpus = [], []
    for i in range(a.runs):
        t = measure(lambda: s.call("step_simulation", {"sim_id": vsim, "steps": TIMED}), 1, True, TIMED)
        walls.append(t.wall)
        cpus.append(t.cpu)
        if i + 1 < a.runs:
            s.call("undo", {"sim_id": vsim, "count": 1})
    s.call("destroy_simulation", {"sim_id": vsim})
    row("pile step: ours over MCP with enable_debug_visualization(show_contacts=false) vs PyBullet maximal",
        Timed(statistics.median(walls), statistics.median(cpus)), pb_max)

    # Building the pile over MCP (both sides ours: per box vs one batch).
    if "batch" in tools:
        bsim, batch_ms = mcp_batch_build(s, boxes)
        s.call("destroy_simulation", {"sim_id": bsim})
        batch, ratio = f"{batch_ms:.1f} ms", f"{batch_ms / build_ms:.2f}"
        note = "both columns ours; ratio = batch / per box"
    else:
        batch, ratio = "n/a", "n/a"
        note = "batch tool not available (the server's tools/list has no batch): not measured"
    ROWS.append(("pile build over MCP: one batch call vs 1,001 add_box calls (keep-alive)", batch,
                 f"{build_ms:.0f} ms (add_box × 1,001, ours)", ratio, note))
    print(f"pile build over MCP: 1,001 add_box calls {build_ms:.1f} ms; one batch call {batch} ({note})", flush=True)

    # Both sides now hold the collapsed pile at step 400.
    saved = s.call("save_simulation", {"sim_id": sim, "file_path": "saves/check.json"})
    same = saved["state_hash"] == inproc["state_hash_after"]
    print(f"the MCP pile at step {WARM + TIMED} has the in-process state hash: {'yes' if same else 'NO'}", flush=True)

    # 10,000 rays (the sensing bench's, seeded), encoded once: the client's JSON encoding of
    # 60,000 numbers is not the server's work.
    rng = random.Random(7)
    frm, to = [], []
    for _ in range(10000):
        x, y = rng.uniform(-0.5, 3.0), rng.uniform(-0.5, 3.0)
        frm.append([x, y, 5.0])
        to.append([x + rng.uniform(-0.3, 0.3), y + rng.uniform(-0.3, 0.3), -1.0])
    encoded = json.dumps({"sim_id": sim, "rays_from": frm, "rays_to": to, "output_path": "@@PATH@@"})
    n = iter(range(10 ** 6))
    ours_rays = measure(lambda: s.call("ray_test_batch", encoded.replace("@@PATH@@", f"rays/r{next(n)}.json")), a.reps, True)
    hits = s.call("ray_test_batch", encoded.replace("@@PATH@@", "rays/final.json"))["hits"]
    cores = os.cpu_count()
    pb_rays1 = measure(lambda: p.rayTestBatch(frm, to, numThreads=1), a.reps, False)
    pb_rays_n = measure(lambda: p.rayTestBatch(frm, to, numThreads=cores), a.reps, False)
    pb_hits = sum(1 for r in p.rayTestBatch(frm, to) if r[0] >= 0)
    row(f"10,000 rays over the pile: ray_test_batch vs rayTestBatch(numThreads={cores})", ours_rays, pb_rays_n, note=
        f"ours on all cores, results to a JSON file (output_path); hits ours {hits}, PyBullet {pb_hits}")
    row("10,000 rays: vs rayTestBatch(numThreads=1)", ours_rays, pb_rays1)

    # Camera.
    view = p.computeViewMatrix([6, -4, 4], [1.1, 1.1, 0.2], [0, 0, 1])
    for w, h in ((320, 240), (640, 480)):
        proj = p.computeProjectionMatrixFOV(60, w / h, 0.1, 100)
        args = {"sim_id": sim, "width": w, "height": h, "view_matrix": list(view), "projection_matrix": list(proj)}
        ours_cam = measure(lambda: s.call("get_camera_image", args), a.reps, True)
        pb_cam = measure(lambda: p.getCameraImage(w, h, view, proj, renderer=p.ER_TINY_RENDERER), a.reps, False)
        row(f"camera {w}x{h} of the pile: get_camera_image vs getCameraImage(ER_TINY_RENDERER)", ours_cam, pb_cam, note=
            "ours: RGB PNG inline (base64); PyBullet: RGB, depth and segmentation arrays" if w == 320 else "")

    # Save / restore of the 1000 bodies.
    n = iter(range(10 ** 6))
    ours_save = measure(lambda: s.call("save_simulation", {"sim_id": sim, "file_path": f"saves/s{next(n)}.json"}), a.reps, True)
    save_mb = (tmp / "ws" / "saves" / "s0.json").stat().st_size / 1e6
    loaded = []
    n = iter(range(10 ** 6))
    ours_load = measure(lambda: loaded.append(s.call("load_simulation", {"file_path": f"saves/s{next(n)}.json"})["simulation_id"]), a.reps, True)
    for lsim in loaded:
        s.call("destroy_simulation", {"sim_id": lsim})
    bullet = str(tmp / "pile.bullet")
    pb_save_file = measure(lambda: p.saveBullet(bullet), a.reps, False)
    pb_load_file = measure(lambda: p.restoreState(fileName=bullet), a.reps, False)
    states = []
    pb_save_mem = measure(lambda: states.append(p.saveState()), a.reps, False)
    pb_load_mem = measure(lambda: p.restoreState(stateId=states[0]), a.reps, False)
    row("save 1000 bodies: save_simulation vs saveBullet (files)", ours_save, pb_save_file, note=
        f"ours: {save_mb:.1f} MB JSON with the whole history, fsynced; .bullet {os.path.getsize(bullet) / 1e6:.1f} MB")
    row("save 1000 bodies: save_simulation vs saveState (memory)", ours_save, pb_save_mem)
    row("restore 1000 bodies: load_simulation vs restoreState(fileName)", ours_load, pb_load_file, note=
        "ours: a new simulation from the file (snapshot verified, log written)")
    row("restore 1000 bodies: load_simulation vs restoreState(stateId)", ours_load, pb_load_mem)

    ik(a, s)


def ik(a, s):
    """KUKA iiwa IK, both from all joints at zero, errors measured by PyBullet's FK."""
    ksim = s.call("create_simulation", {})["simulation_id"]
    kid = s.call("load_urdf", {"sim_id": ksim, "file_path": "kuka_iiwa/model.urdf", "use_fixed_base": True})["object_id"]
    p.resetSimulation()
    k = p.loadURDF(str(pathlib.Path(pybullet_data.getDataPath()) / "kuka_iiwa" / "model.urdf"), useFixedBase=True)
    nj, ee = p.getNumJoints(k), 6
    limits = [p.getJointInfo(k, j)[8:10] for j in range(nj)]

    def set_joints(q):
        for j in range(nj):
            p.resetJointState(k, j, q[j])

    def error(q, target):
        set_joints(q)
        return math.dist(p.getLinkState(k, ee, computeForwardKinematics=True)[4], target)

    rng = random.Random(3)
    targets = []
    for _ in range(a.ik_targets):
        set_joints([rng.uniform(lo, hi) * 0.8 for lo, hi in limits])
        targets.append(p.getLinkState(k, ee, computeForwardKinematics=True)[4])

    def solve_all(solve, ours):
        """Median µs per call (wall, CPU) and each answer's error (m)."""
        walls, cpus, errs = [], [], []
        for target in targets:
            set_joints([0] * nj)
            out = []
            t = measure(lambda: out.append(solve(target)), 1, ours)
            walls.append(t.wall * 1e3)
            cpus.append(t.cpu * 1e3)
            errs.append(error(out[0], target))
        return Timed(statistics.median(walls), statistics.median(cpus)), errs

    def errs_note(errs):
        errs = sorted(errs)
        return f"median error {errs[len(errs) // 2] * 1e3:.3g} mm, {sum(e < 1e-3 for e in errs) * 100 // len(errs)} % under 1 mm"

    ours, ours_errs = solve_all(lambda t: s.call("calculate_inverse_kinematics", {
        "sim_id": ksim, "object_id": kid, "end_effector_link_index": ee, "target_position": list(t)})["joint_positions"], True)
    pb, pb_errs = solve_all(lambda t: p.calculateInverseKinematics(k, ee, t), False)
    row(f"KUKA iiwa IK, {len(targets)} reachable position targets (µs/call): vs PyBullet's defaults", ours, pb, "µs",
        f"ours over MCP: {errs_note(ours_errs)}; PyBullet: {errs_note(pb_errs)}")
    pb2, pb2_errs = solve_all(lambda t: p.calculateInverseKinematics(k, ee, t, maxNumIterations=200, residualThreshold=1e-6), False)
    row("KUKA iiwa IK: vs PyBullet maxNumIterations=200, residualThreshold=1e-6", ours, pb2, "µs", f"PyBullet: {errs_note(pb2_errs)}")


if __name__ == "__main__":
    main()
