//! load_mjcf's opt-in `use_model_options`: the model's `<option>` timestep and gravity become
//! the simulation's. MuJoCo's models are written for their own step (Gymnasium's: 0.002 to
//! 0.02 s) and gravity (pusher's is 0); by default a model is simulated at the simulation's
//! own (1/240 s, −9.81 along z) and the `<option>` is only reported in `ignored`, because the
//! two are world-wide settings shared by every object. Imposing them is faithful to MuJoCo and,
//! for a model whose step is above 1/240 s, fewer steps per simulated second (docs/benchmarks.md
//! "MJCF models"). MuJoCo's solver options (`iterations`, `integrator`, `cone`, …) have no
//! equivalent in rapier (its iterations are substeps of a different solver) and stay in
//! `ignored`. Recorded in the LoadMjcf event (false when absent), so older logs fold as before.

use rapier3d::prelude::*;

use super::{ObjectKind, World};
use crate::outputs::MjcfLoaded;

/// The `<option>` values load_mjcf's `use_model_options` imposes on the simulation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelOptions {
    /// `<option timestep>` (s; MuJoCo's 0.002 when absent).
    pub timestep: f64,
    /// `<option gravity>` (m/s²; MuJoCo's 0 0 −9.81 when absent).
    pub gravity: [f64; 3],
}

impl World {
    /// The model's timestep and gravity become the simulation's (load_mjcf `use_model_options`),
    /// exactly as set_timestep and a world of that gravity would have them, and the load's
    /// `ignored` says so instead of listing them. A value the engine could not step with (not
    /// finite, a timestep ≤ 0) is left as the simulation had it.
    pub(super) fn use_model_options(&mut self, loaded: &mut MjcfLoaded, o: ModelOptions) {
        let dt = o.timestep as f32;
        if o.timestep.is_finite() && dt > 0.0 && dt.is_finite() {
            self.set_timestep(dt, o.timestep);
        }
        let gravity = o.gravity.map(|x| x as f32);
        if gravity.iter().all(|x| x.is_finite()) {
            self.physics.gravity = Vector::from_array(gravity);
        }
        let note = format!(
            "<option timestep=\"{}\" gravity=\"{} {} {}\">: applied to the simulation (use_model_options)",
            o.timestep, o.gravity[0], o.gravity[1], o.gravity[2]
        );
        // The reply's `ignored` and the one get_simulation_info reports later say the same.
        let replace = |ignored: &mut Vec<String>| {
            if let Some(first) = ignored.first_mut().filter(|n| n.starts_with("<option timestep=")) {
                first.clone_from(&note);
            }
        };
        replace(&mut loaded.ignored);
        if let Some(ObjectKind::Mjcf { mjcf, .. }) = self.tables.objects.get_mut(&loaded.object_id).map(|o| &mut o.kind) {
            replace(&mut mjcf.ignored);
        }
    }
}

