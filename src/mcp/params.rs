//! Tool parameters: the types each tool's arguments are parsed as, whose JSON Schemas (their
//! `///` comments become the descriptions) are the tools' input schemas — one model, so the
//! schema a client reads is exactly what the server accepts.
//!
//! `parse` reads a call's raw argument object into one of these types: an unknown parameter
//! is refused (naming the closest known one), a missing required one is refused with its
//! description, and a value is read by the lenient types of `lenient.rs`; every refusal is one
//! sentence naming the parameter. The raw arguments are still what the log records.

use std::any::TypeId;
use std::collections::BTreeMap;
use std::sync::{Arc, LazyLock, Mutex};

use schemars::JsonSchema;
use serde::de::DeserializeOwned;
use serde::Deserialize;
use serde_json::Value;

use super::lenient::{
    Bool, Color, Gravity, Int, Matrix, NonNegative, Num, Num64, NumList, ObjectId, Positive,
    PositiveGiven, Quat, Text, Vec3, Vec3List, Vec3d, FIELD,
};
use crate::value::{Args, Refusal};

/// Parses a call's arguments as `P` (see the module docs); `tool` names the call in errors.
pub fn parse<P: DeserializeOwned + JsonSchema + 'static>(tool: &str, args: &Args) -> Result<P, Refusal> {
    parse_with(tool, args, true)
}

/// `parse` for arguments recorded by an earlier release, which ignored unknown parameters:
/// those are dropped instead of refused, so an old log's reads replay as they were answered.
pub fn parse_recorded<P: DeserializeOwned + JsonSchema + 'static>(tool: &str, args: &Args) -> Result<P, Refusal> {
    parse_with(tool, args, false)
}

fn parse_with<P: DeserializeOwned + JsonSchema + 'static>(tool: &str, args: &Args, strict: bool) -> Result<P, Refusal> {
    let schema = schema_of::<P>();
    let known: Vec<&str> = schema
        .get("properties")
        .and_then(Value::as_object)
        .map(|p| p.keys().map(String::as_str).collect())
        .unwrap_or_default();
    let mut kept = Args::new();
    for (name, v) in args {
        if known.contains(&name.as_str()) {
            kept.insert(name.clone(), v.clone());
        } else if strict {
            return Err(unknown_parameter(tool, name, &known));
        }
    }
    let required = schema.get("required").and_then(Value::as_array).into_iter().flatten();
    for name in required.filter_map(Value::as_str) {
        if kept.get(name).is_none_or(Value::is_null) {
            let about = schema["properties"][name]["description"].as_str().unwrap_or("see the tool's input schema");
            let about = about.trim_end_matches('.').replace('\n', " ");
            return Err(format!("{name} is required: {about}"));
        }
    }
    serde_path_to_error::deserialize(Value::Object(kept)).map_err(|e| {
        let path = e.path().to_string();
        let why = e.into_inner().to_string();
        if why.contains(FIELD) {
            why.replace(FIELD, &path)
        } else {
            format!("{path}: {why}")
        }
    })
}

/// The JSON Schema of `P` as a JSON object (computed once per type).
pub fn schema_of<P: JsonSchema + 'static>() -> Arc<Value> {
    static SCHEMAS: LazyLock<Mutex<BTreeMap<TypeId, Arc<Value>>>> = LazyLock::new(Default::default);
    let mut schemas = SCHEMAS.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    schemas
        .entry(TypeId::of::<P>())
        .or_insert_with(|| Arc::new(schemars::schema_for!(P).to_value()))
        .clone()
}

/// The refusal of an unknown parameter: its name, the closest known one (edit distance ≤ 2)
/// and the known ones.
fn unknown_parameter(tool: &str, name: &str, known: &[&str]) -> Refusal {
    if known.is_empty() {
        return format!("Unknown parameter `{name}` for {tool}: it takes no parameters");
    }
    let closest = known
        .iter()
        .map(|k| (edit_distance(name, k), *k))
        .filter(|(d, _)| *d <= 2)
        .min();
    let hint = closest.map(|(_, k)| format!(" (did you mean `{k}`?)")).unwrap_or_default();
    format!("Unknown parameter `{name}` for {tool}{hint}; expected one of: {}", known.join(", "))
}

/// Levenshtein distance between two names.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diag = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let next = (diag + usize::from(ca != *cb)).min(row[j] + 1).min(row[j + 1] + 1);
            diag = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

/// No parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct NoParams {}

/// create_simulation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CreateSimulation {
    /// Gravity [gx, gy, gz] in m/s² (z-up; default [0, 0, -9.81]). A single number g or [g]
    /// means [0, 0, g].
    pub gravity: Option<Gravity>,
    /// Show this simulation in the built-in web viewer (default false).
    pub gui: Option<Bool>,
}

