//! Inverse kinematics on a robot's URDF joint chain, in f64, independent of rapier.
//!
//! Damped least squares (Levenberg–Marquardt: the damping shrinks after an improving step and
//! grows after a rejected one), every step clamped to the joint limits, so the answer is always
//! within limits. It starts from the given configuration (rest poses, else the current one);
//! when that does not converge it restarts from configurations drawn by a generator seeded with
//! the query itself, so the same inputs always give the same answer. The target frame is the
//! end-effector link's URDF frame (its parent joint's frame), not its centre of mass.

use rapier3d::glamx::{DQuat, DVec3};

use super::urdf::{JointKind, JointSpec};

/// Iterations per attempt.
pub const MAX_ITERS: usize = 100;
/// Attempts after the first (deterministic restarts).
pub const RESTARTS: usize = 40;
/// Position error (m) under which a solution is accepted.
pub const TOL_POSITION: f64 = 1.0e-5;
/// Orientation error (rad) under which a solution is accepted.
pub const TOL_ORIENTATION: f64 = 1.0e-5;

/// A joint as the engine holds it: its frame in the parent link's frame and in the child
/// link's, the joint moving about (or along) that frame's x axis. An MJCF joint needs this —
/// its `pos` (the pivot) need not be its body's origin, and `ref` shifts its coordinate — where
/// a URDF joint's frame is its child link's frame.
#[derive(Clone, Copy, Debug)]
pub struct JointFrames {
    /// Joint frame in the parent link's frame: position, orientation.
    pub parent: (DVec3, DQuat),
    /// Joint frame in the child link's frame.
    pub child: (DVec3, DQuat),
}

/// One IK question.
pub struct IkQuery<'a> {
    /// Every joint of the robot, PyBullet order.
    pub joints: &'a [JointSpec],
    /// Per joint, the engine's frames (MJCF robots); None: the URDF frames of `joints`.
    pub frames: Option<&'a [JointFrames]>,
    /// World pose of the base link frame.
    pub base_pos: DVec3,
    /// World orientation of the base.
    pub base_rot: DQuat,
    /// The link whose frame must reach the target.
    pub end_effector: usize,
    /// Target position (world).
    pub target_pos: DVec3,
    /// Target orientation (world), if any.
    pub target_rot: Option<DQuat>,
    /// Lower limit per movable joint (lower > upper means unlimited).
    pub lower: Vec<f64>,
    /// Upper limit per movable joint.
    pub upper: Vec<f64>,
    /// Starting configuration, one value per movable joint.
    pub start: Vec<f64>,
}

/// One IK answer.
#[derive(Debug, Clone, PartialEq)]
pub struct IkAnswer {
    /// One value per movable joint, PyBullet order.
    pub q: Vec<f64>,
    /// Distance to the target position (m).
    pub position_error: f64,
    /// Angle to the target orientation (rad; 0 without one).
    pub orientation_error: f64,
    /// Iterations used, all attempts included.
    pub iterations: usize,
}

struct ChainJoint {
    spec: usize,
    movable: Option<usize>,
}

/// The chain from the base to `link`, each joint with its index among movable joints.
fn chain(joints: &[JointSpec], link: usize) -> Vec<ChainJoint> {
    let movable_index: Vec<Option<usize>> = {
        let mut n = 0;
        joints
            .iter()
            .map(|j| {
                j.kind.movable().then(|| {
                    n += 1;
                    n - 1
                })
            })
            .collect()
    };
    let mut out = Vec::new();
    let mut at = link as i32;
    while at >= 0 && (at as usize) < joints.len() && out.len() <= joints.len() {
        out.push(ChainJoint { spec: at as usize, movable: movable_index[at as usize] });
        at = joints[at as usize].parent;
    }
    out.reverse();
    out
}

