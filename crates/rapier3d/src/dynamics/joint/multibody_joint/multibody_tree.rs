//! Tree-sparse joint-space dynamics of a [`Multibody`] ([`MultibodyDynamics::TreeSparse`]).
//!
//! The same equations as the dense path of `multibody.rs` (rapier 0.36.1's), computed over the
//! structure of the tree instead of full-width matrices:
//! - a link's body jacobian is non-zero only in the columns of its own degrees of freedom and
//!   its ancestors': it is kept compact (6 × that many columns), and so are the coriolis terms;
//! - the mass matrix `M = Σ Jᵀ·diag(m, I)·J` and the gyroscopic/coriolis-augmented matrix used for
//!   the free accelerations are accumulated per link over those columns only (a symmetric half
//!   for `M`), skipping links without mass;
//! - both have the tree's sparsity (`M[i][j] ≠ 0` only when one degree of freedom is an
//!   ancestor of the other), which an elimination from the leaves up keeps without fill-in
//!   (Featherstone, *Rigid Body Dynamics Algorithms*, §6.5): `M = Lᵀ·D·L` and the augmented
//!   matrix `U·D·L`, no pivoting, no allocation once sized;
//! - every solve with `M` (free accelerations' fallback, contact and joint constraint
//!   jacobians, limits, motors, couplings) uses that one factorisation per substep, in
//!   `O(ndofs · depth)`, and a unit or single-link right-hand side only walks its chain on the
//!   way up.
//!
//! The results differ from the dense path's in the last bits (other summation orders, no
//! pivoting), so a simulation chooses one path for its life through
//! [`IntegrationParameters::multibody_dynamics`](crate::dynamics::IntegrationParameters).
//! Everything here is a per-step workspace: it is rebuilt from the multibody's state before it
//! is read in a step and is never serialized, so snapshots keep the dense path's form. The
//! mass matrix `M` (with its damping, armature and spring diagonal) is also written, in natural
//! degree-of-freedom order, to the serialized `augmented_mass`, for readers after the step.
//!
//! Arithmetic is plain scalar `f32` in a fixed order (no `mul_add`, no BLAS kernels chosen at
//! run time), so the bits do not depend on the machine's instruction set.

use super::{Multibody, NONE_DOF};
use crate::alloc_prelude::*;
use crate::dynamics::{RigidBodySet, RigidBodyVelocity};
use crate::math::{AngularInertia, DIM, Real, Rotation, SPATIAL_DIM, Vector};
use crate::utils::RotationOps;
use parry::math::VectorExt;

/// One column of a compact body jacobian (or of its coriolis term): the linear and angular
/// velocity of a link's centre of mass per unit velocity of one degree of freedom.
#[derive(Copy, Clone, Debug, Default)]
pub(super) struct Col {
    pub v: Vector,
    pub w: Vector,
}

impl Col {
    #[inline]
    fn dot(&self, other: &Col) -> Real {
        self.v.dot(other.v) + self.w.dot(other.w)
    }
}

