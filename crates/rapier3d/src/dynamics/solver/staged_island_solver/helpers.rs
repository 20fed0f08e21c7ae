//! Staged-solver entry points on [`ContactConstraintsSet`] and
//! [`VelocitySolver`]: generic (multibody) constraint init and the
//! multibody-only halves of buffer init and position integration.

use crate::dynamics::solver::SolverVel;
use crate::dynamics::solver::VelocitySolver;
use crate::dynamics::solver::contact_constraint::{
    ContactConstraintsSet, GenericContactConstraint, GenericContactConstraintBuilder,
};
use crate::dynamics::solver::manifold_store::ManifoldStore;
use crate::dynamics::solver::solver_contact_graph::SolverContactGraph;
#[cfg(feature = "dim3")]
use crate::dynamics::solver::velocity_solver::GyroParams;
#[cfg(all(feature = "parallel", feature = "dim3"))]
use crate::dynamics::MultibodyLinkId;
use crate::dynamics::{IntegrationParameters, MultibodyJointSet, RigidBodyHandle, RigidBodySet};
use crate::math::DVector;
use parry::math::SIMD_WIDTH;

impl ContactConstraintsSet {
    /// Builds the generic (multibody) contact constraints for the staged solver.
    pub(super) fn compute_generic_constraints(
        &mut self,
        bodies: &RigidBodySet,
        multibody_joints: &MultibodyJointSet,
        graph: &SolverContactGraph,
        store: &ManifoldStore,
        jacobian_id: &mut usize,
    ) {
        let generic = graph.generic();
        let total_num_constraints = generic.len();
        self.generic_velocity_constraints_builder.resize(
            total_num_constraints,
            GenericContactConstraintBuilder::invalid(),
        );
        self.generic_velocity_constraints
            .resize(total_num_constraints, GenericContactConstraint::invalid());

        for (curr_id, r) in generic.iter().enumerate() {
            let manifold = store.get(*r);
            GenericContactConstraintBuilder::generate(
                *r,
                manifold,
                bodies,
                multibody_joints,
                &mut self.generic_velocity_constraints_builder[curr_id],
                &mut self.generic_velocity_constraints[curr_id],
                &mut self.generic_jacobians,
                jacobian_id,
            );
        }
    }
}

impl VelocitySolver {
    /// Initializes the solver buffers and multibody solver state; the plain rigid-body
    /// initialization is excluded, the staged solver performs it in parallel in its first stage.
    pub(super) fn init_solver_buffers_and_multibodies(
        &mut self,
        params: &IntegrationParameters,
        island_bodies: &[RigidBodyHandle],
        num_awake_soft_mass_points: usize,
        bodies: &mut RigidBodySet,
        multibodies: &mut MultibodyJointSet,
    ) {
        self.multibody_roots.clear();
        self.solver_bodies.clear();

        // The island's rigid bodies, then the awake soft bodies' particles.
        let aligned_solver_bodies_len =
            (island_bodies.len() + num_awake_soft_mass_points).div_ceil(SIMD_WIDTH) * SIMD_WIDTH;
        self.solver_bodies.resize(aligned_solver_bodies_len);

        self.solver_vels_increment.clear();
        self.solver_vels_increment
            .resize(aligned_solver_bodies_len, SolverVel::zero());

        // Reset every step so multibody/padding slots (which the body-copy stage
        // skips) read as gyro-disabled.
        #[cfg(feature = "dim3")]
        {
            self.solver_gyro.clear();
            self.solver_gyro
                .resize(aligned_solver_bodies_len, GyroParams::default());
        }

        // Assign solver ids to multibodies, and collect the relevant roots.
        let mut multibody_solver_id = 0;
        for handle in island_bodies {
            if let Some(link) = multibodies.rigid_body_link(*handle).copied() {
                let multibody = multibodies
                    .get_multibody_mut_internal(link.multibody)
                    .unwrap();

                if link.id == 0 || link.id == 1 && !multibody.root_is_dynamic {
                    multibody.solver_id = multibody_solver_id;
                    multibody_solver_id += multibody.ndofs() as u32;
                    self.multibody_roots.push(link);
                }
            }
        }

        // physics-mcp patch 7: a multibody with links in the island but not its root link (0,
        // or 1 under a fixed root) got no id above — its root link was disabled, e.g.
        // quarantined for a non-finite pose — and kept last step's, which may lie past this
        // step's vectors (the release then panics where a joint row or a contact slices them).
        // Such a multibody gets the next rows, once, after every other's, and nothing else: it
        // stays out of the roots, as in the release (so its links are solved as loose bodies
        // when no other multibody shares the island, and held still when one does). An old id
        // still inside the vectors is left as the release leaves it. So every step that did not
        // panic computes the release's bits.
        let assigned = multibody_solver_id;
        let mut orphans = crate::alloc_prelude::Vec::new();
        for handle in island_bodies {
            if let Some(link) = multibodies.rigid_body_link(*handle).copied() {
                let multibody = multibodies
                    .get_multibody_mut_internal(link.multibody)
                    .unwrap();
                if multibody.solver_id as usize + multibody.ndofs() > assigned as usize
                    && !orphans.contains(&link.multibody)
                {
                    multibody.solver_id = multibody_solver_id;
                    multibody_solver_id += multibody.ndofs() as u32;
                    orphans.push(link.multibody);
                }
            }
        }

        // physics-mcp patch 5: the same zero vectors, reusing last step's buffers when their
        // length is unchanged (no allocation per step).
        for v in [&mut self.generic_solver_vels_increment, &mut self.generic_solver_vels] {
            if v.len() == multibody_solver_id as usize {
                v.as_mut_slice().fill(0.0);
            } else {
                *v = DVector::zeros(multibody_solver_id as usize);
            }
        }

        // physics-mcp patch 1: under the tree path, independent multibodies' dynamics run in
        // parallel (each reads the bodies and writes only itself, so the bits do not depend on
        // the thread count); the release's dense path stays serial, as released.
        #[cfg(all(feature = "parallel", feature = "dim3"))]
        let parallel = params.multibody_dynamics.is_tree()
            && self.multibody_roots.len() > 1
            && rayon::current_num_threads() > 1;
        #[cfg(not(all(feature = "parallel", feature = "dim3")))]
        let parallel = false;
        #[cfg(all(feature = "parallel", feature = "dim3"))]
        if parallel {
            update_multibodies_in_parallel(&self.multibody_roots, params, bodies, multibodies);
        }

        for link in &self.multibody_roots {
            let multibody = multibodies
                .get_multibody_mut_internal(link.multibody)
                .unwrap();
            if !parallel {
                multibody.update_velocities(bodies);
                multibody.update_dynamics(params, bodies);
            }

            let mut solver_vels_incr = self
                .generic_solver_vels_increment
                .rows_mut(multibody.solver_id as usize, multibody.ndofs());
            let mut solver_vels = self
                .generic_solver_vels
                .rows_mut(multibody.solver_id as usize, multibody.ndofs());

            solver_vels_incr.axpy(params.dt, &multibody.accelerations, 0.0);
            solver_vels.copy_from(&multibody.velocities);
        }
    }