/// Parameters naming just a simulation.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SimRef {
    /// Simulation id (from create_simulation or list_simulations).
    pub sim_id: Text,
}

/// step_simulation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Step {
    /// Simulation id.
    pub sim_id: Text,
    /// Number of fixed timesteps to take (default 1, at most --max-steps).
    pub steps: Option<Int<u64>>,
    /// Also return `trajectory`: poses sampled every this many steps (get_trajectory's form).
    pub sample_every: Option<Int<u64>>,
    /// Objects to sample (default all).
    pub sample_objects: Option<Vec<ObjectId>>,
}

/// set_timestep parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SetTimestep {
    /// Simulation id.
    pub sim_id: Text,
    /// Seconds per step (> 0; PyBullet's default is 1/240).
    pub timestep: PositiveGiven,
}

/// add_box parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct AddBox {
    /// Simulation id.
    pub sim_id: Text,
    /// HALF-extents [hx, hy, hz] in metres (each > 0).
    pub dimensions: Vec3,
    /// World position [x, y, z] of the box centre.
    pub position: Vec3,
    /// Mass in kg (default 1; 0 = static).
    pub mass: Option<NonNegative>,
    /// RGBA (or RGB) color, components in [0, 1].
    pub color: Option<Color>,
    /// Orientation quaternion [x, y, z, w] (default identity).
    pub orientation: Option<Quat>,
}

/// add_sphere parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct AddSphere {
    /// Simulation id.
    pub sim_id: Text,
    /// Radius in metres (> 0).
    pub radius: Positive,
    /// World position [x, y, z] of the centre.
    pub position: Vec3,
    /// Mass in kg (default 1; 0 = static).
    pub mass: Option<NonNegative>,
    /// RGBA (or RGB) color, components in [0, 1].
    pub color: Option<Color>,
    /// Orientation quaternion [x, y, z, w] (default identity).
    pub orientation: Option<Quat>,
}

/// add_cylinder / add_capsule parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct AddRound {
    /// Simulation id.
    pub sim_id: Text,
    /// Radius in metres (> 0).
    pub radius: Positive,
    /// Height in metres (> 0): full height for a cylinder, the cylindrical part for a capsule.
    /// The axis is the body's local z.
    pub height: Positive,
    /// World position [x, y, z] of the centre.
    pub position: Vec3,
    /// Mass in kg (default 1; 0 = static).
    pub mass: Option<NonNegative>,
    /// RGBA (or RGB) color, components in [0, 1].
    pub color: Option<Color>,
    /// Orientation quaternion [x, y, z, w] (default identity).
    pub orientation: Option<Quat>,
}

/// Parameters naming an object.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ObjectRef {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id (from add_* or load_urdf).
    pub object_id: ObjectId,
}

/// set_object_pose parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SetPose {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// New world position [x, y, z].
    pub position: Vec3,
    /// New orientation quaternion [x, y, z, w] (normalised; default identity).
    pub orientation: Option<Quat>,
}

/// apply_force parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ApplyForce {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// Force [fx, fy, fz] in newtons, world frame.
    pub force: Vec3,
    /// World point where the force acts (default: the centre of mass, so no torque).
    pub position: Option<Vec3>,
    /// Link index (-1 = base, the only link of a primitive).
    pub link_index: Option<Int<i64>>,
}

/// apply_torque parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ApplyTorque {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// Torque [tx, ty, tz] in N·m, world frame.
    pub torque: Vec3,
    /// Link index (-1 = base).
    pub link_index: Option<Int<i64>>,
}

/// set_object_velocity parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SetVelocity {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// Linear velocity [vx, vy, vz] in m/s.
    pub linear_velocity: Option<Vec3>,
    /// Angular velocity [wx, wy, wz] in rad/s (world frame).
    pub angular_velocity: Option<Vec3>,
}

/// change_dynamics parameters: give at least one property; each must be ≥ 0.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ChangeDynamics {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// Link index (-1 = base).
    pub link_index: Option<Int<i64>>,
    /// Mass in kg (0 makes the body static).
    pub mass: Option<NonNegative>,
    /// Coulomb friction coefficient (combined by multiplying, as in Bullet).
    pub lateral_friction: Option<NonNegative>,
    /// Spinning friction (stored and reported; rapier does not simulate it).
    pub spinning_friction: Option<NonNegative>,
    /// Rolling friction (stored and reported; rapier does not simulate it).
    pub rolling_friction: Option<NonNegative>,
    /// Restitution (combined by multiplying: a ball bounces only if the ground's is > 0 too).
    pub restitution: Option<NonNegative>,
    /// Linear damping (PyBullet default 0.04).
    pub linear_damping: Option<NonNegative>,
    /// Angular damping (PyBullet default 0.04).
    pub angular_damping: Option<NonNegative>,
    /// Contact stiffness (stored and reported; rapier's contact softness is global).
    pub contact_stiffness: Option<NonNegative>,
    /// Contact damping (stored and reported; rapier's contact softness is global).
    pub contact_damping: Option<NonNegative>,
}