/// The tree-sparse path's per-step workspace (see the module doc). Never serialized.
#[derive(Clone, Debug, Default)]
pub(crate) struct TreeWorkspace {
    /// Whether this multibody's last dynamics update ran this path, so its solves are current.
    pub active: bool,
    /// Each degree of freedom's parent in the tree of degrees of freedom: the previous one of
    /// its link, else the last one of its nearest ancestor link that has any (`NONE_DOF`).
    parent_dof: Vec<u32>,
    /// Whether each degree of freedom belongs to a kinematic joint (never moved by dynamics).
    kinematic: Vec<bool>,
    any_kinematic: bool,
    /// For each link, the last degree of freedom of itself or its nearest ancestor with any:
    /// the bottom of the chain its jacobian's columns form (`NONE_DOF`: no column).
    chain_end: Vec<u32>,
    /// Link `l`'s columns are `cols[link_cols[l]..link_cols[l + 1]]`: its ancestors' degrees of
    /// freedom and its own, ascending (a parent's columns are a prefix of its child's).
    link_cols: Vec<usize>,
    cols: Vec<u32>,
    /// The compact body jacobians, parallel to `cols`.
    jac: Vec<Col>,
    /// The compact coriolis terms, parallel to `cols`.
    cor: Vec<Col>,
    /// Each degree of freedom's raw joint jacobian column (world orientation, before the shift
    /// to the centre of mass), by degree of freedom.
    joint_cols: Vec<Col>,
    /// Each link's effective mass and angular inertia this substep.
    masses: Vec<Vector>,
    inertias: Vec<AngularInertia>,
    /// `M`'s `Lᵀ·D·L` factor, row-major `ndofs × ndofs` (only the tree's pattern is read), and
    /// the inverse pivots.
    mass_factor: Vec<Real>,
    mass_inv_pivots: Vec<Real>,
    /// The augmented matrix's `U·D·L` factor, row-major (both halves of the pattern), and its
    /// inverse pivots; `acc_factor_ok` is false when a pivot vanished (`M` is used instead).
    acc_factor: Vec<Real>,
    acc_inv_pivots: Vec<Real>,
    acc_factor_ok: bool,
    /// Scratch: per-column products for one link.
    scratch_a: Vec<Col>,
    scratch_b: Vec<Col>,
    /// Scratch: generalized forces (all, and those from positions and inputs only) for the
    /// energy guard, and vectors for its products.
    gen_forces: Vec<Real>,
    pos_forces: Vec<Real>,
    scratch_x: Vec<Real>,
    scratch_y: Vec<Real>,
    /// physics-mcp patch 3: `M⁻¹·e_k` for the degrees of freedom `k` with a limit, a motor or dry
    /// friction, row `k` of `unit_responses` (`unit_ready[k]`), computed with each per-step
    /// factorisation: every substep's joint constraints copy them instead of solving again
    /// (the same solve of the same vector, so the same bits). Empty under the other paths.
    unit_responses: Vec<Real>,
    unit_ready: Vec<bool>,
    /// Tests only: a deliberately wrong rule (the mass matrix and factorisations of the first
    /// dynamics update kept for every later step), which the per-step path's tolerance must
    /// catch (multibody_per_step_tests.rs).
    #[cfg(test)]
    pub mass_frozen_for_tests: bool,
}

/// Resizes `v` to `n` entries, all `value` (no allocation once large enough).
#[inline]
fn reset<T: Copy>(v: &mut Vec<T>, n: usize, value: T) {
    v.clear();
    v.resize(n, value);
}

impl TreeWorkspace {
    #[inline]
    fn link_range(&self, link: usize) -> core::ops::Range<usize> {
        self.link_cols[link]..self.link_cols[link + 1]
    }

    /// [`Self::solve_acc`] for the tests that compare it with the dense path's.
    #[cfg(test)]
    pub(super) fn solve_acc_for_tests(&self, x: &mut [Real]) {
        self.solve_acc(x)
    }

    /// Solves `M·x = b` in place with the `Lᵀ·D·L` factor. `chain_end`: when `b` is zero
    /// outside the chain from this degree of freedom up to its root (a unit vector, one link's
    /// jacobian), the upward pass walks that chain only.
    pub(super) fn solve_mass(&self, x: &mut [Real], chain_end: Option<u32>) {
        solve(&self.parent_dof, &self.mass_factor, &self.mass_inv_pivots, &self.kinematic, self.any_kinematic, x, chain_end);
    }

    /// Solves the augmented system (free accelerations) in place, or `M·x = b` when its
    /// factorisation met a vanishing pivot.
    fn solve_acc(&self, x: &mut [Real]) {
        if self.acc_factor_ok {
            solve_unsymmetric(&self.parent_dof, &self.acc_factor, &self.acc_inv_pivots, &self.kinematic, self.any_kinematic, x);
        } else {
            self.solve_mass(x, None);
        }
    }
}

/// `Lᵀ·D·L` solve over the tree (Featherstone's Table 6.4): `factor[k·n + i]` holds `L[k][i]`
/// for `i` an ancestor of `k`.
fn solve(
    parent: &[u32],
    factor: &[Real],
    inv_pivots: &[Real],
    kinematic: &[bool],
    any_kinematic: bool,
    x: &mut [Real],
    chain_end: Option<u32>,
) {
    let n = parent.len();
    if any_kinematic {
        for (xi, k) in x.iter_mut().zip(kinematic) {
            if *k {
                *xi = 0.0;
            }
        }
    }
    // Lᵀ·y = b, from the leaves up: y_k is final once every descendant of k is done.
    let up = |k: usize, x: &mut [Real]| {
        let xk = x[k];
        if xk != 0.0 {
            let mut i = parent[k];
            while i != NONE_DOF {
                x[i as usize] -= factor[k * n + i as usize] * xk;
                i = parent[i as usize];
            }
        }
    };
    match chain_end {
        Some(end) => {
            let mut k = end;
            while k != NONE_DOF {
                up(k as usize, x);
                k = parent[k as usize];
            }
        }
        None => {
            for k in (0..n).rev() {
                up(k, x);
            }
        }
    }
    for (xi, d) in x.iter_mut().zip(inv_pivots) {
        *xi *= *d;
    }
    // L·x = z, from the root down.
    for k in 0..n {
        let mut sum = x[k];
        let mut i = parent[k];
        while i != NONE_DOF {
            sum -= factor[k * n + i as usize] * x[i as usize];
            i = parent[i as usize];
        }
        x[k] = sum;
    }
}

