"""Writes tests/reference/mjcf_ball_pair.json: MuJoCo's own trajectories for two hand-written
fixtures, what load_mjcf's ball joints and contact pairs (event version 9) must reproduce
(tests/physics/mjcf_ball_pair.rs):

- tests/fixtures/mjcf/ball_pendulum.xml from its `tilted` keyframe: the ball joint's quaternion
  (MuJoCo's qpos [w, x, y, z], written here as [x, y, z, w] as get_joint_state gives it) and
  angular velocity (qvel, child frame), and the hinge below it, at sampled steps.
- tests/fixtures/mjcf/pair_slide.xml: a box sent along x at 2 m/s on a plane whose pair friction
  (0.2) differs from both geoms' (1): its x and x-velocity at sampled steps.

Dev-only (mujoco is not a dependency): /tmp/pb/bin/python scripts/mjcf_ball_pair_reference.py
"""
import json
import os

import mujoco

HERE = os.path.dirname(os.path.abspath(__file__))
FIXTURES = os.path.join(HERE, "..", "tests", "fixtures", "mjcf")
OUT = os.path.join(HERE, "..", "tests", "reference", "mjcf_ball_pair.json")
BALL_SAMPLES = [50, 100, 200, 300, 400, 500]
SLIDE_SAMPLES = [50, 150, 250, 400, 600, 750]


def ball():
    m = mujoco.MjModel.from_xml_path(os.path.join(FIXTURES, "ball_pendulum.xml"))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "tilted"))
    mujoco.mj_forward(m, d)
    samples = []
    for step in range(1, BALL_SAMPLES[-1] + 1):
        mujoco.mj_step(m, d)
        if step in BALL_SAMPLES:
            w, x, y, z = (float(v) for v in d.qpos[0:4])
            samples.append({
                "step": step,
                "ball_xyzw": [x, y, z, w],
                "ball_angvel": [float(v) for v in d.qvel[0:3]],
                "hinge": float(d.qpos[4]),
                "hinge_vel": float(d.qvel[3]),
            })
    return {"timestep": float(m.opt.timestep), "keyframe": "tilted", "samples": samples}


def slide():
    m = mujoco.MjModel.from_xml_path(os.path.join(FIXTURES, "pair_slide.xml"))
    d = mujoco.MjData(m)
    # Let the box settle on the floor for 0.1 s, then send it along x.
    for _ in range(50):
        mujoco.mj_step(m, d)
    settled_z = float(d.qpos[2])
    d.qvel[:] = 0
    d.qvel[0] = 2.0
    samples = []
    for step in range(1, SLIDE_SAMPLES[-1] + 1):
        mujoco.mj_step(m, d)
        if step in SLIDE_SAMPLES:
            samples.append({"step": step, "x": float(d.qpos[0]), "vx": float(d.qvel[0])})
    return {"timestep": float(m.opt.timestep), "settle_steps": 50, "settled_z": settled_z, "speed": 2.0, "pair_friction": float(m.pair_friction[0][0]), "samples": samples}


def main():
    out = {"mujoco": mujoco.__version__, "ball_pendulum": ball(), "pair_slide": slide()}
    with open(OUT, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