/// get_dynamics_info parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct DynamicsRef {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// Link index (-1 = base).
    pub link_index: Option<Int<i64>>,
}

/// undo / redo parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Count {
    /// Simulation id.
    pub sim_id: Text,
    /// How many state-changing events to move over (default 1).
    pub count: Option<Int<u64>>,
}

/// get_history parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct HistoryPage {
    /// Simulation id.
    pub sim_id: Text,
    /// Return events with seq greater than this (default 0: from the start).
    pub since_seq: Option<Int<u64>>,
    /// At most this many events (1–1000, default 50).
    pub limit: Option<Int<u64>>,
}

/// fork_simulation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Fork {
    /// The simulation to fork.
    pub sim_id: Text,
    /// A state-changing event of it to start from (default: its current head).
    pub at_seq: Option<Int<u64>>,
}

/// save_simulation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Save {
    /// Simulation id.
    pub sim_id: Text,
    /// Where to write the JSON file, relative to the workspace (folders are created).
    pub file_path: Text,
}

/// load_simulation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Load {
    /// A saved JSON file, relative to the workspace.
    pub file_path: Text,
    /// Show the loaded simulation in the web viewer (default false).
    pub gui: Option<Bool>,
}

/// load_urdf parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct LoadUrdf {
    /// Simulation id.
    pub sim_id: Text,
    /// URDF file relative to the workspace, or a built-in: plane.urdf, cube.urdf, sphere.urdf.
    pub file_path: Text,
    /// World position [x, y, z] of the base link frame (default [0, 0, 0]).
    pub position: Option<Vec3>,
    /// Base orientation [x, y, z, w] (default identity).
    pub orientation: Option<Quat>,
    /// Fix the base to the world (default false; a base of mass 0 is static anyway).
    pub use_fixed_base: Option<Bool>,
}

/// load_mjcf parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct LoadMjcf {
    /// Simulation id.
    pub sim_id: Text,
    /// MuJoCo MJCF file relative to the workspace (its `<include>`s are read beside it).
    pub file_path: Text,
    /// World position [x, y, z] of the model's frame (default [0, 0, 0]).
    pub position: Option<Vec3>,
    /// Orientation [x, y, z, w] of the model's frame (default identity).
    pub orientation: Option<Quat>,
    /// Fix a free-joint root body to the world (default false).
    pub use_fixed_base: Option<Bool>,
    /// Name of a `<key>` whose qpos the joints start at (default: qpos0).
    pub keyframe: Option<Text>,
}

/// Parameters naming a joint of an object.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct JointRef {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id of the robot.
    pub object_id: ObjectId,
    /// Joint index (PyBullet numbering, from 0).
    pub joint_index: Int<u32>,
}

/// set_joint_motor_control parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct MotorControl {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id of the robot.
    pub object_id: ObjectId,
    /// Joint index (PyBullet numbering).
    pub joint_index: Int<u32>,
    /// POSITION_CONTROL, VELOCITY_CONTROL or TORQUE_CONTROL.
    pub control_mode: Text,
    /// Target position (rad or m); required for POSITION_CONTROL.
    pub target_position: Option<Num>,
    /// Target velocity (default 0).
    pub target_velocity: Option<Num>,
    /// Maximum effort (POSITION/VELOCITY; default the URDF effort limit, else 500) or the
    /// torque to apply (TORQUE_CONTROL; required).
    pub force: Option<Num>,
    /// Position gain (default 0.1).
    pub position_gain: Option<NonNegative>,
    /// Velocity gain (default 1.0).
    pub velocity_gain: Option<NonNegative>,
}

/// calculate_inverse_kinematics parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct InverseKinematics {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id of the robot.
    pub object_id: ObjectId,
    /// The link whose frame must reach the target.
    pub end_effector_link_index: Int<u32>,
    /// Target position [x, y, z] (world).
    pub target_position: Vec3,
    /// Target orientation [x, y, z, w] (world), optional.
    pub target_orientation: Option<Quat>,
    /// Lower limits, one per movable joint (default: the URDF's).
    pub lower_limits: Option<NumList>,
    /// Upper limits, one per movable joint (default: the URDF's).
    pub upper_limits: Option<NumList>,
    /// Joint ranges, one per movable joint (accepted for PyBullet compatibility).
    pub joint_ranges: Option<NumList>,
    /// Starting configuration, one per movable joint (default: the current one).
    pub rest_poses: Option<NumList>,
}

