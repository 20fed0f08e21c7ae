#!/usr/bin/env python3
"""Pictures of three scenes, as the server draws them: a still (get_camera_image, 480×360) and
a looping GIF of the run (render_animation, 320×240) of each, with the server's default camera
(no view or projection matrix is passed). Made to compare the pictures of two builds, e.g. the
before and after of a change to the default camera or the renderer: run the same script with
each binary into its own directory.

    python3 scripts/pictures.py [--bin target/release/physics-mcp] --out DIR

Stdlib only (scripts/lib/mcp_http.py). The server runs on a free loopback port with throwaway
data and workspace directories, and stops when the script ends. Scenes, each in its own
simulation, each run one step_simulation call (so render_animation's default interval, the last
step, is the whole run):
- tower: plane.urdf, five 0.2 m boxes of different colours stacked, a ball thrown into them
  (set_object_velocity), 2 s.
- pile: plane.urdf and 1,000 0.2 m boxes (10×10×10, 0.36 m apart from z = 0.5, jittered and
  turned every way by a seeded generator), added with `batch` (4 calls), dropped for 2 s.
- arm: plane.urdf and the KUKA iiwa 14 of tests/fixtures/iiwa14.urdf (fixed base), three
  joints driven to targets by set_joint_motor_control (POSITION_CONTROL), 2 s.
Writes NAME.png and NAME.gif into --out. Every file must stay within --max-kb (300 KB): a GIF
over it is rendered again with a larger `every` (fewer frames), then smaller, and what was used
is printed. Only the arguments a tool's schema (tools/list) declares are sent, so one script
serves builds whose tools take different parameters; what is left out is printed.
"""

import argparse
import base64
import math
import os
import pathlib
import random
import shutil
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts" / "lib"))
from mcp_http import Session, start  # noqa: E402

SECONDS = 2.0
PNG_SIZE = (480, 360)
GIF_SIZE = (320, 240)
COLOURS = [[0.90, 0.20, 0.20], [0.95, 0.60, 0.10], [0.95, 0.90, 0.20], [0.25, 0.75, 0.30], [0.20, 0.45, 0.90],
           [0.60, 0.30, 0.80]]


class Server:
    """A session plus the tools' schemas: `call` drops arguments a tool does not declare."""

    def __init__(self, session):
        self.s = session
        self.schemas = {t["name"]: t.get("inputSchema", {}) for t in session.post("tools/list", {})["result"]["tools"]}
        self.dropped = set()

    def declares(self, tool, param):
        return param in self.schemas.get(tool, {}).get("properties", {})

    def args(self, tool, args):
        if tool not in self.schemas:
            raise SystemExit(f"the server has no tool {tool}")
        kept = {k: v for k, v in args.items() if self.declares(tool, k)}
        for k in args.keys() - kept.keys():
            if (tool, k) not in self.dropped:
                self.dropped.add((tool, k))
                print(f"  note: {tool} does not declare {k}; not sent", flush=True)
        missing = set(self.schemas[tool].get("required", [])) - kept.keys()
        if missing:
            raise SystemExit(f"{tool} requires {sorted(missing)}, which this script does not give")
        return kept

    def raw(self, tool, args):
        """The whole tools/call result (content and structuredContent), refusals included."""
        msg = self.s.post("tools/call", {"name": tool, "arguments": self.args(tool, args)})
        if "error" in msg:
            raise SystemExit(f"{tool}: JSON-RPC error {msg['error']}")
        return msg["result"]

    def call(self, tool, **args):
        result = self.raw(tool, args)
        if result.get("isError"):
            raise SystemExit(f"{tool} refused: {refusal(result)}")
        return result.get("structuredContent") or {}


def refusal(result):
    return " ".join(c.get("text", "") for c in result.get("content", []) if c.get("type") == "text")[:500]


def new_sim(srv, name):
    sim = srv.call("create_simulation", name=name)["simulation_id"]
    srv.call("load_urdf", sim_id=sim, file_path="plane.urdf")
    return sim


def steps_for(srv, sim, seconds):
    dt = srv.call("get_simulation_info", sim_id=sim).get("timestep") or 1 / 240
    return max(1, round(seconds / dt))


def run(srv, sim, seconds):
    """One step_simulation call of `seconds` simulated; prints the wall time."""
    n = steps_for(srv, sim, seconds)
    t0 = time.perf_counter()
    r = srv.call("step_simulation", sim_id=sim, steps=n)
    print(f"  stepped {r.get('steps_taken', n)} steps to t = {r.get('current_time', 0):.2f} s "
          f"in {time.perf_counter() - t0:.1f} s", flush=True)
    return n