/// `U·D·L` solve over the tree: `factor[k·n + i]` holds `L[k][i]` and `factor[i·n + k]` holds
/// `U[i][k]`, for `i` an ancestor of `k`.
fn solve_unsymmetric(parent: &[u32], factor: &[Real], inv_pivots: &[Real], kinematic: &[bool], any_kinematic: bool, x: &mut [Real]) {
    let n = parent.len();
    if any_kinematic {
        for (xi, k) in x.iter_mut().zip(kinematic) {
            if *k {
                *xi = 0.0;
            }
        }
    }
    // U·y = b from the leaves up.
    for k in (0..n).rev() {
        let xk = x[k];
        if xk != 0.0 {
            let mut i = parent[k];
            while i != NONE_DOF {
                x[i as usize] -= factor[i as usize * n + k] * xk;
                i = parent[i as usize];
            }
        }
    }
    for (xi, d) in x.iter_mut().zip(inv_pivots) {
        *xi *= *d;
    }
    for k in 0..n {
        let mut sum = x[k];
        let mut i = parent[k];
        while i != NONE_DOF {
            sum -= factor[k * n + i as usize] * x[i as usize];
            i = parent[i as usize];
        }
        x[k] = sum;
    }
}

/// `1 / pivot`, or 0 for a pivot that vanished or is not finite (that degree of freedom then
/// does not respond, instead of poisoning the solve with infinities).
#[inline]
fn inv_pivot(pivot: Real) -> Real {
    if pivot != 0.0 && pivot.is_finite() { 1.0 / pivot } else { 0.0 }
}

/// The raw jacobian columns of `joint` (world orientation `rot`), as `MultibodyJoint::jacobian`
/// computes them, one per free degree of freedom, written to `out`.
fn joint_columns(joint: &super::MultibodyJoint, rot: &Rotation, out: &mut [Col]) {
    let locked_bits = joint.data.locked_axes.bits();
    let mut curr = 0;
    for i in 0..DIM {
        if (locked_bits & (1 << i)) == 0 {
            out[curr] = Col { v: *rot * Vector::ith(i, 1.0), w: Vector::ZERO };
            curr += 1;
        }
    }
    let locked_ang_bits = locked_bits >> DIM;
    let num_free_ang_dofs = 3 - locked_ang_bits.count_ones() as usize;
    match num_free_ang_dofs {
        0 => {}
        1 => {
            let dof_id = (!locked_ang_bits).trailing_zeros() as usize;
            let rotmat = rot.to_mat();
            out[curr] = Col { v: Vector::ZERO, w: rotmat.col(dof_id) };
        }
        2 => todo!(),
        3 => {
            let rotmat = rot.to_mat();
            for k in 0..3 {
                out[curr + k] = Col { v: Vector::ZERO, w: rotmat.col(k) };
            }
        }
        _ => unreachable!(),
    }
}

impl Multibody {
    /// Rebuilds the tree's structure (degrees of freedom's parents, each link's columns) from
    /// the links: cheap, and done with every forward kinematics so it always matches them.
    fn tree_structure(&mut self) {
        let t = &mut self.tree;
        let n = self.ndofs;
        reset(&mut t.parent_dof, n, NONE_DOF);
        reset(&mut t.kinematic, n, false);
        t.any_kinematic = false;
        t.chain_end.clear();
        t.link_cols.clear();
        t.cols.clear();
        for (l, link) in self.links.iter().enumerate() {
            t.link_cols.push(t.cols.len());
            let above = if l == 0 { NONE_DOF } else { t.chain_end[link.parent_internal_id] };
            if l != 0 {
                let p = link.parent_internal_id;
                let (from, to) = (t.link_cols[p], t.link_cols[p + 1]);
                t.cols.extend_from_within(from..to);
            }
            let (first, own) = (link.assembly_id, link.joint.ndofs());
            for d in 0..own {
                let dof = first + d;
                t.parent_dof[dof] = if d == 0 { above } else { (dof - 1) as u32 };
                t.kinematic[dof] = link.joint.kinematic;
                t.cols.push(dof as u32);
            }
            t.any_kinematic |= own > 0 && link.joint.kinematic;
            t.chain_end.push(if own > 0 { (first + own - 1) as u32 } else { above });
        }
        t.link_cols.push(t.cols.len());
    }