/// The world pose of the end-effector frame, and per movable chain joint its world position
/// and axis (for the Jacobian).
fn forward(
    q: &IkQuery,
    path: &[ChainJoint],
    config: &[f64],
    axes: &mut Vec<(usize, JointKind, DVec3, DVec3)>,
) -> (DVec3, DQuat) {
    axes.clear();
    let (mut p, mut r) = (q.base_pos, q.base_rot);
    for c in path {
        let j = &q.joints[c.spec];
        if let Some(f) = q.frames.and_then(|f| f.get(c.spec)) {
            // parent link · joint frame · motion · (child's joint frame)⁻¹
            p += r * f.parent.0;
            r = (r * f.parent.1).normalize();
            if let Some(m) = c.movable {
                let world_axis = r * DVec3::X;
                axes.push((m, j.kind, p, world_axis));
                match j.kind {
                    JointKind::Prismatic => p += world_axis * config[m],
                    _ => r = (r * DQuat::from_axis_angle(DVec3::X, config[m])).normalize(),
                }
            }
            let inv = f.child.1.inverse();
            p += r * (inv * -f.child.0);
            r = (r * inv).normalize();
            continue;
        }
        p += r * DVec3::from_array(j.origin_pos);
        r = (r * DQuat::from_array(j.origin_rot)).normalize();
        let Some(m) = c.movable else { continue };
        let axis = DVec3::from_array(j.axis);
        let world_axis = r * axis;
        axes.push((m, j.kind, p, world_axis));
        match j.kind {
            JointKind::Prismatic => p += world_axis * config[m],
            _ => r = (r * DQuat::from_axis_angle(axis, config[m])).normalize(),
        }
    }
    (p, r)
}

fn rotation_error(target: DQuat, r: DQuat) -> DVec3 {
    let mut d = target * r.inverse();
    if d.w < 0.0 {
        d = -d;
    }
    d.to_scaled_axis()
}

fn errors(q: &IkQuery, p: DVec3, r: DQuat) -> (DVec3, DVec3) {
    let ep = q.target_pos - p;
    let er = q.target_rot.map_or(DVec3::ZERO, |t| rotation_error(t, r));
    (ep, er)
}

fn cost(ep: DVec3, er: DVec3) -> f64 {
    ep.length_squared() + er.length_squared()
}

fn clamp(q: &IkQuery, config: &mut [f64]) {
    for (m, v) in config.iter_mut().enumerate() {
        let (lo, hi) = (q.lower[m], q.upper[m]);
        if lo <= hi {
            *v = v.clamp(lo, hi);
        }
    }
}