    /// The multibody part of `integrate_positions`, used by the staged solver
    /// (regular solver bodies are integrated in parallel by the workers).
    pub(super) fn integrate_multibody_positions(
        &mut self,
        params: &IntegrationParameters,
        is_last_substep: bool,
        bodies: &mut RigidBodySet,
        multibodies: &mut MultibodyJointSet,
    ) {
        for link in &self.multibody_roots {
            let multibody = multibodies
                .get_multibody_mut_internal(link.multibody)
                .unwrap();
            let solver_vels = self
                .generic_solver_vels
                .rows(multibody.solver_id as usize, multibody.ndofs());
            multibody.velocities.copy_from(&solver_vels);
            multibody.integrate(params.dt);
            multibody.forward_kinematics_in_step(bodies, params.multibody_dynamics);
            multibody.update_rigid_bodies_internal(bodies, !is_last_substep, true, false);
            if is_last_substep && crate::dynamics::skip_unchanged_multibody_kinematics() {
                // physics-mcp patch 4: what these poses were computed from, for the next step's
                // opening pass to skip itself when nothing changed in between.
                multibody.record_kinematics_inputs(bodies, params.multibody_dynamics);
            }

            if !is_last_substep {
                multibody.update_velocities(bodies);
                // physics-mcp patch 3: under `TreeSparsePerStep`, the free accelerations only.
                multibody.update_substep_dynamics(params, bodies);

                let mut solver_vels_incr = self
                    .generic_solver_vels_increment
                    .rows_mut(multibody.solver_id as usize, multibody.ndofs());
                solver_vels_incr.axpy(params.dt, &multibody.accelerations, 0.0);
            }
        }
    }
}

/// The multibodies of `roots`: their links' velocities written to the bodies (serially: they
/// write the shared set), then each one's dynamics on the rayon pool (each reads the bodies and
/// writes only itself).
#[cfg(all(feature = "parallel", feature = "dim3"))]
fn update_multibodies_in_parallel(
    roots: &[MultibodyLinkId],
    params: &IntegrationParameters,
    bodies: &mut RigidBodySet,
    multibodies: &mut MultibodyJointSet,
) {
    use rayon::prelude::*;
    for link in roots {
        if let Some(multibody) = multibodies.get_multibody_mut_internal(link.multibody) {
            multibody.update_velocities(bodies);
        }
    }
    let mut wanted: crate::alloc_prelude::Vec<bool> = crate::alloc_prelude::Vec::new();
    for link in roots {
        let slot = link.multibody.0.into_raw_parts().0 as usize;
        if wanted.len() <= slot {
            wanted.resize(slot + 1, false);
        }
        wanted[slot] = true;
    }
    let mut work: crate::alloc_prelude::Vec<&mut crate::dynamics::Multibody> = multibodies
        .multibodies
        .iter_mut()
        .filter(|(i, _)| wanted.get(i.into_raw_parts().0 as usize).copied().unwrap_or(false))
        .map(|(_, m)| m)
        .collect();
    let bodies: &RigidBodySet = bodies;
    work.par_iter_mut()
        .with_min_len(4)
        .for_each(|multibody| multibody.update_dynamics(params, bodies));
}