    /// The compact body jacobians (the tree path's `update_body_jacobians`), after the links'
    /// poses and shifts were updated by forward kinematics.
    pub(super) fn tree_update_jacobians(&mut self) {
        self.tree_structure();
        let t = &mut self.tree;
        reset(&mut t.jac, t.cols.len(), Col::default());
        reset(&mut t.joint_cols, self.ndofs, Col::default());
        for l in 0..self.links.len() {
            let link = &self.links[l];
            let range = t.link_range(l);
            let parent_rot;
            let mut inherited = 0;
            if l != 0 {
                let p = link.parent_internal_id;
                let parent_range = t.link_range(p);
                inherited = parent_range.len();
                parent_rot = self.links[p].local_to_world.rotation;
                for c in 0..inherited {
                    let pc = t.jac[parent_range.start + c];
                    t.jac[range.start + c] = Col { v: pc.v + pc.w.cross(link.shift02), w: pc.w };
                }
            } else {
                parent_rot = Rotation::IDENTITY;
            }
            let own = link.joint.ndofs();
            let (first, rot) = (link.assembly_id, parent_rot * link.joint.data.local_frame1.rotation);
            joint_columns(&link.joint, &rot, &mut t.joint_cols[first..first + own]);
            for d in 0..own {
                t.jac[range.start + inherited + d] = t.joint_cols[first + d];
            }
            for c in range {
                let col = &mut t.jac[c];
                col.v += col.w.cross(link.shift23);
            }
        }
    }

    /// One substep's mass matrices and their factorisations, then the free accelerations:
    /// the tree path's `update_mass_matrix` followed by `update_acceleration`.
    /// physics-mcp patch 2: whether the tree path may run this multibody. A link whose mass or
    /// inertia holds a subnormal or non-finite number (a 1e-40 inertia, found by the file
    /// fuzzer) overflowed the tree path's inverses and left its solver slicing out of bounds;
    /// such a multibody takes the release's dense path, kinematics and dynamics alike, which
    /// copes. A multibody of normal numbers (every real model) is unaffected.
    pub(crate) fn tree_eligible(&self, bodies: &RigidBodySet) -> bool {
        // physics-mcp patch 5: the same test without short-circuits (it runs with every forward
        // kinematics and dynamics update): zero, or normal and finite (NaN fails every comparison).
        let normal = |x: Real| {
            let a = x.abs();
            ((a >= Real::MIN_POSITIVE) & (a <= Real::MAX)) | (a == 0.0)
        };
        self.links.iter().all(|link| {
            let mp = &bodies[link.rigid_body].mprops;
            let (m, p) = (mp.local_mprops.inv_mass, mp.local_mprops.inv_principal_inertia);
            let e = mp.effective_inv_mass;
            normal(m) & normal(p.x) & normal(p.y) & normal(p.z) & normal(e.x) & normal(e.y) & normal(e.z)
        })
    }

    pub(crate) fn tree_update_dynamics(&mut self, dt: Real, bodies: &RigidBodySet) {
        self.tree.active = true;
        self.tree.unit_ready.clear();
        if self.ndofs == 0 {
            return;
        }
        self.tree_mass_matrices(dt, bodies);
        self.tree_factorize();
        self.tree_update_acceleration(dt, bodies);
    }

    /// physics-mcp patch 3 (`MultibodyDynamics::TreeSparsePerStep`): a later substep's free
    /// accelerations — each link's mass and world inertia read again (the links turned), the
    /// generalized forces of this substep's poses and velocities — solved with the factorisations
    /// of the step's first substep, which stay in place (`M` changes with the configuration,
    /// which moves by a fraction of a step between substeps).
    pub(crate) fn tree_update_substep_acceleration(&mut self, dt: Real, bodies: &RigidBodySet) {
        if self.ndofs == 0 {
            return;
        }
        let t = &mut self.tree;
        t.masses.clear();
        t.inertias.clear();
        for link in self.links.iter() {
            let mp = &bodies[link.rigid_body].mprops;
            t.masses.push(mp.effective_mass());
            t.inertias.push(mp.effective_angular_inertia());
        }
        self.tree_update_acceleration(dt, bodies);
    }

