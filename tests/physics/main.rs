//! What the tools compute, against independent references (analytic physics, PyBullet, MuJoCo):
//! bodies and contacts, sensing, robots from URDF and MJCF (the built-in models too), joint
//! limits, inverse kinematics, values reported as set, and stepping on several threads bit for
//! bit.

#[path = "../common/mod.rs"]
mod common;

mod agent_calls;
mod builtins;
mod engine_rules;
mod geometry_reads;
mod ik;
mod joint_trajectory;
mod link_state;
mod measures;
mod mjcf;
mod mjcf_actuators;
mod mjcf_ball_pair;
mod mjcf_equality;
mod mjcf_sensors;
mod mjcf_touch;
mod mjcf_rest;
mod physical_facts;
mod robot_dynamics;
mod robots;
mod sensing;
mod threads;
mod threads_flag;
mod urdf_limits;
mod values_as_set;
