//! Parameters of create_simulation, list_simulations, destroy_simulation, step_simulation, set_timestep, get_simulation_info.

use schemars::JsonSchema;
use serde::Deserialize;

use super::lenient::*;

/// No parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct NoParams {}

/// create_simulation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CreateSimulation {
    /// m/s² (default [0, 0, -9.81]); g alone: [0, 0, g].
    pub gravity: Option<Gravity>,
    /// Web viewer (default false).
    pub gui: Option<Bool>,
    /// A label.
    pub name: Option<Text>,
}

/// Parameters naming just a simulation.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SimRef {
    /// Sim id.
    pub sim_id: Text,
}

/// step_simulation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Step {
    /// Sim id.
    pub sim_id: Text,
    /// Default 1.
    pub steps: Option<Int<u64>>,
    /// Sample poses every N steps.
    pub sample_every: Option<Int<u64>>,
    /// Default all.
    pub sample_objects: Option<Vec<ObjectId>>,
    /// full: exact samples.
    pub detail: Option<Text>,
    /// Samples' decimals (default 4).
    pub precision: Option<Int<u32>>,
    /// Per-step answers.
    pub measure: Option<super::trajectory::Measures>,
    /// Sample columns.
    pub fields: Option<Vec<Text>>,
}

/// set_timestep parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SetTimestep {
    /// Sim id.
    pub sim_id: Text,
    /// Seconds per step (default 1/240).
    pub timestep: PositiveGiven,
}