/// generate_revolute_joint parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct GenerateRevolute {
    /// box, sphere or cylinder.
    pub parent_shape: Text,
    /// box, sphere or cylinder.
    pub child_shape: Text,
    /// Box half-extents [hx, hy, hz], sphere [radius], cylinder [radius, height].
    pub parent_dimensions: NumList,
    /// As parent_dimensions.
    pub child_dimensions: NumList,
    /// Parent mass in kg (default 1).
    pub parent_mass: Option<Positive>,
    /// Child mass in kg (default 1).
    pub child_mass: Option<Positive>,
    /// Joint axis in the parent frame (default [0, 0, 1]).
    pub joint_axis: Option<Vec3>,
    /// Joint position in the parent frame (default [0, 0, 0]).
    pub joint_origin: Option<Vec3>,
    /// Lower limit in rad (default -3.14159).
    pub joint_lower_limit: Option<Num>,
    /// Upper limit in rad (default 3.14159).
    pub joint_upper_limit: Option<Num>,
    /// Effort limit (default 100).
    pub max_effort: Option<NonNegative>,
    /// Velocity limit (default 10).
    pub max_velocity: Option<NonNegative>,
    /// Where to write, relative to the workspace (default generated/revolute_<n>.urdf).
    pub output_path: Option<Text>,
}

/// create_constraint parameters (PyBullet's createConstraint, plus revolute).
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CreateConstraint {
    /// Simulation id.
    pub sim_id: Text,
    /// The parent object.
    pub parent_id: ObjectId,
    /// The child object, or -1 for the world.
    pub child_id: Int<i64>,
    /// fixed, prismatic, spherical (PyBullet's point2point) or revolute.
    pub joint_type: Text,
    /// Free axis of a prismatic or revolute joint, in the parent's constraint frame
    /// (default [0, 0, 1]).
    pub joint_axis: Option<Vec3>,
    /// Joint position in the parent's body frame (default [0, 0, 0]).
    pub parent_frame_position: Option<Vec3>,
    /// Joint position in the child's body frame, or in world coordinates when child_id is -1
    /// (default [0, 0, 0]).
    pub child_frame_position: Option<Vec3>,
    /// Joint orientation in the parent's frame, quaternion [x, y, z, w] (default identity).
    pub parent_frame_orientation: Option<Quat>,
    /// Joint orientation in the child's frame (world when child_id is -1; default identity).
    pub child_frame_orientation: Option<Quat>,
}

/// remove_constraint parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ConstraintRef {
    /// Simulation id.
    pub sim_id: Text,
    /// Constraint id (from create_constraint).
    pub constraint_id: Int<u32>,
}

/// ray_test parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct RayTest {
    /// Simulation id.
    pub sim_id: Text,
    /// Start of the ray, world [x, y, z].
    pub ray_from: Vec3,
    /// End of the ray, world [x, y, z].
    pub ray_to: Vec3,
}

/// ray_test_batch parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct RayTestBatch {
    /// Simulation id.
    pub sim_id: Text,
    /// Starts of the rays (at least 1, at most --max-rays).
    pub rays_from: Vec3List,
    /// Ends of the rays, as many as rays_from.
    pub rays_to: Vec3List,
}

/// get_collisions_for_pair parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CollisionPair {
    /// Simulation id.
    pub sim_id: Text,
    /// Object A (contact normals point from B to A).
    pub obj_a: ObjectId,
    /// Object B.
    pub obj_b: ObjectId,
}

/// compute_view_matrix parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ViewMatrix {
    /// Camera position [x, y, z].
    pub camera_eye_position: Vec3d,
    /// Point looked at [x, y, z].
    pub camera_target_position: Vec3d,
    /// Up direction [x, y, z] (not parallel to the view direction).
    pub camera_up_vector: Vec3d,
}

/// compute_view_matrix_from_yaw_pitch parameters (roll 0).
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ViewMatrixYawPitch {
    /// Distance from the camera to the target (m).
    pub distance: Num64,
    /// Yaw in degrees.
    pub yaw: Num64,
    /// Pitch in degrees.
    pub pitch: Num64,
    /// Point looked at [x, y, z].
    pub target_position: Vec3d,
    /// 2 = z up (default), 1 = y up.
    pub up_axis_index: Option<Int<u8>>,
    /// Roll in degrees: only 0 (accepted for PyBullet compatibility).
    pub roll: Option<Num64>,
}

