//! set_joint_trajectory: a joint's position motor follows a time-parameterised path as the
//! world steps. The path is a cubic Hermite spline: it starts at the joint's position at the
//! call (at rest), passes each waypoint at its time with the velocity given (else the
//! Catmull-Rom slope between its neighbours, 0 at the last), and holds the last waypoint.
//! Before each step the joint's motor is aimed at where the path is at the end of that step;
//! once the last waypoint's time is reached the trajectory ends and the motor holds it.
//!
//! State (`Tables::joint_trajectories`): hashed behind its own tag and snapshotted (version 9)
//! only when a trajectory is followed, so every world without one is as it always was.

use serde::{Deserialize, Serialize};

use super::World;
use crate::command::{ControlMode, MotorSpec};
use crate::value::Refusal;

/// One joint's path: waypoints after its start, and the motor settings that follow them.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct JointTrajectory {
    /// World time (s) of the call: waypoint times count from here.
    pub start_s: f64,
    /// The joint's position at the call: the path's first point (time 0, velocity 0).
    pub start_position: f64,
    /// Waypoint times (s after the call), strictly increasing, the first > 0.
    pub times: Vec<f64>,
    /// Waypoint positions (rad or m).
    pub positions: Vec<f64>,
    /// Waypoint velocities: given, or the Catmull-Rom slopes (0 at the last).
    pub velocities: Vec<f64>,
    /// The motor's maximum effort (None: the URDF's, else 500, as a motor's).
    pub force: Option<f32>,
    /// PyBullet's positionGain.
    pub position_gain: f32,
    /// PyBullet's velocityGain.
    pub velocity_gain: f32,
}

/// Where a followed trajectory is, for get_joint_state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrajectoryProgress {
    /// Seconds since the call.
    pub elapsed_s: f64,
    /// Seconds from the call to the last waypoint.
    pub duration_s: f64,
    /// Index of the next waypoint to reach.
    pub next_waypoint: usize,
}

impl JointTrajectory {
    /// The Catmull-Rom slope at each waypoint (the start counting as a waypoint at time 0),
    /// 0 at the last: what a trajectory without velocities passes its waypoints with.
    pub fn default_velocities(start: f64, times: &[f64], positions: &[f64]) -> Vec<f64> {
        let n = positions.len();
        (0..n)
            .map(|i| {
                if i + 1 == n {
                    return 0.0;
                }
                let (t0, q0) = if i == 0 { (0.0, start) } else { (times[i - 1], positions[i - 1]) };
                (positions[i + 1] - q0) / (times[i + 1] - t0)
            })
            .collect()
    }

    /// Seconds from the call to the last waypoint.
    pub fn duration(&self) -> f64 {
        self.times.last().copied().unwrap_or(0.0)
    }

    /// Position and velocity on the path `t` seconds after the call (the last waypoint, at
    /// rest, from its time on).
    pub fn sample(&self, t: f64) -> (f64, f64) {
        let n = self.times.len();
        if n == 0 || t >= self.times[n - 1] {
            return (self.positions.last().copied().unwrap_or(self.start_position), 0.0);
        }
        let t = t.max(0.0);
        let i = self.times.partition_point(|&ti| ti <= t);
        let (t0, q0, v0) = if i == 0 { (0.0, self.start_position, 0.0) } else { (self.times[i - 1], self.positions[i - 1], self.velocities[i - 1]) };
        let (t1, q1, v1) = (self.times[i], self.positions[i], self.velocities[i]);
        let h = t1 - t0;
        let s = (t - t0) / h;
        let (s2, s3) = (s * s, s * s * s);
        let q = (2.0 * s3 - 3.0 * s2 + 1.0) * q0 + (s3 - 2.0 * s2 + s) * h * v0 + (-2.0 * s3 + 3.0 * s2) * q1 + (s3 - s2) * h * v1;
        let v = (6.0 * s2 - 6.0 * s) * q0 / h + (3.0 * s2 - 4.0 * s + 1.0) * v0 + (-6.0 * s2 + 6.0 * s) * q1 / h + (3.0 * s2 - 2.0 * s) * v1;
        (q, v)
    }