    /// Accumulates `M` (lower half, column-major into `augmented_mass`) and the augmented matrix
    /// (row-major into `tree.acc_factor`) over each link's columns, with the coriolis terms.
    fn tree_mass_matrices(&mut self, dt: Real, bodies: &RigidBodySet) {
        let n = self.ndofs;
        if self.augmented_mass.nrows() != n || self.augmented_mass.ncols() != n {
            self.augmented_mass = na::DMatrix::zeros(n, n);
        } else {
            // physics-mcp patch 5: the same zeros through a slice (nalgebra's `fill` iterates).
            self.augmented_mass.as_mut_slice().fill(0.0);
        }
        let t = &mut self.tree;
        reset(&mut t.acc_factor, n * n, 0.0);
        reset(&mut t.cor, t.cols.len(), Col::default());
        t.masses.clear();
        t.inertias.clear();
        let mass = self.augmented_mass.as_mut_slice();

        for l in 0..self.links.len() {
            let link = &self.links[l];
            let rb = &bodies[link.rigid_body];
            let m = rb.mprops.effective_mass();
            let inertia = rb.mprops.effective_angular_inertia();
            t.masses.push(m);
            t.inertias.push(inertia);
            let w = rb.vels.angvel;
            let range = t.link_range(l);

            // Coriolis terms (the dense path's `coriolis_v`/`coriolis_w`, column by column).
            if l != 0 {
                let p = link.parent_internal_id;
                let parent_range = t.link_range(p);
                let inherited = parent_range.len();
                let wp = bodies[self.links[p].rigid_body].vels.angvel;
                let (lin, ang) = (link.joint_velocity.linvel, link.joint_velocity.angvel);
                let dvel = w.cross(link.shift02) + lin * 2.0;
                for c in 0..inherited {
                    let pc = t.cor[parent_range.start + c];
                    let pjw = t.jac[parent_range.start + c].w;
                    let mut cv = pc.v + pc.w.cross(link.shift02);
                    cv += pjw.cross(dvel);
                    cv += pjw.cross(lin);
                    cv += wp.cross(pjw.cross(link.shift02));
                    let cw = pc.w - ang.cross(pjw);
                    t.cor[range.start + c] = Col { v: cv, w: cw };
                }
                if !link.joint.kinematic {
                    let first = link.assembly_id;
                    for d in 0..link.joint.ndofs() {
                        let jj = t.joint_cols[first + d];
                        t.cor[range.start + inherited + d] = Col { v: wp.cross(jj.v) * 2.0, w: wp.cross(jj.w) };
                    }
                }
            }
            let wxs = w.cross(link.shift23);
            for c in range.clone() {
                let jw = t.jac[c].w;
                let col = &mut t.cor[c];
                col.v += col.w.cross(link.shift23);
                col.v += jw.cross(wxs);
                col.v += w.cross(jw.cross(link.shift23));
            }

            // Mass contributions; a link without mass adds nothing.
            if m == Vector::ZERO && inertia.is_zero() {
                continue;
            }
            let iw = inertia.mul_vec(w);
            let mdt = m * dt;
            let s = range.len();
            reset(&mut t.scratch_a, s, Col::default());
            reset(&mut t.scratch_b, s, Col::default());
            for c in 0..s {
                let j = t.jac[range.start + c];
                let cor = t.cor[range.start + c];
                let i_jw = inertia.mul_vec(j.w);
                let gyro = w.cross(i_jw) - iw.cross(j.w);
                t.scratch_a[c] = Col { v: m * j.v, w: i_jw };
                t.scratch_b[c] = Col { v: m * j.v + mdt * cor.v, w: i_jw + gyro * dt + inertia.mul_vec(cor.w) * dt };
            }
            for r in 0..s {
                let jr = t.jac[range.start + r];
                let row = t.cols[range.start + r] as usize;
                for c in 0..s {
                    let col = t.cols[range.start + c] as usize;
                    if c <= r {
                        mass[col * n + row] += jr.dot(&t.scratch_a[c]);
                    }
                    t.acc_factor[row * n + col] += jr.dot(&t.scratch_b[c]);
                }
            }
        }

        // Damping and armature (`dt·d + a`), then implicit springs (`dt²·k`), on the diagonals.
        for i in 0..n {
            let diag = self.damping[i] * dt + self.armature[i];
            mass[i * n + i] += diag;
            t.acc_factor[i * n + i] += diag;
        }
        let dt2 = dt * dt;
        for link in self.links.iter() {
            let mut idx = link.assembly_id;
            let locked = link.joint.data.locked_axes.bits();
            for a in 0..SPATIAL_DIM {
                if (locked >> a) & 1 == 0 {
                    let k = link.joint.spring_stiffness[a];
                    if k != 0.0 {
                        let d = k * dt2;
                        mass[idx * n + idx] += d;
                        t.acc_factor[idx * n + idx] += d;
                    }
                    idx += 1;
                }
            }
        }

        // Kinematic degrees of freedom are out of the dynamics: identity rows and columns.
        if t.any_kinematic {
            for k in 0..n {
                if t.kinematic[k] {
                    for j in 0..n {
                        mass[j * n + k] = 0.0;
                        mass[k * n + j] = 0.0;
                        t.acc_factor[j * n + k] = 0.0;
                        t.acc_factor[k * n + j] = 0.0;
                    }
                    mass[k * n + k] = 1.0;
                    t.acc_factor[k * n + k] = 1.0;
                }
            }
        }

        // The upper half of `M` mirrors the lower one, so `augmented_mass` is all of it.
        for c in 0..n {
            for r in c + 1..n {
                mass[r * n + c] = mass[c * n + r];
            }
        }
    }

