//! Tool parameters: the types each tool's arguments are parsed as, whose JSON Schemas (their
//! `///` comments become the descriptions) are the tools' input schemas — one model, so the
//! schema a client reads is exactly what the server accepts.
//!
//! `parse` reads a call's raw argument object into one of these types: an unknown parameter
//! is refused (naming the closest known one), a missing required one is refused with its
//! description, and a value is read by the lenient types of `lenient.rs`; every refusal is one
//! sentence naming the parameter. The raw arguments are still what the log records.

pub mod lenient;

use std::any::TypeId;
use std::collections::BTreeMap;
use std::sync::{Arc, LazyLock, Mutex};

use schemars::JsonSchema;
use serde::de::DeserializeOwned;
use serde::Deserialize;
use serde_json::Value;

use self::lenient::{
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
    /// m/s² (default [0, 0, -9.81]); a number g means [0, 0, g].
    pub gravity: Option<Gravity>,
    /// Web viewer (default false).
    pub gui: Option<Bool>,
}

/// Parameters naming just a simulation.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SimRef {
    /// Simulation id.
    pub sim_id: Text,
}

/// step_simulation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Step {
    /// Simulation id.
    pub sim_id: Text,
    /// Default 1, at most --max-steps.
    pub steps: Option<Int<u64>>,
    /// Also return poses every N steps.
    pub sample_every: Option<Int<u64>>,
    /// Default all.
    pub sample_objects: Option<Vec<ObjectId>>,
}

/// set_timestep parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SetTimestep {
    /// Simulation id.
    pub sim_id: Text,
    /// Seconds per step (default 1/240).
    pub timestep: PositiveGiven,
}

/// add_box parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct AddBox {
    /// Simulation id.
    pub sim_id: Text,
    /// HALF-extents [hx, hy, hz] (m).
    pub dimensions: Vec3,
    /// World (m).
    pub position: Vec3,
    /// kg (default 1; 0 = static).
    pub mass: Option<NonNegative>,
    /// RGB(A) in [0, 1].
    pub color: Option<Color>,
    /// Default identity.
    pub orientation: Option<Quat>,
}

/// add_sphere parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct AddSphere {
    /// Simulation id.
    pub sim_id: Text,
    /// Radius (m).
    pub radius: Positive,
    /// World (m).
    pub position: Vec3,
    /// kg (default 1; 0 = static).
    pub mass: Option<NonNegative>,
    /// RGB(A) in [0, 1].
    pub color: Option<Color>,
    /// Default identity.
    pub orientation: Option<Quat>,
}

/// add_cylinder / add_capsule parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct AddRound {
    /// Simulation id.
    pub sim_id: Text,
    /// Radius (m).
    pub radius: Positive,
    /// Along local z (m).
    pub height: Positive,
    /// World (m).
    pub position: Vec3,
    /// kg (default 1; 0 = static).
    pub mass: Option<NonNegative>,
    /// RGB(A) in [0, 1].
    pub color: Option<Color>,
    /// Default identity.
    pub orientation: Option<Quat>,
}

/// Parameters naming an object.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ObjectRef {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id.
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
    /// World (m).
    pub position: Vec3,
    /// Default identity.
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
    /// N, world frame.
    pub force: Vec3,
    /// World point (default: centre of mass).
    pub position: Option<Vec3>,
    /// Default -1 (base).
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
    /// N·m, world frame.
    pub torque: Vec3,
    /// Default -1 (base).
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
    /// m/s.
    pub linear_velocity: Option<Vec3>,
    /// rad/s.
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
    /// Default -1 (base).
    pub link_index: Option<Int<i64>>,
    /// kg (0 = static).
    pub mass: Option<NonNegative>,
    /// Coulomb coefficient.
    pub lateral_friction: Option<NonNegative>,
    /// Stored, not simulated.
    pub spinning_friction: Option<NonNegative>,
    /// Stored, not simulated.
    pub rolling_friction: Option<NonNegative>,
    /// Bounce needs both bodies > 0.
    pub restitution: Option<NonNegative>,
    /// Default 0.04.
    pub linear_damping: Option<NonNegative>,
    /// Default 0.04.
    pub angular_damping: Option<NonNegative>,
    /// Stored, not simulated.
    pub contact_stiffness: Option<NonNegative>,
    /// Stored, not simulated.
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
    /// Default -1 (base).
    pub link_index: Option<Int<i64>>,
}

/// undo / redo parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Count {
    /// Simulation id.
    pub sim_id: Text,
    /// Default 1.
    pub count: Option<Int<u64>>,
}

/// get_history parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct HistoryPage {
    /// Simulation id.
    pub sim_id: Text,
    /// Events after this seq (default 0).
    pub since_seq: Option<Int<u64>>,
    /// 1-1000 (default 50).
    pub limit: Option<Int<u64>>,
}

/// fork_simulation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Fork {
    /// Simulation id.
    pub sim_id: Text,
    /// Default: the head.
    pub at_seq: Option<Int<u64>>,
}

