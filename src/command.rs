//! Commands: the validated, self-contained form of every state-changing tool call.
//!
//! A `Command` is what the log stores and what `World::apply` folds. It is built by an adapter
//! from the client's JSON (shape checks, in `value.rs`), then checked against the current world
//! and the limits (`Command::check`): ids exist, limits hold. Once accepted, applying it cannot
//! fail. Commands are serialised with serde_json (`float_roundtrip`), so decoding an event gives
//! back exactly the command that was applied. Never change what an existing variant means: add
//! a new one and bump `EVENT_VERSION`.

use serde::{Deserialize, Serialize};

use crate::limits::Limits;
use crate::value::Refusal;
use crate::world::World;

/// Version of the event encoding; stored with every event so old versions can be upcast.
pub const EVENT_VERSION: u32 = 1;

/// A primitive collision shape with its dimensions (PyBullet conventions: box half-extents,
/// cylinder full height, capsule cylindrical-part height; cylinders/capsules along local z).
/// Externally tagged (`{"box": {...}}`): snapshots use postcard, which cannot decode
/// internally tagged enums.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    /// A box given by its half-extents.
    Box {
        /// Half-extents [hx, hy, hz] in metres.
        half_extents: [f32; 3],
    },
    /// A sphere.
    Sphere {
        /// Radius in metres.
        radius: f32,
    },
    /// A cylinder along local z.
    Cylinder {
        /// Radius in metres.
        radius: f32,
        /// Full height in metres.
        height: f32,
    },
    /// A capsule along local z.
    Capsule {
        /// Radius in metres.
        radius: f32,
        /// Height of the cylindrical part in metres.
        height: f32,
    },
}

impl Shape {
    /// The shape's name as the tools report it.
    pub fn name(&self) -> &'static str {
        match self {
            Shape::Box { .. } => "box",
            Shape::Sphere { .. } => "sphere",
            Shape::Cylinder { .. } => "cylinder",
            Shape::Capsule { .. } => "capsule",
        }
    }

    /// The `dimensions` list used in saved files: box half-extents, [radius], [radius, height].
    pub fn dimensions(&self) -> Vec<f32> {
        match *self {
            Shape::Box { half_extents } => half_extents.to_vec(),
            Shape::Sphere { radius } => vec![radius],
            Shape::Cylinder { radius, height } | Shape::Capsule { radius, height } => {
                vec![radius, height]
            }
        }
    }
}

/// Properties `change_dynamics` may set; `None` leaves a property as it is.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq, Default)]
pub struct DynamicsChange {
    /// New mass in kg (0 makes the body static).
    pub mass: Option<f32>,
    /// Coulomb friction coefficient.
    pub lateral_friction: Option<f32>,
    /// Stored and reported (no direct rapier equivalent).
    pub spinning_friction: Option<f32>,
    /// Stored and reported (no direct rapier equivalent).
    pub rolling_friction: Option<f32>,
    /// Coefficient of restitution.
    pub restitution: Option<f32>,
    /// Linear velocity damping.
    pub linear_damping: Option<f32>,
    /// Angular velocity damping.
    pub angular_damping: Option<f32>,
    /// Stored and reported (rapier's contact softness is global).
    pub contact_stiffness: Option<f32>,
    /// Stored and reported (rapier's contact softness is global).
    pub contact_damping: Option<f32>,
}

impl DynamicsChange {
    /// Names of the properties this change sets, in a fixed order (reported as `changed`).
    pub fn names(&self) -> Vec<&'static str> {
        let all = [
            ("mass", self.mass),
            ("lateral_friction", self.lateral_friction),
            ("spinning_friction", self.spinning_friction),
            ("rolling_friction", self.rolling_friction),
            ("restitution", self.restitution),
            ("linear_damping", self.linear_damping),
            ("angular_damping", self.angular_damping),
            ("contact_stiffness", self.contact_stiffness),
            ("contact_damping", self.contact_damping),
        ];
        all.iter().filter(|(_, v)| v.is_some()).map(|(n, _)| *n).collect()
    }
}

