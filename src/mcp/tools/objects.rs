//! Object tools: add primitives, poses, velocities, forces, dynamics, state reads, removal.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};

use crate::params::lenient::{link_index, link_index_named, Bool, Color, NonNegative, Quat, Vec3};
use crate::params::{
    self, AddBox, AddRound, AddSphere, ApplyForce, ApplyTorque, ChangeDynamics, CollisionFilterGroupMask, CollisionFilterPair,
    ObjectRef, SetPose, SetVelocity,
};
use crate::mcp::PhysicsServer;
use crate::command::{Command, DynamicsChange, Shape};
use crate::outputs::{DynamicsChanged, DynamicsInfo, Message, ObjectAdded, ObjectState};
use crate::sim::reads;
use crate::value::Refusal;

/// An optional quaternion, the identity when absent.
pub(super) fn quat_or_identity(q: Option<Quat>) -> [f32; 4] {
    q.map_or([0.0, 0.0, 0.0, 1.0], |q| q.0)
}

/// The parts every add_* call shares: where, how heavy, what colour, whether it collides.
struct Placed {
    position: Vec3,
    orientation: Option<Quat>,
    mass: Option<NonNegative>,
    color: Option<Color>,
    collides: Option<Bool>,
}

fn decide_add(shape: Shape, p: Placed) -> Command {
    Command::AddBody {
        shape,
        position: p.position.0,
        orientation: quat_or_identity(p.orientation),
        mass: p.mass.map_or(1.0, |m| m.0),
        color: p.color.map(|c| c.0),
        collides: p.collides.is_none_or(|b| b.0),
    }
}

pub(super) fn decide_box(p: AddBox) -> Result<Command, Refusal> {
    let d = p.dimensions.0;
    if d.iter().any(|x| *x <= 0.0) {
        return Err(format!(
            "dimensions must be 3 half-extents > 0 [hx, hy, hz]; got {:?}",
            d
        ));
    }
    let placed = Placed { position: p.position, orientation: p.orientation, mass: p.mass, color: p.color, collides: p.collides };
    Ok(decide_add(Shape::Box { half_extents: d }, placed))
}

pub(super) fn decide_sphere(p: AddSphere) -> Result<Command, Refusal> {
    let placed = Placed { position: p.position, orientation: p.orientation, mass: p.mass, color: p.color, collides: p.collides };
    Ok(decide_add(Shape::Sphere { radius: p.radius.0 }, placed))
}

fn decide_round(p: AddRound, shape: fn(f32, f32) -> Shape) -> Command {
    let placed = Placed { position: p.position, orientation: p.orientation, mass: p.mass, color: p.color, collides: p.collides };
    decide_add(shape(p.radius.0, p.height.0), placed)
}

pub(super) fn decide_cylinder(p: AddRound) -> Result<Command, Refusal> {
    Ok(decide_round(p, |radius, height| Shape::Cylinder { radius, height }))
}

pub(super) fn decide_capsule(p: AddRound) -> Result<Command, Refusal> {
    Ok(decide_round(p, |radius, height| Shape::Capsule { radius, height }))
}

/// A 32-bit set as PyBullet takes it: 0 to 2^32 − 1, or a negative 32-bit int (−1 = all bits).
fn bits(v: crate::params::lenient::Int<u32>, name: &str) -> Result<u32, Refusal> {
    let i = v.get();
    u32::try_from(i)
        .or_else(|_| i32::try_from(i).map(|x| x as u32))
        .map_err(|_| format!("{name} must be a 32-bit set of bits (0 to 4294967295, or -1 for all); got {i}"))
}

pub(super) fn decide_filter(p: CollisionFilterGroupMask) -> Result<Command, Refusal> {
    Ok(Command::SetCollisionFilter {
        object_id: p.object_id.0,
        link_index: link_index(p.link_index)?,
        group: bits(p.collision_filter_group, "collision_filter_group")?,
        mask: bits(p.collision_filter_mask, "collision_filter_mask")?,
        pybullet_test: true,
    })
}

pub(super) fn decide_pair(p: CollisionFilterPair) -> Result<Command, Refusal> {
    Ok(Command::SetCollisionPair {
        a: (p.object_id_a.0, link_index_named(p.link_index_a, "link_index_a")?),
        b: (p.object_id_b.0, link_index_named(p.link_index_b, "link_index_b")?),
        enable: p.enable_collision.0,
    })
}

pub(super) fn decide_pose(p: SetPose) -> Result<Command, Refusal> {
    Ok(Command::SetObjectPose {
        object_id: p.object_id.0,
        position: p.position.0,
        orientation: quat_or_identity(p.orientation),
    })
}

pub(super) fn decide_force(p: ApplyForce) -> Result<Command, Refusal> {
    Ok(Command::ApplyForce {
        object_id: p.object_id.0,
        force: p.force.0,
        position: p.position.map(|v| v.0),
        link_index: link_index(p.link_index)?,
    })
}

pub(super) fn decide_torque(p: ApplyTorque) -> Result<Command, Refusal> {
    Ok(Command::ApplyTorque {
        object_id: p.object_id.0,
        torque: p.torque.0,
        link_index: link_index(p.link_index)?,
    })
}

pub(super) fn decide_velocity(p: SetVelocity) -> Result<Command, Refusal> {
    if p.linear_velocity.is_none() && p.angular_velocity.is_none() {
        return Err("linear_velocity or angular_velocity is required: give at least one [x, y, z]".into());
    }
    Ok(Command::SetObjectVelocity {
        object_id: p.object_id.0,
        linear_velocity: p.linear_velocity.map(|v| v.0),
        angular_velocity: p.angular_velocity.map(|v| v.0),
    })
}

