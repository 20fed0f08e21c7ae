//! Object tools: add primitives, poses, velocities, forces, dynamics, state reads, removal.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};

use super::{params, PhysicsServer};
use crate::command::{Command, DynamicsChange, Shape};
use crate::reads;
use crate::outputs::{DynamicsChanged, DynamicsInfo, Message, ObjectAdded, ObjectState};
use crate::value::{self, arg, Args, Refusal};

/// The parts every add_* call shares: position, orientation, mass, color.
fn decide_add(a: &Args, shape: Shape) -> Result<Command, Refusal> {
    Ok(Command::AddBody {
        shape,
        position: value::req_vec3(a, "position")?,
        orientation: value::quat_or_identity(a, "orientation")?,
        mass: value::non_negative_or(a, "mass", 1.0)?,
        color: arg(a, "color").map(|c| value::color("color", c)).transpose()?,
    })
}

fn req_positive(a: &Args, name: &str) -> Result<f32, Refusal> {
    value::positive(name, value::required(a, name, "a finite number > 0")?)
}

fn decide_box(a: &Args) -> Result<Command, Refusal> {
    let d = value::req_vec3(a, "dimensions")?;
    if d.iter().any(|x| *x <= 0.0) {
        return Err(format!(
            "dimensions must be 3 half-extents > 0 [hx, hy, hz]; got {:?}",
            d
        ));
    }
    decide_add(a, Shape::Box { half_extents: d })
}

fn decide_sphere(a: &Args) -> Result<Command, Refusal> {
    let radius = req_positive(a, "radius")?;
    decide_add(a, Shape::Sphere { radius })
}

fn decide_cylinder(a: &Args) -> Result<Command, Refusal> {
    let (radius, height) = (req_positive(a, "radius")?, req_positive(a, "height")?);
    decide_add(a, Shape::Cylinder { radius, height })
}

fn decide_capsule(a: &Args) -> Result<Command, Refusal> {
    let (radius, height) = (req_positive(a, "radius")?, req_positive(a, "height")?);
    decide_add(a, Shape::Capsule { radius, height })
}

fn decide_pose(a: &Args) -> Result<Command, Refusal> {
    Ok(Command::SetObjectPose {
        object_id: value::object_id(a, "object_id")?,
        position: value::req_vec3(a, "position")?,
        orientation: value::quat_or_identity(a, "orientation")?,
    })
}

fn decide_force(a: &Args) -> Result<Command, Refusal> {
    Ok(Command::ApplyForce {
        object_id: value::object_id(a, "object_id")?,
        force: value::req_vec3(a, "force")?,
        position: value::opt_vec3(a, "position")?,
        link_index: value::link_index(a)?,
    })
}

fn decide_torque(a: &Args) -> Result<Command, Refusal> {
    Ok(Command::ApplyTorque {
        object_id: value::object_id(a, "object_id")?,
        torque: value::req_vec3(a, "torque")?,
        link_index: value::link_index(a)?,
    })
}

fn decide_velocity(a: &Args) -> Result<Command, Refusal> {
    let object_id = value::object_id(a, "object_id")?;
    let linear_velocity = value::opt_vec3(a, "linear_velocity")?;
    let angular_velocity = value::opt_vec3(a, "angular_velocity")?;
    if linear_velocity.is_none() && angular_velocity.is_none() {
        return Err("linear_velocity or angular_velocity is required: give at least one [x, y, z]".into());
    }
    Ok(Command::SetObjectVelocity {
        object_id,
        linear_velocity,
        angular_velocity,
    })
}

fn decide_dynamics(a: &Args) -> Result<Command, Refusal> {
    let object_id = value::object_id(a, "object_id")?;
    let link_index = value::link_index(a)?;
    let get = |name: &str| arg(a, name).map(|v| value::non_negative(name, v)).transpose();
    let change = DynamicsChange {
        mass: get("mass")?,
        lateral_friction: get("lateral_friction")?,
        spinning_friction: get("spinning_friction")?,
        rolling_friction: get("rolling_friction")?,
        restitution: get("restitution")?,
        linear_damping: get("linear_damping")?,
        angular_damping: get("angular_damping")?,
        contact_stiffness: get("contact_stiffness")?,
        contact_damping: get("contact_damping")?,
    };
    if change.names().is_empty() {
        return Err("change_dynamics needs at least one property: mass, lateral_friction, \
                    spinning_friction, rolling_friction, restitution, linear_damping, \
                    angular_damping, contact_stiffness or contact_damping"
            .into());
    }
    Ok(Command::ChangeDynamics {
        object_id,
        link_index,
        change,
    })
}

