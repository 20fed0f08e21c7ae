"""Writes tests/reference/mjcf_equality.json: joint trajectories MuJoCo itself computes for the
hand-written tests/fixtures/mjcf/equality_mix.xml (a parallelogram closed by <connect>, a
pendulum bent rigid by a <weld relpose>, the Panda's two fingers coupled by <equality><joint>
and driven through the fixed tendon "split" by one <general> actuator) — what load_mjcf's
equality constraints and tendon transmissions must reproduce (tests/physics/mjcf_equality.rs).

Started at the keyframe `start` (every constraint satisfied: the weld's joint t at its
relpose's 30 degrees, the parallelogram closed, the fingers closed), the gripper's control held at each `schedule` value for its steps, every
hinge/slide joint's qpos (MuJoCo's order) after every `every`-th step.

Dev-only (mujoco is not a dependency): /tmp/pb/bin/python scripts/mjcf_equality_reference.py
"""
import json
import os

import mujoco

HERE = os.path.dirname(os.path.abspath(__file__))
MODEL = os.path.join(HERE, "..", "tests", "fixtures", "mjcf", "equality_mix.xml")
OUT = os.path.join(HERE, "..", "tests", "reference", "mjcf_equality.json")
# (gripper control, steps at the model's 2 ms): open, close, half open
SCHEDULE = [(255.0, 250), (0.0, 250), (128.0, 250)]
EVERY = 5


def main():
    m = mujoco.MjModel.from_xml_path(MODEL)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "start"))
    joints = list(range(m.njnt))
    samples = []
    step = 0
    for u, n in SCHEDULE:
        d.ctrl[:] = [u]
        for _ in range(n):
            mujoco.mj_step(m, d)
            step += 1
            if step % EVERY == 0:
                samples.append({"step": step, "qpos": [float(d.qpos[m.jnt_qposadr[j]]) for j in joints]})
    out = {
        "mujoco": mujoco.__version__,
        "model": "equality_mix.xml",
        "keyframe": "start",
        "timestep": float(m.opt.timestep),
        "every": EVERY,
        "schedule": [{"ctrl": u, "steps": n} for u, n in SCHEDULE],
        "joints": [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in joints],
        "samples": samples,
    }
    with open(OUT, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")
    last = samples[-1]["qpos"]
    print("final qpos", [round(x, 4) for x in last])
    for s in samples[::25]:
        print(s["step"], [round(x, 4) for x in s["qpos"]])


if __name__ == "__main__":
    main()