pub(super) fn decide_dynamics(p: ChangeDynamics) -> Result<Command, Refusal> {
    let link_index = link_index(p.link_index)?;
    let get = |v: Option<NonNegative>| v.map(|x| x.0);
    let change = DynamicsChange {
        mass: get(p.mass),
        lateral_friction: get(p.lateral_friction),
        spinning_friction: get(p.spinning_friction),
        rolling_friction: get(p.rolling_friction),
        restitution: get(p.restitution),
        linear_damping: get(p.linear_damping),
        angular_damping: get(p.angular_damping),
        contact_stiffness: get(p.contact_stiffness),
        contact_damping: get(p.contact_damping),
    };
    if change.names().is_empty() {
        return Err("change_dynamics needs at least one property: mass, lateral_friction, \
                    spinning_friction, rolling_friction, restitution, linear_damping, \
                    angular_damping, contact_stiffness or contact_damping"
            .into());
    }
    Ok(Command::ChangeDynamics {
        object_id: p.object_id.0,
        link_index,
        change,
    })
}

pub(super) fn decide_remove(p: ObjectRef) -> Result<Command, Refusal> {
    Ok(Command::RemoveObject { object_id: p.object_id.0 })
}

#[tool_router(router = object_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Add a box. dimensions are HALF-extents (PyBullet convention).
    #[tool(input_schema = schema_for_type::<params::AddBox>())]
    async fn add_box(&self, args: JsonObject) -> Result<Json<ObjectAdded>, String> {
        self.change("add_box", args, decide_box).await
    }

    /// Add a sphere.
    #[tool(input_schema = schema_for_type::<params::AddSphere>())]
    async fn add_sphere(&self, args: JsonObject) -> Result<Json<ObjectAdded>, String> {
        self.change("add_sphere", args, decide_sphere).await
    }

    /// Add a cylinder along local z; height is the full height.
    #[tool(input_schema = schema_for_type::<params::AddRound>())]
    async fn add_cylinder(&self, args: JsonObject) -> Result<Json<ObjectAdded>, String> {
        self.change("add_cylinder", args, decide_cylinder).await
    }

    /// Add a capsule along local z; height is the cylindrical part.
    #[tool(input_schema = schema_for_type::<params::AddRound>())]
    async fn add_capsule(&self, args: JsonObject) -> Result<Json<ObjectAdded>, String> {
        self.change("add_capsule", args, decide_capsule).await
    }

    /// Teleport an object (velocities are kept).
    #[tool(input_schema = schema_for_type::<params::SetPose>())]
    async fn set_object_pose(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("set_object_pose", args, decide_pose).await
    }

    /// An object's position, orientation, linear and angular velocity.
    #[tool(
        input_schema = schema_for_type::<params::ObjectRef>(),
        annotations(read_only_hint = true)
    )]
    async fn get_object_state(&self, args: JsonObject) -> Result<Json<ObjectState>, String> {
        self.read("get_object_state", args, |sim, p| reads::object_state(&sim.read_context(), &p))
            .await
    }

    /// Apply a force for the NEXT STEP ONLY.
    #[tool(input_schema = schema_for_type::<params::ApplyForce>())]
    async fn apply_force(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("apply_force", args, decide_force).await
    }

    /// Apply a torque for the NEXT STEP ONLY.
    #[tool(input_schema = schema_for_type::<params::ApplyTorque>())]
    async fn apply_torque(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("apply_torque", args, decide_torque).await
    }

    /// Set linear and/or angular velocity.
    #[tool(input_schema = schema_for_type::<params::SetVelocity>())]
    async fn set_object_velocity(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("set_object_velocity", args, decide_velocity).await
    }

    /// Change mass, friction, restitution, damping or contact properties (friction and
    /// restitution multiply).
    #[tool(input_schema = schema_for_type::<params::ChangeDynamics>())]
    async fn change_dynamics(&self, args: JsonObject) -> Result<Json<DynamicsChanged>, String> {
        self.change("change_dynamics", args, decide_dynamics).await
    }

    /// Mass, friction, inertia, restitution, damping, contacts, body type.
    #[tool(
        input_schema = schema_for_type::<params::DynamicsRef>(),
        annotations(read_only_hint = true)
    )]
    async fn get_dynamics_info(&self, args: JsonObject) -> Result<Json<DynamicsInfo>, String> {
        self.read("get_dynamics_info", args, |sim, p| reads::dynamics_info(&sim.read_context(), &p))
            .await
    }

    /// Remove an object (undo brings it back).
    #[tool(
        input_schema = schema_for_type::<params::ObjectRef>(),
        annotations(destructive_hint = true)
    )]
    async fn remove_object(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("remove_object", args, decide_remove).await
    }

    /// Parts touch when either's group meets the other's mask (default 1, all; static 2, all but 2).
    #[tool(input_schema = schema_for_type::<params::CollisionFilterGroupMask>())]
    async fn set_collision_filter_group_mask(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("set_collision_filter_group_mask", args, decide_filter).await
    }

    /// Turn contacts between two parts off or on, whatever the masks.
    #[tool(input_schema = schema_for_type::<params::CollisionFilterPair>())]
    async fn set_collision_filter_pair(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("set_collision_filter_pair", args, decide_pair).await
    }
}