fn decide_remove(a: &Args) -> Result<Command, Refusal> {
    Ok(Command::RemoveObject {
        object_id: value::object_id(a, "object_id")?,
    })
}

#[tool_router(router = object_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Add a box. `dimensions` are HALF-extents [hx, hy, hz] (PyBullet convention); mass 0
    /// makes it static (e.g. a ground slab).
    #[tool(input_schema = schema_for_type::<params::AddBox>())]
    async fn add_box(&self, args: JsonObject) -> Result<Json<ObjectAdded>, String> {
        self.change("add_box", args, decide_box).await
    }

    /// Add a sphere; mass 0 makes it static.
    #[tool(input_schema = schema_for_type::<params::AddSphere>())]
    async fn add_sphere(&self, args: JsonObject) -> Result<Json<ObjectAdded>, String> {
        self.change("add_sphere", args, decide_sphere).await
    }

    /// Add a cylinder along the body's local z axis (`height` is the full height).
    #[tool(input_schema = schema_for_type::<params::AddRound>())]
    async fn add_cylinder(&self, args: JsonObject) -> Result<Json<ObjectAdded>, String> {
        self.change("add_cylinder", args, decide_cylinder).await
    }

    /// Add a capsule along the body's local z axis (`height` is the cylindrical part).
    #[tool(input_schema = schema_for_type::<params::AddRound>())]
    async fn add_capsule(&self, args: JsonObject) -> Result<Json<ObjectAdded>, String> {
        self.change("add_capsule", args, decide_capsule).await
    }

    /// Teleport an object to a position and orientation (velocities are kept).
    #[tool(input_schema = schema_for_type::<params::SetPose>())]
    async fn set_object_pose(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("set_object_pose", args, decide_pose).await
    }

    /// Read an object's position, orientation [x, y, z, w], linear and angular velocity.
    #[tool(
        input_schema = schema_for_type::<params::ObjectRef>(),
        annotations(read_only_hint = true)
    )]
    async fn get_object_state(&self, args: JsonObject) -> Result<Json<ObjectState>, String> {
        self.read("get_object_state", args, |sim, a| reads::object_state(&sim.read_context(), a))
            .await
    }

    /// Apply a force (N, world frame) during the NEXT SINGLE STEP only, then it is cleared
    /// (PyBullet semantics). With `position` it acts at that world point (adding torque);
    /// without, at the centre of mass.
    #[tool(input_schema = schema_for_type::<params::ApplyForce>())]
    async fn apply_force(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("apply_force", args, decide_force).await
    }

    /// Apply a torque (N·m, world frame) during the NEXT SINGLE STEP only, then it is cleared
    /// (PyBullet semantics).
    #[tool(input_schema = schema_for_type::<params::ApplyTorque>())]
    async fn apply_torque(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("apply_torque", args, decide_torque).await
    }

    /// Set an object's linear and/or angular velocity (give at least one).
    #[tool(input_schema = schema_for_type::<params::SetVelocity>())]
    async fn set_object_velocity(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("set_object_velocity", args, decide_velocity).await
    }

    /// Change mass (0 = static), friction, restitution, damping and contact properties.
    /// Give at least one; each must be >= 0. Friction and restitution combine by multiplying.
    #[tool(input_schema = schema_for_type::<params::ChangeDynamics>())]
    async fn change_dynamics(&self, args: JsonObject) -> Result<Json<DynamicsChanged>, String> {
        self.change("change_dynamics", args, decide_dynamics).await
    }

    /// Read the dynamics properties in force: mass, friction, inertia, restitution, damping,
    /// contact properties and body type.
    #[tool(
        input_schema = schema_for_type::<params::DynamicsRef>(),
        annotations(read_only_hint = true)
    )]
    async fn get_dynamics_info(&self, args: JsonObject) -> Result<Json<DynamicsInfo>, String> {
        self.read("get_dynamics_info", args, |sim, a| reads::dynamics_info(&sim.read_context(), a))
            .await
    }

    /// Remove an object from the simulation (undo brings it back).
    #[tool(
        input_schema = schema_for_type::<params::ObjectRef>(),
        annotations(destructive_hint = true)
    )]
    async fn remove_object(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("remove_object", args, decide_remove).await
    }
}
