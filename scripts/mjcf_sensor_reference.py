"""Writes tests/reference/mjcf_sensors.json: MuJoCo's own sensordata for the hand-written
tests/fixtures/mjcf/sensor_arm.xml (a fixed-base arm with one sensor of each type
get_sensor_data computes), what get_sensor_data must reproduce (tests/physics/mjcf_sensors.rs).

- `poses`: the joints set to fixed positions and velocities (qpos, qvel in MuJoCo's joint
  order), then mj_forward: every position- and velocity-stage sensor (jointpos … subtreecom);
  and mj_inverse with qacc = 0 for the acceleration-stage ones (accelerometer, force, torque,
  actuatorfrc): get_sensor_data computes those at zero joint acceleration (docs/tools.md).
- `run`: from qpos0 at rest, the controls held for `steps` steps at the model's timestep, then
  every sensor after mj_forward (the trajectory is the engine's, so looser).

Dev-only (mujoco is not a dependency): /tmp/pb/bin/python scripts/mjcf_sensor_reference.py
(or python -m venv /tmp/mj && /tmp/mj/bin/pip install mujoco && /tmp/mj/bin/python …).
"""
import json
import os

import mujoco
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
MODEL = os.path.join(HERE, "..", "tests", "fixtures", "mjcf", "sensor_arm.xml")
OUT = os.path.join(HERE, "..", "tests", "reference", "mjcf_sensors.json")
POSES = [
    {"qpos": [0.0, 0.0, 0.0], "qvel": [0.0, 0.0, 0.0], "ctrl": [0.0, 0.0, 0.0]},
    {"qpos": [0.6, -0.4, 0.05], "qvel": [0.0, 0.0, 0.0], "ctrl": [0.3, 0.5, 0.1]},
    {"qpos": [-0.3, 1.1, -0.08], "qvel": [1.2, -0.7, 0.3], "ctrl": [-0.5, -0.2, 0.4]},
]
RUN = {"ctrl": [0.8, 0.4, 0.2], "steps": 150}
ACC_STAGE = {int(mujoco.mjtSensor.mjSENS_ACCELEROMETER), int(mujoco.mjtSensor.mjSENS_FORCE),
             int(mujoco.mjtSensor.mjSENS_TORQUE), int(mujoco.mjtSensor.mjSENS_ACTUATORFRC)}


def readings(m, d, stage_acc):
    out = {}
    for k in range(m.nsensor):
        if (int(m.sensor_type[k]) in ACC_STAGE) != stage_acc:
            continue
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SENSOR, k)
        a, n = m.sensor_adr[k], m.sensor_dim[k]
        out[name] = [float(x) for x in d.sensordata[a:a + n]]
    return out


def main():
    m = mujoco.MjModel.from_xml_path(MODEL)
    d = mujoco.MjData(m)
    poses = []
    for p in POSES:
        mujoco.mj_resetData(m, d)
        d.qpos[:] = p["qpos"]
        d.qvel[:] = p["qvel"]
        d.ctrl[:] = p["ctrl"]
        mujoco.mj_forward(m, d)
        kinematic = readings(m, d, False)
        d.qacc[:] = 0.0
        mujoco.mj_inverse(m, d)
        dynamic = readings(m, d, True)
        poses.append({**p, "sensors": {**kinematic, **dynamic}})
    mujoco.mj_resetData(m, d)
    d.ctrl[:] = RUN["ctrl"]
    for _ in range(RUN["steps"]):
        mujoco.mj_step(m, d)
    mujoco.mj_forward(m, d)
    run = {**RUN, "qpos": [float(x) for x in d.qpos], "sensors": readings(m, d, False)}
    meta = {"mujoco": mujoco.__version__, "script": "scripts/mjcf_sensor_reference.py", "model": "mjcf/sensor_arm.xml",
            "timestep": float(m.opt.timestep)}
    with open(OUT, "w") as f:
        json.dump({"meta": meta, "poses": poses, "run": run}, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