/// Solves `a · x = b` for a small dense system (Gaussian elimination, partial pivoting).
fn solve_small(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for col in 0..n {
        let pivot = (col..n).max_by(|x, y| a[*x][col].abs().total_cmp(&a[*y][col].abs()))?;
        if a[pivot][col].abs() < 1e-14 {
            return None;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        let pivot_row = a[col].clone();
        for row in col + 1..n {
            let f = a[row][col] / pivot_row[col];
            for (x, p) in a[row][col..].iter_mut().zip(&pivot_row[col..]) {
                *x -= f * p;
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = vec![0.0; n];
    for row in (0..n).rev() {
        let s: f64 = (row + 1..n).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    Some(x)
}

/// One damped-least-squares run from `config`; returns (config, cost, iterations).
fn attempt(q: &IkQuery, path: &[ChainJoint], mut config: Vec<f64>) -> (Vec<f64>, f64, usize) {
    let rows = if q.target_rot.is_some() { 6 } else { 3 };
    let mut axes = Vec::new();
    let mut lambda = 1.0e-2;
    clamp(q, &mut config);
    let (p, r) = forward(q, path, &config, &mut axes);
    let (mut ep, mut er) = errors(q, p, r);
    let mut best = cost(ep, er);
    let mut iters = 0;
    while iters < MAX_ITERS {
        if ep.length() < TOL_POSITION && er.length() < TOL_ORIENTATION {
            break;
        }
        iters += 1;
        // Jacobian columns of the movable chain joints, at the current end-effector point.
        let pe = q.target_pos - ep;
        let cols: Vec<(usize, [f64; 6])> = axes
            .iter()
            .map(|&(m, kind, pj, z)| {
                let (lin, ang) = match kind {
                    JointKind::Prismatic => (z, DVec3::ZERO),
                    _ => (z.cross(pe - pj), z),
                };
                (m, [lin.x, lin.y, lin.z, ang.x, ang.y, ang.z])
            })
            .collect();
        let e = [ep.x, ep.y, ep.z, er.x, er.y, er.z];
        let mut jjt = vec![vec![0.0; rows]; rows];
        for (i, row) in jjt.iter_mut().enumerate() {
            for (k, v) in row.iter_mut().enumerate() {
                *v = cols.iter().map(|(_, c)| c[i] * c[k]).sum::<f64>() + if i == k { lambda * lambda } else { 0.0 };
            }
        }
        let Some(y) = solve_small(jjt, e[..rows].to_vec()) else { break };
        let mut next = config.clone();
        for (m, c) in &cols {
            next[*m] += (0..rows).map(|i| c[i] * y[i]).sum::<f64>();
        }
        clamp(q, &mut next);
        let (p2, r2) = forward(q, path, &next, &mut axes);
        let (ep2, er2) = errors(q, p2, r2);
        let c2 = cost(ep2, er2);
        if c2 < best {
            config = next;
            best = c2;
            ep = ep2;
            er = er2;
            lambda = (lambda * 0.5).max(1.0e-6);
        } else {
            lambda *= 4.0;
            // Restore the Jacobian axes of the accepted configuration.
            forward(q, path, &config, &mut axes);
            if lambda > 1.0e3 {
                break;
            }
        }
    }
    (config, best, iters)
}

/// A deterministic generator (SplitMix64) for restart configurations.
struct SplitMix(u64);

impl SplitMix {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn seed(q: &IkQuery) -> u64 {
    let mut h = blake3::Hasher::new();
    for x in q.target_pos.to_array().iter().chain(q.start.iter()).chain(q.lower.iter()).chain(q.upper.iter()) {
        h.update(&x.to_bits().to_le_bytes());
    }
    if let Some(r) = q.target_rot {
        for x in r.to_array() {
            h.update(&x.to_bits().to_le_bytes());
        }
    }
    h.update(&(q.end_effector as u64).to_le_bytes());
    let bytes = h.finalize();
    let mut b = [0u8; 8];
    b.copy_from_slice(&bytes.as_bytes()[..8]);
    u64::from_le_bytes(b)
}

/// Solves the query. Always returns a configuration within limits: the best one found.
pub fn solve(q: &IkQuery) -> IkAnswer {
    let path = chain(q.joints, q.end_effector);
    let converged = |c: f64| c.sqrt() < TOL_POSITION.min(TOL_ORIENTATION);
    let (mut best_q, mut best_c, mut total) = attempt(q, &path, q.start.clone());
    let mut rng = SplitMix(seed(q));
    let mut restarts = 0;
    while !converged(best_c) && restarts < RESTARTS {
        restarts += 1;
        let start: Vec<f64> = (0..q.start.len())
            .map(|m| {
                let (lo, hi) = (q.lower[m], q.upper[m]);
                let u = rng.next_f64();
                if lo <= hi {
                    lo + (hi - lo) * u
                } else {
                    (u * 2.0 - 1.0) * std::f64::consts::PI
                }
            })
            .collect();
        let (c, cost, it) = attempt(q, &path, start);
        total += it;
        if cost < best_c {
            best_q = c;
            best_c = cost;
        }
    }
    let mut axes = Vec::new();
    let (p, r) = forward(q, &path, &best_q, &mut axes);
    let (ep, _) = errors(q, p, r);
    let orientation_error = q.target_rot.map_or(0.0, |t| rotation_error(t, r).length());
    IkAnswer {
        q: best_q,
        position_error: ep.length(),
        orientation_error,
        iterations: total,
    }
}

/// Forward kinematics of link `link` for a configuration (one value per movable joint): the
/// world position and orientation of its URDF frame. Tests and benchmarks draw IK targets
/// from it.
pub fn link_pose(
    joints: &[JointSpec],
    base_pos: DVec3,
    base_rot: DQuat,
    link: usize,
    config: &[f64],
) -> (DVec3, DQuat) {
    let q = IkQuery {
        joints,
        frames: None,
        base_pos,
        base_rot,
        end_effector: link,
        target_pos: DVec3::ZERO,
        target_rot: None,
        lower: Vec::new(),
        upper: Vec::new(),
        start: Vec::new(),
    };
    let path = chain(joints, link);
    let mut axes = Vec::new();
    forward(&q, &path, config, &mut axes)
}
