"""Writes tests/reference/mjcf_touch.json: MuJoCo's own `touch` readings for the hand-written
tests/fixtures/mjcf/touch_box.xml (a 1 kg box on a plane with touch sites over its bottom face,
its top face and one bottom corner), what get_sensor_data's `touch` must reproduce
(tests/physics/mjcf_touch.rs).

Per keyframe (`resting`: on the floor; `falling`: from 0.2 m above it), the sensors and the
box's height after each sampled step at the model's timestep.

Dev-only (mujoco is not a dependency): /tmp/pb/bin/python scripts/mjcf_touch_reference.py
"""
import json
import os

import mujoco

HERE = os.path.dirname(os.path.abspath(__file__))
MODEL = os.path.join(HERE, "..", "tests", "fixtures", "mjcf", "touch_box.xml")
OUT = os.path.join(HERE, "..", "tests", "reference", "mjcf_touch.json")
# steps at which to sample: in flight (50 = 0.1 s), just after landing, settled (500 = 1 s)
SAMPLES = [50, 250, 500]


def main():
    m = mujoco.MjModel.from_xml_path(MODEL)
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SENSOR, k) for k in range(m.nsensor)]
    out = {"mujoco": mujoco.__version__, "model": "touch_box.xml", "timestep": float(m.opt.timestep), "sensors": names, "keyframes": {}}
    for key in ["resting", "falling"]:
        d = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, d, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, key))
        samples = []
        for step in range(1, SAMPLES[-1] + 1):
            mujoco.mj_step(m, d)
            if step in SAMPLES:
                mujoco.mj_forward(m, d)
                samples.append({"step": step, "z": float(d.qpos[2]), "touch": [float(x) for x in d.sensordata]})
        out["keyframes"][key] = samples
        print(key, samples)
    with open(OUT, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