    /// Factorises `M` (`Lᵀ·D·L`) and the augmented matrix (`U·D·L`) from the leaves up, over
    /// the tree's pattern only (Featherstone's Table 6.3; no fill-in, no pivoting).
    fn tree_factorize(&mut self) {
        let n = self.ndofs;
        let t = &mut self.tree;
        let mass = self.augmented_mass.as_slice();

        // M: the lower pattern copied (row-major, row k: its ancestors and itself).
        reset(&mut t.mass_factor, n * n, 0.0);
        for k in 0..n {
            t.mass_factor[k * n + k] = mass[k * n + k];
            let mut i = t.parent_dof[k];
            while i != NONE_DOF {
                // M[k][i], k > i: column-major lower half at i·n + k.
                t.mass_factor[k * n + i as usize] = mass[i as usize * n + k];
                i = t.parent_dof[i as usize];
            }
        }
        reset(&mut t.mass_inv_pivots, n, 0.0);
        let f = &mut t.mass_factor;
        for k in (0..n).rev() {
            let inv = inv_pivot(f[k * n + k]);
            t.mass_inv_pivots[k] = inv;
            let mut i = t.parent_dof[k];
            while i != NONE_DOF {
                let iu = i as usize;
                let a = f[k * n + iu] * inv;
                let mut j = i;
                while j != NONE_DOF {
                    let ju = j as usize;
                    f[iu * n + ju] -= a * f[k * n + ju];
                    j = t.parent_dof[ju];
                }
                f[k * n + iu] = a;
                i = t.parent_dof[iu];
            }
        }

        // The augmented matrix: both halves, in place.
        reset(&mut t.acc_inv_pivots, n, 0.0);
        t.acc_factor_ok = true;
        let f = &mut t.acc_factor;
        for k in (0..n).rev() {
            let pivot = f[k * n + k];
            let inv = inv_pivot(pivot);
            t.acc_factor_ok &= inv != 0.0 || t.kinematic[k];
            t.acc_inv_pivots[k] = inv;
            // A[i][j] -= A[i][k]·A[k][j] / A[k][k] for every pair of ancestors i, j of k.
            let mut i = t.parent_dof[k];
            while i != NONE_DOF {
                let iu = i as usize;
                let u = f[iu * n + k] * inv;
                if u != 0.0 {
                    let mut j = t.parent_dof[k];
                    while j != NONE_DOF {
                        let ju = j as usize;
                        f[iu * n + ju] -= u * f[k * n + ju];
                        j = t.parent_dof[ju];
                    }
                }
                i = t.parent_dof[iu];
            }
            let mut i = t.parent_dof[k];
            while i != NONE_DOF {
                let iu = i as usize;
                f[iu * n + k] *= inv;
                f[k * n + iu] *= inv;
                i = t.parent_dof[iu];
            }
        }
    }

