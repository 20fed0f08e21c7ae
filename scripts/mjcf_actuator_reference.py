"""Writes tests/reference/mjcf_actuators.json: joint trajectories MuJoCo itself computes for
Gymnasium's fixed-base models (tests/fixtures/mjcf/, MIT, see LICENSE.gymnasium there) driven
through their own actuators by the same sinusoid controls — what load_mjcf's actuators and
set_actuator_controls must reproduce (tests/physics/mjcf_actuators.rs).

Per model: its timestep (the model's own `<option timestep>`), the number of steps (2 s;
inverted_double_pendulum 0.5 s: it is chaotic), and per actuator the control
u_k(t) = amplitude_k · sin(2π · frequency_k · t + phase_k) applied before the step taken at
t = k · timestep (held for that step, as data.ctrl is); then every joint's qpos (hinge/slide,
MuJoCo's order) after every `every`-th step. The models start at qpos0 with zero velocity.
actuator_mix is hand-written (tests/fixtures/mjcf/actuator_mix.xml: intvelocity, damper, general
affine and integrator actuators). `keyframes`: a model started at a `<key>` with that key's
`ctrl`, held (no control is set), and the same samples.

Dev-only (mujoco is not a dependency): /tmp/pb/bin/python scripts/mjcf_actuator_reference.py
(or python -m venv /tmp/mj && /tmp/mj/bin/pip install mujoco && /tmp/mj/bin/python …).
"""
import json
import math
import os

import mujoco

HERE = os.path.dirname(os.path.abspath(__file__))
FIXTURES = os.path.join(HERE, "..", "tests", "fixtures", "mjcf")
OUT = os.path.join(HERE, "..", "tests", "reference", "mjcf_actuators.json")
# (model, seconds, sample every n steps, amplitude as a fraction of the half control range:
# reacher's gear of 200 spins its 0.1 m arm past 15 rad in 2 s at half range, so it gets less)
MODELS = [("reacher", 2.0, 5, 0.05), ("pusher", 2.0, 5, 0.5), ("inverted_pendulum", 2.0, 2, 0.5),
          ("inverted_double_pendulum", 0.5, 1, 0.5), ("actuator_mix", 2.0, 5, 0.5)]
# (model, keyframe, seconds, sample every n steps)
KEYFRAMES = [("actuator_mix", "start", 1.0, 5)]


def controls(m, fraction):
    """`fraction` of each actuator's half control range (of 1 when unlimited), at 0.7 Hz,
    1.1 Hz, … with phases 0, 0.3, …"""
    out = []
    for k in range(m.nu):
        lo, hi = m.actuator_ctrlrange[k]
        half = fraction * (hi - lo) / 2 if m.actuator_ctrllimited[k] else fraction
        out.append({"amplitude": float(half), "frequency": 0.7 + 0.4 * k, "phase": 0.3 * k})
    return out


def main():
    refs = {}
    for name, seconds, every, fraction in MODELS:
        m = mujoco.MjModel.from_xml_path(os.path.join(FIXTURES, name + ".xml"))
        d = mujoco.MjData(m)
        dt = float(m.opt.timestep)
        steps = int(round(seconds / dt))
        sine = controls(m, fraction)
        joints = [j for j in range(m.njnt) if int(m.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))]
        samples = []
        for k in range(steps):
            t = k * dt
            d.ctrl[:] = [c["amplitude"] * math.sin(2 * math.pi * c["frequency"] * t + c["phase"]) for c in sine]
            mujoco.mj_step(m, d)
            if (k + 1) % every == 0:
                samples.append({"step": k + 1, "qpos": [float(d.qpos[m.jnt_qposadr[j]]) for j in joints]})
        refs[name] = {
            "timestep": dt,
            "steps": steps,
            "every": every,
            "joints": [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in joints],
            "controls": sine,
            "samples": samples,
        }
    held = {}
    for name, key, seconds, every in KEYFRAMES:
        m = mujoco.MjModel.from_xml_path(os.path.join(FIXTURES, name + ".xml"))
        d = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, d, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, key))
        dt = float(m.opt.timestep)
        steps = int(round(seconds / dt))
        joints = [j for j in range(m.njnt) if int(m.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))]
        samples = []
        for k in range(steps):
            mujoco.mj_step(m, d)
            if (k + 1) % every == 0:
                samples.append({"step": k + 1, "qpos": [float(d.qpos[m.jnt_qposadr[j]]) for j in joints]})
        held[name] = {"keyframe": key, "timestep": dt, "steps": steps, "every": every, "samples": samples}
    meta = {"mujoco": mujoco.__version__, "script": "scripts/mjcf_actuator_reference.py"}
    with open(OUT, "w") as f:
        json.dump({"meta": meta, "models": refs, "keyframes": held}, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