/// One accepted state-changing call, in the form the log stores and `World::apply` folds.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
#[serde(tag = "op", rename_all = "snake_case")]
pub enum Command {
    /// Root event: a new, empty world. The id is chosen by the adapter, never by `apply`.
    CreateSimulation {
        /// The new simulation's UUID.
        simulation_id: String,
        /// Gravity in m/s².
        gravity: [f32; 3],
        /// Whether the web viewer follows this simulation.
        gui: bool,
    },
    /// Root event of a fork: the world is the parent's at `at_seq` (the inherited chain
    /// before this event in the log folds to it), under a new id. Applying it changes nothing.
    ForkSimulation {
        /// The new simulation's UUID.
        simulation_id: String,
        /// The simulation it was forked from.
        parent_id: String,
        /// The parent's event it starts from.
        at_seq: u64,
        /// Whether the web viewer follows this simulation.
        gui: bool,
    },
    /// Root event of a simulation loaded from a saved file's history: the world is the one
    /// the inherited chain before this event folds to, under a new id. Applying it changes
    /// nothing.
    LoadSimulation {
        /// The new simulation's UUID.
        simulation_id: String,
        /// The file it was loaded from (as given).
        file_path: String,
        /// Whether the web viewer follows this simulation.
        gui: bool,
    },
    /// Advance time by `steps` fixed timesteps.
    StepSimulation {
        /// Number of steps actually taken (a cancelled call records the steps it did).
        steps: u64,
    },
    /// Change the fixed timestep.
    SetTimestep {
        /// Seconds per step.
        timestep: f32,
    },
    /// Add a primitive body (add_box / add_sphere / add_cylinder / add_capsule).
    AddBody {
        /// Shape and dimensions.
        shape: Shape,
        /// World position of the body origin.
        position: [f32; 3],
        /// Orientation quaternion [x, y, z, w] (normalised).
        orientation: [f32; 4],
        /// Mass in kg; 0 = static.
        mass: f32,
        /// RGBA color, if given.
        color: Option<[f32; 4]>,
    },
    /// Teleport a body.
    SetObjectPose {
        /// Target object.
        object_id: u32,
        /// New world position.
        position: [f32; 3],
        /// New orientation (normalised).
        orientation: [f32; 4],
    },
    /// A force acting during the next single step.
    ApplyForce {
        /// Target object.
        object_id: u32,
        /// Force in N (world frame).
        force: [f32; 3],
        /// World point of application; None = centre of mass.
        position: Option<[f32; 3]>,
        /// −1 = the base; ≥ 0 a URDF link.
        #[serde(default = "base_link")]
        link_index: i32,
    },
    /// A torque acting during the next single step.
    ApplyTorque {
        /// Target object.
        object_id: u32,
        /// Torque in N·m (world frame).
        torque: [f32; 3],
        /// −1 = the base; ≥ 0 a URDF link.
        #[serde(default = "base_link")]
        link_index: i32,
    },
    /// Set linear and/or angular velocity.
    SetObjectVelocity {
        /// Target object.
        object_id: u32,
        /// New linear velocity, if given.
        linear_velocity: Option<[f32; 3]>,
        /// New angular velocity, if given.
        angular_velocity: Option<[f32; 3]>,
    },
    /// Change mass/material/damping properties.
    ChangeDynamics {
        /// Target object.
        object_id: u32,
        /// −1 = the base; ≥ 0 a URDF link.
        #[serde(default = "base_link")]
        link_index: i32,
        /// The properties to set.
        change: DynamicsChange,
    },
    /// Remove a body.
    RemoveObject {
        /// Target object.
        object_id: u32,
    },
}

fn base_link() -> i32 {
    -1
}

/// The standard "object not found" sentence (SPEC).
pub fn object_not_found(object_id: u32, sim_id: &str) -> Refusal {
    format!("Object {object_id} not found in simulation {sim_id}")
}

impl Command {
    /// Checks the command against the current world and limits. An `Ok` here guarantees
    /// `World::apply` succeeds; an `Err` is the one-sentence reason, and nothing changes.
    pub fn check(&self, world: &World, limits: &Limits) -> Result<(), Refusal> {
        let exists = |id: u32| {
            if world.has_object(id) {
                Ok(())
            } else {
                Err(object_not_found(id, world.simulation_id()))
            }
        };
        match self {
            Command::CreateSimulation { .. }
            | Command::ForkSimulation { .. }
            | Command::LoadSimulation { .. } => Err("a root event cannot be applied here".into()),
            Command::StepSimulation { steps } => {
                if *steps == 0 || *steps > limits.max_steps {
                    Err(format!(
                        "steps must be an integer from 1 to {} (--max-steps); got {steps}",
                        limits.max_steps
                    ))
                } else {
                    Ok(())
                }
            }
            Command::SetTimestep { .. } => Ok(()),
            Command::AddBody { .. } => {
                if world.object_count() >= limits.max_objects {
                    Err(format!(
                        "Object limit reached: {} objects in simulation {} (--max-objects)",
                        limits.max_objects,
                        world.simulation_id()
                    ))
                } else {
                    Ok(())
                }
            }
            Command::SetObjectPose { object_id, .. }
            | Command::SetObjectVelocity { object_id, .. }
            | Command::RemoveObject { object_id } => exists(*object_id),
            Command::ApplyForce {
                object_id,
                link_index,
                ..
            }
            | Command::ApplyTorque {
                object_id,
                link_index,
                ..
            } => {
                exists(*object_id)?;
                world.check_link(*object_id, *link_index)
            }
            Command::ChangeDynamics {
                object_id,
                link_index,
                change,
            } => {
                exists(*object_id)?;
                world.check_link(*object_id, *link_index)?;
                if change.mass == Some(0.0) && *link_index >= 0 {
                    return Err("mass 0 (static) applies to the base only (link_index -1)".into());
                }
                Ok(())
            }
        }
    }
}