    /// The tree path's `update_acceleration`: the same generalized forces (each link's over its
    /// columns only) and energy guard, solved with the factorisations above.
    fn tree_update_acceleration(&mut self, dt: Real, bodies: &RigidBodySet) {
        let n = self.ndofs;
        // physics-mcp patch 5: the same zeros through a slice (nalgebra's `fill` iterates).
        self.accelerations.as_mut_slice().fill(0.0);
        let check_implicit_coriolis_divergence = dt * self.velocities.amax() >= 1.0e-3;
        let t = &mut self.tree;
        reset(&mut t.pos_forces, if check_implicit_coriolis_divergence { n } else { 0 }, 0.0);
        let accs = self.accelerations.as_mut_slice();

        for i in 0..self.links.len() {
            let link = &self.links[i];
            let rb = &bodies[link.rigid_body];
            let mut acc = RigidBodyVelocity::zero();
            if i != 0 {
                let parent_id = link.parent_internal_id;
                let parent_rb = &bodies[self.links[parent_id].rigid_body];
                let pw = parent_rb.vels.angvel;
                acc += self.workspace.accs[parent_id];
                acc.linvel += pw.cross(link.joint_velocity.linvel) * 2.0;
                acc.angvel += pw.cross(link.joint_velocity.angvel);
                acc.linvel += pw.cross(pw.cross(link.shift02));
                acc.linvel += self.workspace.accs[parent_id].angvel.cross(link.shift02);
            }
            let w = rb.vels.angvel;
            acc.linvel += w.cross(w.cross(link.shift23));
            acc.linvel += acc.angvel.cross(link.shift23);
            self.workspace.accs[i] = acc;

            let (m, inertia) = (t.masses[i], t.inertias[i]);
            let gyroscopic = w.cross(inertia.mul_vec(w));
            let force = rb.forces.force - m * acc.linvel;
            let torque = rb.forces.torque - gyroscopic - inertia.mul_vec(acc.angvel);
            for c in t.link_range(i) {
                let j = t.jac[c];
                let dof = t.cols[c] as usize;
                accs[dof] += j.v.dot(force) + j.w.dot(torque);
                if check_implicit_coriolis_divergence {
                    t.pos_forces[dof] += j.v.dot(rb.forces.force) + j.w.dot(rb.forces.torque);
                }
            }
        }

        for i in 0..n {
            accs[i] -= self.damping[i] * self.velocities[i];
        }
        for link in self.links.iter() {
            let mut idx = link.assembly_id;
            let locked = link.joint.data.locked_axes.bits();
            for a in 0..SPATIAL_DIM {
                if (locked >> a) & 1 == 0 {
                    let k = link.joint.spring_stiffness[a];
                    if k != 0.0 {
                        let q = link.joint.coords[a];
                        let spring_pos_force = -k * (q - link.joint.spring_ref[a]);
                        accs[idx] += spring_pos_force - k * dt * self.velocities[idx];
                        if check_implicit_coriolis_divergence {
                            t.pos_forces[idx] += spring_pos_force;
                        }
                    }
                    idx += 1;
                }
            }
        }

        if check_implicit_coriolis_divergence {
            t.gen_forces.clear();
            t.gen_forces.extend_from_slice(accs);
        }
        t.solve_acc(accs);
        if check_implicit_coriolis_divergence {
            self.tree_energy_guard(dt);
        }
    }

    /// The dense path's `free_velocity_energy_guard` on the tree path's matrices: if the
    /// semi-implicit solve added more kinetic energy than the forces' work (or is not finite),
    /// the accelerations are solved again with `M` alone.
    fn tree_energy_guard(&mut self, dt: Real) {
        if !self.tree_energy_is_sound(dt) {
            self.tree_energy_fallback();
        }
    }

    /// Whether the free accelerations are finite and add no more energy than the forces' work
    /// (plus a margin of 1% of the kinetic energy), over the non-kinematic degrees of freedom.
    fn tree_energy_is_sound(&mut self, dt: Real) -> bool {
        let n = self.ndofs;
        let t = &mut self.tree;
        if t.kinematic.iter().all(|k| *k) {
            return true;
        }
        let accs = self.accelerations.as_slice();
        if !accs.iter().all(|x| x.is_finite()) {
            return false;
        }
        let m = self.augmented_mass.as_slice();
        // Kinematic degrees of freedom are left out, as the dense path's reordering does.
        let kinematic = &t.kinematic;
        let keep = |i: usize, x: Real| if kinematic[i] { 0.0 } else { x };
        reset(&mut t.scratch_x, n, 0.0);
        reset(&mut t.scratch_y, n, 0.0);
        for i in 0..n {
            t.scratch_x[i] = keep(i, self.velocities[i]);
            t.scratch_y[i] = keep(i, accs[i]);
        }
        let (v, a) = (&t.scratch_x, &t.scratch_y);
        // M·a and M·v (M symmetric, column-major: row i of M is its column i).
        let (mut va, mut aa, mut vf, mut af, mut vv) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for i in 0..n {
            let row = &m[i * n..i * n + n];
            let (mut ma_i, mut mv_i) = (0.0, 0.0);
            for j in 0..n {
                ma_i += row[j] * a[j];
                mv_i += row[j] * v[j];
            }
            va += v[i] * ma_i;
            aa += a[i] * ma_i;
            vv += v[i] * mv_i;
            vf += v[i] * keep(i, t.gen_forces[i]);
            af += a[i] * keep(i, t.pos_forces[i]);
        }
        let energy_delta = dt * va + 0.5 * dt * dt * aa;
        let work = dt * vf + 0.5 * dt * dt * af;
        let energy_margin = 1.0e-2 * (0.5 * vv) + 1.0e-8;
        energy_delta - work - energy_margin <= 0.0
    }