def tower(srv):
    sim = new_sim(srv, "tower")
    for i in range(5):
        srv.call("add_box", sim_id=sim, dimensions=[0.1, 0.1, 0.1], position=[0, 0, 0.1 + 0.2 * i + 0.001 * i],
                 mass=1.0, color=COLOURS[i])
    ball = srv.call("add_sphere", sim_id=sim, radius=0.1, mass=2.0, position=[-1.2, 0, 0.75],
                    color=[0.15, 0.15, 0.15])["object_id"]
    srv.call("set_object_velocity", sim_id=sim, object_id=ball, linear_velocity=[4.0, 0, 1.2])
    return sim, run(srv, sim, SECONDS)


def pile(srv):
    """1,000 boxes on a 10×10×10 grid, 0.36 m apart (more than a box's diagonal) from z = 0.5,
    jittered and turned every way by a seeded generator, so they land on edges and corners and
    tumble into a heap rather than settling as columns."""
    sim = new_sim(srv, "pile")
    rng = random.Random(27)
    calls = []
    for k in range(10):
        for j in range(10):
            for i in range(10):
                pos = [(i - 4.5) * 0.36 + rng.uniform(-0.03, 0.03), (j - 4.5) * 0.36 + rng.uniform(-0.03, 0.03),
                       0.5 + k * 0.36]
                calls.append({"tool": "add_box", "arguments": {
                    "dimensions": [0.1, 0.1, 0.1], "position": [round(x, 4) for x in pos], "mass": 1.0,
                    "orientation": random_quaternion(rng), "color": COLOURS[(i + j + k) % len(COLOURS)]}})
    t0 = time.perf_counter()
    for at in range(0, len(calls), 250):
        srv.call("batch", sim_id=sim, calls=calls[at:at + 250])
    print(f"  added {len(calls)} boxes in {len(calls) // 250} batch calls, {time.perf_counter() - t0:.1f} s", flush=True)
    return sim, run(srv, sim, SECONDS)


def random_quaternion(rng):
    """A uniformly random turn, [x, y, z, w] (Shoemake)."""
    u1, u2, u3 = rng.random(), rng.random(), rng.random()
    a, b = math.sqrt(1 - u1), math.sqrt(u1)
    q = [a * math.sin(2 * math.pi * u2), a * math.cos(2 * math.pi * u2), b * math.sin(2 * math.pi * u3),
         b * math.cos(2 * math.pi * u3)]
    return [round(x, 6) for x in q]


def arm(srv):
    sim = new_sim(srv, "arm")
    robot = srv.call("load_urdf", sim_id=sim, file_path="iiwa14.urdf", position=[0, 0, 0],
                     use_fixed_base=True)["object_id"]
    targets = {0: 0.8, 1: 0.7, 3: -1.2}  # base turn, shoulder forward, elbow bent: reaching forward and down
    for joint, target in targets.items():
        srv.call("set_joint_motor_control", sim_id=sim, object_id=robot, joint_index=joint,
                 control_mode="POSITION_CONTROL", target_position=target)
    n = run(srv, sim, SECONDS)
    reached = []
    for joint, target in targets.items():
        st = srv.call("get_joint_state", sim_id=sim, object_id=robot, joint_index=joint)
        pos = st.get("position", st.get("joint_position"))
        reached.append(f"joint {joint}: {pos:.2f} (target {target})" if isinstance(pos, (int, float)) else f"joint {joint}: {st}")
    print("  " + "; ".join(reached), flush=True)
    return sim, n


def still(srv, sim, name, ws, out, max_bytes):
    w, h = PNG_SIZE
    args = {"sim_id": sim, "width": w, "height": h}
    if srv.declares("get_camera_image", "output_path"):
        args["output_path"] = f"{name}.png"
        srv.call("get_camera_image", **args)
        shutil.copyfile(ws / f"{name}.png", out / f"{name}.png")
    else:
        write_inline(srv.raw("get_camera_image", args), "get_camera_image", out / f"{name}.png")
    size = (out / f"{name}.png").stat().st_size
    print(f"  {name}.png {w}×{h}: {size / 1024:.1f} KB", flush=True)
    if size > max_bytes:
        raise SystemExit(f"{name}.png is {size} bytes, over {max_bytes}")