/// compute_projection_matrix parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ProjectionMatrix {
    /// Vertical field of view in degrees, in (0, 180).
    pub fov: Num64,
    /// Width / height, > 0.
    pub aspect: Num64,
    /// Near clipping distance, > 0.
    pub near_plane: Num64,
    /// Far clipping distance, > near_plane.
    pub far_plane: Num64,
}

/// get_camera_image parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CameraImage {
    /// Simulation id.
    pub sim_id: Text,
    /// Image width in pixels (width x height at most --max-image-px).
    pub width: Int<u32>,
    /// Image height in pixels.
    pub height: Int<u32>,
    /// 16 floats, column-major (from compute_view_matrix*); default: the simulation's viewer
    /// camera (set_camera).
    pub view_matrix: Option<Matrix>,
    /// 16 floats, column-major (from compute_projection_matrix); default: fov 60, the image's
    /// aspect, near 0.01, far 100.
    pub projection_matrix: Option<Matrix>,
    /// Accepted for PyBullet compatibility and ignored (there is one CPU renderer).
    pub renderer: Option<serde_json::Value>,
    /// Also return the depth of every pixel (metres along the view axis, row-major).
    pub include_depth: Option<Bool>,
    /// Also return the object id of every pixel (-1 background, row-major).
    pub include_segmentation: Option<Bool>,
}

/// enable_debug_visualization parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct DebugVisualization {
    /// Simulation id.
    pub sim_id: Text,
    /// Draw contact points (default true).
    pub show_contacts: Option<Bool>,
    /// Draw body frames (default false).
    pub show_frames: Option<Bool>,
}

/// set_camera parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SetCamera {
    /// Simulation id.
    pub sim_id: Text,
    /// Distance from the camera to the target (m, > 0).
    pub distance: Positive,
    /// Yaw in degrees.
    pub yaw: Num,
    /// Pitch in degrees (negative looks down).
    pub pitch: Num,
    /// The point looked at [x, y, z].
    pub target: Vec3,
}

/// get_trajectory parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct GetTrajectory {
    /// Simulation id.
    pub sim_id: Text,
    /// State-changing event whose resulting state starts the interval (default: the state
    /// just before the last step_simulation).
    pub from_seq: Option<Int<u64>>,
    /// State-changing event that ends the interval (default: the head).
    pub to_seq: Option<Int<u64>>,
    /// Steps between samples (default: about 100 samples).
    pub every: Option<Int<u64>>,
    /// Objects to sample (default: all).
    pub object_ids: Option<Vec<ObjectId>>,
    /// Also sample velocities (default false).
    pub include_velocities: Option<Bool>,
    /// Write the whole table to this .csv or .jsonl file in the workspace; reply a summary.
    pub output_path: Option<Text>,
}

/// render_animation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct RenderAnimation {
    /// Simulation id.
    pub sim_id: Text,
    /// The interval starts at the state after this state-changing event of the chain
    /// (default: just before the most recent step_simulation).
    pub from_seq: Option<Int<u64>>,
    /// The interval ends at the state after this state-changing event (default: the head).
    pub to_seq: Option<Int<u64>>,
    /// Steps between frames (default: about 100 frames over the interval).
    pub every: Option<Int<u64>>,
    /// Frame width in pixels (default 320; width x height at most --max-image-px).
    pub width: Option<Int<u32>>,
    /// Frame height in pixels (default 240).
    pub height: Option<Int<u32>>,
    /// Frames per second when played, 1 to 50 (default 30).
    pub fps: Option<Int<u32>>,
    /// 16 floats, column-major; default: the viewer camera (set_camera) at each frame.
    pub view_matrix: Option<Matrix>,
    /// 16 floats, column-major; default: fov 60, the frames' aspect, near 0.01, far 100.
    pub projection_matrix: Option<Matrix>,
    /// Write the GIF to this .gif file in the workspace instead of returning it inline.
    pub output_path: Option<Text>,
}

/// get_link_state parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct LinkRef {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id of the robot.
    pub object_id: ObjectId,
    /// Link index (PyBullet numbering; -1 = the base).
    pub link_index: Int<i32>,
}

/// reset_joint_state parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ResetJoint {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id of the robot.
    pub object_id: ObjectId,
    /// Joint index (PyBullet numbering).
    pub joint_index: Int<u32>,
    /// New joint position (rad or m).
    pub target_value: Num,
    /// New joint velocity (default 0).
    pub target_velocity: Option<Num>,
}