    /// The position motor that aims at where the path is `t` seconds after the call.
    fn motor_at(&self, t: f64) -> MotorSpec {
        let (q, v) = self.sample(t);
        MotorSpec {
            mode: ControlMode::PositionControl,
            target_position: q as f32,
            target_velocity: v as f32,
            force: self.force,
            position_gain: self.position_gain,
            velocity_gain: self.velocity_gain,
        }
    }
}

/// A trajectory for several joints of one robot, as set_joint_trajectory gives it (checked by
/// `World::check_trajectory`).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct TrajectorySpec {
    /// The movable joints that follow it (PyBullet indices, no repeats).
    pub joint_indices: Vec<u32>,
    /// Waypoint times (s after the call), strictly increasing, the first > 0.
    pub times: Vec<f64>,
    /// Per waypoint, one position per joint.
    pub positions: Vec<Vec<f64>>,
    /// Per waypoint, one velocity per joint (None: Catmull-Rom slopes, 0 at the last).
    pub velocities: Option<Vec<Vec<f64>>>,
    /// Per joint, the maximum effort.
    pub forces: Option<Vec<f32>>,
    /// Per joint, PyBullet's positionGain.
    pub position_gains: Option<Vec<f32>>,
    /// Per joint, PyBullet's velocityGain.
    pub velocity_gains: Option<Vec<f32>>,
}

/// Default positionGain and velocityGain of a trajectory's motors (PyBullet's motor defaults).
const DEFAULT_GAINS: (f32, f32) = (0.1, 1.0);

impl World {
    /// Refuses a trajectory whose joints do not move, repeat, or whose lists do not fit.
    pub fn check_trajectory(&self, id: u32, spec: &TrajectorySpec) -> Result<(), Refusal> {
        let n = spec.joint_indices.len();
        if n == 0 {
            return Err("joint_indices must name at least one joint; got []".into());
        }
        let mut seen = std::collections::BTreeSet::new();
        for &j in &spec.joint_indices {
            let i = self.check_joint(id, j as i64)?;
            if let Some(spec) = self.robot(id).map(|r| &r.links[i].joint).filter(|s| !s.kind.movable()) {
                return Err(match spec.kind {
                    super::urdf::JointKind::Spherical => format!("joint_indices: joint {j} is a ball joint; only hinge and slide joints follow a trajectory"),
                    _ => format!("joint_indices: joint {j} is fixed; only movable joints follow a trajectory"),
                });
            }
            if !seen.insert(j) {
                return Err(format!("joint_indices names joint {j} twice"));
            }
        }
        if spec.times.is_empty() {
            return Err("times must hold at least one waypoint time; got []".into());
        }
        if spec.times[0] <= 0.0 || spec.times.windows(2).any(|w| w[1] <= w[0]) {
            return Err(format!("times must be strictly increasing seconds after the call, the first > 0; got {:?}", spec.times));
        }
        let m = spec.times.len();
        let table = |name: &str, rows: &[Vec<f64>]| -> Result<(), Refusal> {
            if rows.len() != m {
                return Err(format!("{name} must hold one row per time ({m}); got {}", rows.len()));
            }
            match rows.iter().position(|r| r.len() != n) {
                Some(k) => Err(format!("{name}[{k}] must hold one value per joint ({n}); got {}", rows[k].len())),
                None => Ok(()),
            }
        };
        table("positions", &spec.positions)?;
        if let Some(v) = &spec.velocities {
            table("velocities", v)?;
        }
        for (name, list) in [("forces", &spec.forces), ("position_gains", &spec.position_gains), ("velocity_gains", &spec.velocity_gains)] {
            if let Some(list) = list {
                if list.len() != n {
                    return Err(format!("{name} must hold one value per joint ({n}); got {}", list.len()));
                }
                if list.iter().any(|x| *x < 0.0) {
                    return Err(format!("{name} must be >= 0; got {list:?}"));
                }
            }
        }
        Ok(())
    }