def write_inline(result, tool, path):
    if result.get("isError"):
        raise SystemExit(f"{tool} refused: {refusal(result)}")
    images = [c for c in result.get("content", []) if c.get("type") == "image"]
    if not images:
        raise SystemExit(f"{tool}: no image in the reply")
    path.write_bytes(base64.b64decode(images[0]["data"]))


def animation(srv, sim, name, steps, ws, out, max_bytes):
    """render_animation at the defaults but 320×240; over max_bytes (or refused as too large): a
    larger every (fewer frames), or, once every covers the run or is not a parameter, smaller."""
    w, h = GIF_SIZE
    every = None  # the server's default first
    for attempt in range(1, 12):
        args = {"sim_id": sim, "width": w, "height": h}
        if every is not None:
            args["every"] = every
        file = f"{name}.{attempt}.gif"
        to_file = srv.declares("render_animation", "output_path")
        if to_file:
            args["output_path"] = file
        t0 = time.perf_counter()
        result = srv.raw("render_animation", args)
        secs = time.perf_counter() - t0
        meta = result.get("structuredContent") or {}
        if result.get("isError"):
            text = refusal(result)
            print(f"  render_animation {w}×{h} every={every or 'default'} refused: {text}", flush=True)
            if not any(word in text for word in ("every", "smaller", "too large", "budget", "bytes")):
                raise SystemExit("render_animation refused, and not for the size of the reply")
            size = None
        else:
            if to_file:
                shutil.copyfile(ws / file, out / f"{name}.gif")
            else:
                write_inline(result, "render_animation", out / f"{name}.gif")
            size = (out / f"{name}.gif").stat().st_size
            if meta.get("steps") not in (None, steps):
                print(f"  note: the animation covers {meta.get('steps')} steps, not the run's {steps}", flush=True)
            print(f"  {name}.gif {meta.get('width', w)}×{meta.get('height', h)}, every {meta.get('every', every)}, "
                  f"{meta.get('frames', '?')} frames at {meta.get('fps', '?')} fps: {size / 1024:.1f} KB "
                  f"(rendered in {secs:.1f} s)", flush=True)
            if size <= max_bytes:
                return
        used = meta.get("every") or every or max(1, steps // 100)
        if srv.declares("render_animation", "every") and used < steps:
            # Frames in proportion to the size over the limit, with a margin; twice as few on a refusal.
            every = max(used + 1, math.ceil(used * size / max_bytes * 1.1)) if size else used * 2
        else:
            w, h = w * 3 // 4, h * 3 // 4
        print(f"  too large: trying again with every={every or 'default'}, {w}×{h}", flush=True)
    raise SystemExit(f"{name}.gif: could not get it within {max_bytes} bytes")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", default=str(ROOT / os.environ.get("CARGO_TARGET_DIR", "target") / "release" / "physics-mcp"))
    ap.add_argument("--out", required=True, help="directory for NAME.png and NAME.gif (made if missing)")
    ap.add_argument("--max-kb", type=int, default=300, help="largest file allowed (KB, 1024 bytes)")
    ap.add_argument("--scenes", default="tower,pile,arm", help="comma-separated subset")
    a = ap.parse_args()
    if not os.access(a.bin, os.X_OK):
        raise SystemExit(f"no server binary at {a.bin}: cargo build --release --locked (or --bin)")
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    scenes = {"tower": tower, "pile": pile, "arm": arm}
    t_all = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        ws = pathlib.Path(tmp) / "ws"
        ws.mkdir()
        shutil.copyfile(ROOT / "tests" / "fixtures" / "iiwa14.urdf", ws / "iiwa14.urdf")
        proc, hostport = start(a.bin, {}, tmp)
        try:
            s = Session(hostport)
            info = s.open("pictures")
            print(f"server {a.bin} ({info.get('serverInfo', {}).get('version', '?')}) on {hostport}", flush=True)
            srv = Server(s)
            for name in a.scenes.split(","):
                print(f"{name}:", flush=True)
                t0 = time.perf_counter()
                sim, steps = scenes[name](srv)
                still(srv, sim, name, ws, out, a.max_kb * 1024)
                animation(srv, sim, name, steps, ws, out, a.max_kb * 1024)
                srv.call("destroy_simulation", sim_id=sim)
                print(f"  {name} done in {time.perf_counter() - t0:.1f} s", flush=True)
        finally:
            proc.terminate()
            proc.wait()
    print(f"wrote {out}/ in {time.perf_counter() - t_all:.1f} s:")
    for f in sorted(out.iterdir()):
        print(f"  {f.name:12s} {f.stat().st_size:8d} bytes")


if __name__ == "__main__":
    main()