/// save_simulation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Save {
    /// Simulation id.
    pub sim_id: Text,
    /// Workspace-relative .json path.
    pub file_path: Text,
    /// Replace a non-save file (default false).
    pub overwrite: Option<Bool>,
}

/// load_simulation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Load {
    /// Workspace-relative saved file.
    pub file_path: Text,
    /// Web viewer (default false).
    pub gui: Option<Bool>,
}

/// load_urdf parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct LoadUrdf {
    /// Simulation id.
    pub sim_id: Text,
    /// Workspace-relative URDF, or a built-in.
    pub file_path: Text,
    /// Base position (default origin).
    pub position: Option<Vec3>,
    /// Default identity.
    pub orientation: Option<Quat>,
    /// Fix the base (default false).
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
    /// Object id.
    pub object_id: ObjectId,
    /// PyBullet numbering.
    pub joint_index: Int<u32>,
}

/// set_joint_motor_control parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct MotorControl {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// PyBullet numbering.
    pub joint_index: Int<u32>,
    /// POSITION_CONTROL, VELOCITY_CONTROL or TORQUE_CONTROL.
    pub control_mode: Text,
    /// rad or m; required for POSITION_CONTROL.
    pub target_position: Option<Num>,
    /// Default 0.
    pub target_velocity: Option<Num>,
    /// Max effort (default: URDF limit, else 500); the torque for TORQUE_CONTROL.
    pub force: Option<Num>,
    /// Default 0.1.
    pub position_gain: Option<NonNegative>,
    /// Default 1.
    pub velocity_gain: Option<NonNegative>,
}

/// calculate_inverse_kinematics parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct InverseKinematics {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// The link to place.
    pub end_effector_link_index: Int<u32>,
    /// World (m).
    pub target_position: Vec3,
    /// Optional.
    pub target_orientation: Option<Quat>,
    /// Default: the URDF's.
    pub lower_limits: Option<NumList>,
    /// Default: the URDF's.
    pub upper_limits: Option<NumList>,
    /// Accepted, ignored (PyBullet).
    pub joint_ranges: Option<NumList>,
    /// Start pose (default: current).
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
    /// Box half-extents, [radius] or [radius, height].
    pub parent_dimensions: NumList,
    /// As parent_dimensions.
    pub child_dimensions: NumList,
    /// kg (default 1).
    pub parent_mass: Option<Positive>,
    /// kg (default 1).
    pub child_mass: Option<Positive>,
    /// Parent frame (default [0, 0, 1]).
    pub joint_axis: Option<Vec3>,
    /// Parent frame (default origin).
    pub joint_origin: Option<Vec3>,
    /// rad (default -3.14159).
    pub joint_lower_limit: Option<Num>,
    /// rad (default 3.14159).
    pub joint_upper_limit: Option<Num>,
    /// Default 100.
    pub max_effort: Option<NonNegative>,
    /// Default 10.
    pub max_velocity: Option<NonNegative>,
    /// Default generated/revolute_<n>.urdf.
    pub output_path: Option<Text>,
    /// Replace a file it did not write (default false).
    pub overwrite: Option<Bool>,
}

/// create_constraint parameters (PyBullet's createConstraint, plus revolute).
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CreateConstraint {
    /// Simulation id.
    pub sim_id: Text,
    /// Parent object.
    pub parent_id: ObjectId,
    /// Child object, or -1: the world.
    pub child_id: Int<i64>,
    /// fixed, prismatic, spherical or revolute.
    pub joint_type: Text,
    /// Parent frame (default [0, 0, 1]).
    pub joint_axis: Option<Vec3>,
    /// Parent body frame (default origin).
    pub parent_frame_position: Option<Vec3>,
    /// Child body frame, or world if child_id -1.
    pub child_frame_position: Option<Vec3>,
    /// Default identity.
    pub parent_frame_orientation: Option<Quat>,
    /// Default identity.
    pub child_frame_orientation: Option<Quat>,
}

/// remove_constraint parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ConstraintRef {
    /// Simulation id.
    pub sim_id: Text,
    /// Constraint id.
    pub constraint_id: Int<u32>,
}

/// ray_test parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct RayTest {
    /// Simulation id.
    pub sim_id: Text,
    /// Start, world.
    pub ray_from: Vec3,
    /// End, world.
    pub ray_to: Vec3,
}

/// ray_test_batch parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct RayTestBatch {
    /// Simulation id.
    pub sim_id: Text,
    /// Starts (at most --max-rays).
    pub rays_from: Vec3List,
    /// Ends, one per start.
    pub rays_to: Vec3List,
    /// New .json file.
    pub output_path: Option<Text>,
}

/// get_collisions_for_pair parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CollisionPair {
    /// Simulation id.
    pub sim_id: Text,
    /// Object A.
    pub obj_a: ObjectId,
    /// Object B.
    pub obj_b: ObjectId,
}

/// compute_view_matrix parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ViewMatrix {
    /// Eye.
    pub camera_eye_position: Vec3d,
    /// Target.
    pub camera_target_position: Vec3d,
    /// Up.
    pub camera_up_vector: Vec3d,
}