    /// set_joint_trajectory: each joint follows its path from now on (replacing its motor and
    /// any trajectory it followed).
    pub(super) fn set_trajectory(&mut self, id: u32, spec: &TrajectorySpec) -> String {
        for (k, &j) in spec.joint_indices.iter().enumerate() {
            let Some(link) = self.robot(id).and_then(|r| r.links.get(j as usize)) else { continue };
            let (q, _) = self.joint_coordinates(link.body, link.joint.kind);
            let start = f64::from(q);
            let positions: Vec<f64> = spec.positions.iter().map(|row| row[k]).collect();
            let velocities = match &spec.velocities {
                Some(v) => v.iter().map(|row| row[k]).collect(),
                None => JointTrajectory::default_velocities(start, &spec.times, &positions),
            };
            let path = JointTrajectory {
                start_s: self.tables.time_s,
                start_position: start,
                times: spec.times.clone(),
                positions,
                velocities,
                force: spec.forces.as_ref().map(|f| f[k]),
                position_gain: spec.position_gains.as_ref().map_or(DEFAULT_GAINS.0, |g| g[k]),
                velocity_gain: spec.velocity_gains.as_ref().map_or(DEFAULT_GAINS.1, |g| g[k]),
            };
            self.set_motor(id, j, &path.motor_at(0.0));
            self.tables.joint_trajectories.insert((id, j), path);
        }
        let end = spec.times.last().copied().unwrap_or(0.0);
        format!("Joints {:?} of object {id} follow a trajectory of {} waypoints ending {end} s from now", spec.joint_indices, spec.times.len())
    }

    /// A motor call on a joint ends the trajectory it followed.
    pub(super) fn end_trajectory(&mut self, id: u32, joint_index: u32) {
        if !self.tables.joint_trajectories.is_empty() {
            self.tables.joint_trajectories.remove(&(id, joint_index));
        }
    }

    /// Before a step: aims each followed joint's motor at where its path is at the step's end;
    /// a path whose last waypoint that reaches ends (its motor holds the waypoint).
    pub(super) fn follow_trajectories(&mut self) {
        if self.tables.joint_trajectories.is_empty() {
            return;
        }
        let end_of_step = self.tables.time_s + f64::from(self.physics.integration_parameters.dt);
        // Taken out while the motors are set (a motor call ends a path: here it finds none),
        // kept in place otherwise — no map rebuilt per step.
        let mut paths = std::mem::take(&mut self.tables.joint_trajectories);
        paths.retain(|&(id, j), path| {
            let t = end_of_step - path.start_s;
            self.set_motor(id, j, &path.motor_at(t));
            t < path.duration()
        });
        self.tables.joint_trajectories = paths;
    }

    /// Where joint `joint_index` of `id` is on the trajectory it follows, if it follows one.
    pub fn trajectory_progress(&self, id: u32, joint_index: u32) -> Option<TrajectoryProgress> {
        let path = self.tables.joint_trajectories.get(&(id, joint_index))?;
        let elapsed_s = self.tables.time_s - path.start_s;
        Some(TrajectoryProgress {
            elapsed_s,
            duration_s: path.duration(),
            next_waypoint: path.times.partition_point(|&t| t <= elapsed_s),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn path(velocities: Option<Vec<f64>>) -> JointTrajectory {
        let (times, positions) = (vec![1.0, 2.0, 4.0], vec![1.0, -1.0, 0.5]);
        let velocities = velocities.unwrap_or_else(|| JointTrajectory::default_velocities(0.0, &times, &positions));
        JointTrajectory { start_s: 0.0, start_position: 0.0, times, positions, velocities, force: None, position_gain: 0.1, velocity_gain: 1.0 }
    }

    /// The path passes every waypoint at its time with its velocity, starts at rest, and holds
    /// the last waypoint.
    #[test]
    fn passes_waypoints_with_their_velocities() {
        let p = path(None);
        assert_eq!(p.velocities, vec![-0.5, -0.5 / 3.0, 0.0]);
        assert_eq!(p.sample(0.0), (0.0, 0.0));
        for (k, t) in p.times.iter().enumerate() {
            let (q, v) = p.sample(*t - 1e-12);
            assert!((q - p.positions[k]).abs() < 1e-9 && (v - p.velocities[k]).abs() < 1e-9, "waypoint {k}: {q} {v}");
        }
        assert_eq!(p.sample(9.0), (0.5, 0.0));
        let given = path(Some(vec![2.0, 0.0, 0.0]));
        let (_, v) = given.sample(1.0 - 1e-12);
        assert!((v - 2.0).abs() < 1e-9);
    }
}