    /// The energy guard's fallback: the accelerations from `M` alone, or zero if even that is
    /// not finite.
    fn tree_energy_fallback(&mut self) {
        let accs = self.accelerations.as_mut_slice();
        accs.copy_from_slice(&self.tree.gen_forces);
        self.tree.solve_mass(accs, None);
        if !accs.iter().all(|x| x.is_finite()) {
            accs.fill(0.0);
        }
    }

    /// `fill_jacobians` on the tree path: `J = J_linkᵀ·f` over the link's columns, `M⁻¹·J` along
    /// its chain, and `(J·M⁻¹·J, J·v)`.
    pub(super) fn tree_fill_jacobians(&self, link_id: usize, force: Col, j_id: usize, jacobians: &mut [Real]) -> (Real, Real) {
        let n = self.ndofs;
        let t = &self.tree;
        let link = self.links[link_id].internal_id;
        let (j, wj) = jacobians[j_id..j_id + 2 * n].split_at_mut(n);
        j.fill(0.0);
        for c in t.link_range(link) {
            j[t.cols[c] as usize] = t.jac[c].dot(&force);
        }
        wj.copy_from_slice(j);
        let end = t.chain_end[link];
        if end != NONE_DOF {
            t.solve_mass(wj, Some(end));
        }
        let (mut jwj, mut jv) = (0.0, 0.0);
        for c in t.link_range(link) {
            let dof = t.cols[c] as usize;
            jwj += j[dof] * wj[dof];
            jv += j[dof] * self.velocities[dof];
        }
        (jwj, jv)
    }

    /// `J_linkᵀ·f` (dense, length `ndofs`) into `out`, and the squared norm of the link's
    /// whole body jacobian (for `fill_relative_jacobians`' cancellation guard).
    pub(super) fn tree_jacobian_tr_mul(&self, link_id: usize, force: Col, out: &mut [Real]) -> Real {
        let t = &self.tree;
        let link = self.links[link_id].internal_id;
        out.fill(0.0);
        let mut norm2 = 0.0;
        for c in t.link_range(link) {
            let col = &t.jac[c];
            out[t.cols[c] as usize] = col.dot(&force);
            norm2 += col.dot(col);
        }
        norm2
    }

    /// `x ← M⁻¹·x` on the tree path (any right-hand side).
    pub(super) fn tree_solve(&self, x: &mut [Real]) {
        self.tree.solve_mass(x, None);
    }

    /// `x ← M⁻¹·x` on the tree path for `x` zero outside the chain from `dof` to its root (a
    /// unit vector at `dof`); under patch 3, the step's `M⁻¹·e_dof` when it holds it (`x` is then
    /// that unit vector).
    pub(crate) fn tree_solve_along(&self, dof: usize, x: &mut [Real]) {
        let t = &self.tree;
        if t.unit_ready.get(dof).copied().unwrap_or(false) {
            let n = self.ndofs;
            x.copy_from_slice(&t.unit_responses[dof * n..dof * n + n]);
            return;
        }
        t.solve_mass(x, Some(dof as u32));
    }

    /// physics-mcp patch 3: `M⁻¹·e_k` with the step's factorisation for every degree of freedom
    /// with a limit, a motor or dry friction (what `unit_multibody_joint.rs` solves for in every
    /// substep), kept for the step.
    pub(crate) fn tree_cache_unit_responses(&mut self) {
        let n = self.ndofs;
        let t = &mut self.tree;
        reset(&mut t.unit_ready, n, false);
        // Out of the workspace while it is filled (the solves borrow the workspace).
        let mut responses = core::mem::take(&mut t.unit_responses);
        reset(&mut responses, n * n, 0.0);
        for link in self.links.iter() {
            let data = &link.joint.data;
            let (locked, wanted) = (data.locked_axes.bits(), data.limit_axes.bits() | data.motor_axes.bits());
            let mut dof = link.assembly_id;
            for a in 0..SPATIAL_DIM {
                if (locked >> a) & 1 == 0 {
                    if (wanted >> a) & 1 != 0 || self.frictions.get(dof).copied().unwrap_or(0.0) > 0.0 {
                        let x = &mut responses[dof * n..dof * n + n];
                        x[dof] = 1.0;
                        t.solve_mass(x, Some(dof as u32));
                        t.unit_ready[dof] = true;
                    }
                    dof += 1;
                }
            }
        }
        t.unit_responses = responses;
    }
}