/// compute_view_matrix_from_yaw_pitch parameters (roll 0).
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ViewMatrixYawPitch {
    /// Distance (m).
    pub distance: Num64,
    /// Degrees.
    pub yaw: Num64,
    /// Degrees.
    pub pitch: Num64,
    /// Target.
    pub target_position: Vec3d,
    /// 2: z up (default), 1: y up.
    pub up_axis_index: Option<Int<u8>>,
    /// Only 0.
    pub roll: Option<Num64>,
}

/// compute_projection_matrix parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ProjectionMatrix {
    /// Vertical, degrees.
    pub fov: Num64,
    /// Width / height.
    pub aspect: Num64,
    /// m, > 0.
    pub near_plane: Num64,
    /// m, > near_plane.
    pub far_plane: Num64,
}

/// get_camera_image parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CameraImage {
    /// Simulation id.
    pub sim_id: Text,
    /// Pixels.
    pub width: Int<u32>,
    /// Pixels.
    pub height: Int<u32>,
    /// 16 floats (default: set_camera).
    pub view_matrix: Option<Matrix>,
    /// 16 floats (default: fov 60).
    pub projection_matrix: Option<Matrix>,
    /// Ignored (PyBullet).
    pub renderer: Option<serde_json::Value>,
    /// Add per-pixel depth (m).
    pub include_depth: Option<Bool>,
    /// Add per-pixel object id (-1: none).
    pub include_segmentation: Option<Bool>,
    /// New .png file (arrays as <stem>.depth.npy, .seg.npy).
    pub output_path: Option<Text>,
}

/// enable_debug_visualization parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct DebugVisualization {
    /// Simulation id.
    pub sim_id: Text,
    /// Contact points (default true).
    pub show_contacts: Option<Bool>,
    /// Body frames (default false).
    pub show_frames: Option<Bool>,
}

/// set_camera parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SetCamera {
    /// Simulation id.
    pub sim_id: Text,
    /// Distance (m).
    pub distance: Positive,
    /// Degrees.
    pub yaw: Num,
    /// Degrees (< 0 looks down).
    pub pitch: Num,
    /// Point looked at.
    pub target: Vec3,
}

/// get_trajectory parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct GetTrajectory {
    /// Simulation id.
    pub sim_id: Text,
    /// Default: before the last step.
    pub from_seq: Option<Int<u64>>,
    /// Default: the head.
    pub to_seq: Option<Int<u64>>,
    /// Default: ~100 samples.
    pub every: Option<Int<u64>>,
    /// Default all.
    pub object_ids: Option<Vec<ObjectId>>,
    /// Default false.
    pub include_velocities: Option<Bool>,
    /// New .csv or .jsonl file.
    pub output_path: Option<Text>,
}

/// render_animation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct RenderAnimation {
    /// Simulation id.
    pub sim_id: Text,
    /// Default: before the last step.
    pub from_seq: Option<Int<u64>>,
    /// Default: the head.
    pub to_seq: Option<Int<u64>>,
    /// Default: ~100 frames.
    pub every: Option<Int<u64>>,
    /// Pixels (default 320).
    pub width: Option<Int<u32>>,
    /// Pixels (default 240).
    pub height: Option<Int<u32>>,
    /// 1-50 (default 30).
    pub fps: Option<Int<u32>>,
    /// 16 floats (default: set_camera).
    pub view_matrix: Option<Matrix>,
    /// 16 floats (default: fov 60).
    pub projection_matrix: Option<Matrix>,
    /// New .gif file.
    pub output_path: Option<Text>,
}

/// get_link_state parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct LinkRef {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// -1 = base.
    pub link_index: Int<i32>,
}

/// reset_joint_state parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ResetJoint {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// PyBullet numbering.
    pub joint_index: Int<u32>,
    /// Position, rad or m.
    pub target_value: Num,
    /// Default 0.
    pub target_velocity: Option<Num>,
}

/// One call of a batch or of a sweep's variant.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CallSpec {
    /// Tool name.
    pub tool: String,
    /// Its arguments; sim_id may be omitted.
    pub arguments: Option<serde_json::Map<String, Value>>,
}

/// batch parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Batch {
    /// Simulation id.
    pub sim_id: Text,
    /// 1-10,000 calls, in order.
    pub calls: Vec<CallSpec>,
}

/// What run_sweep reports of each variant.
#[derive(Deserialize, JsonSchema, Debug, Clone, Default)]
#[serde(deny_unknown_fields)]
pub struct Observe {
    /// Default all.
    pub object_ids: Option<Vec<ObjectId>>,
    /// Default false.
    pub include_velocities: Option<Bool>,
    /// Also sample poses every N steps.
    pub every: Option<Int<u64>>,
}

/// run_sweep parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Sweep {
    /// Simulation id.
    pub sim_id: Text,
    /// 1-256 lists of calls, one fork each.
    pub variants: Vec<Vec<CallSpec>>,
    /// Steps after the calls.
    pub steps: Int<u64>,
    /// Default: final states of all objects.
    pub observe: Option<Observe>,
    /// Keep the forks (default false).
    pub keep: Option<Bool>,
}
