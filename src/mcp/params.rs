//! Input schemas of the tools. These types only *describe* parameters (their `///` comments
//! become the schema descriptions); arguments arrive as a raw JSON object and are parsed by
//! `value.rs`, so that a wrong type is a clear tool error (isError), not a JSON-RPC failure,
//! and the raw arguments can be logged exactly as sent.
#![allow(dead_code)]

use schemars::JsonSchema;

/// No parameters.
#[derive(JsonSchema)]
pub struct NoParams {}

/// create_simulation parameters.
#[derive(JsonSchema)]
pub struct CreateSimulation {
    /// Gravity [gx, gy, gz] in m/s² (z-up; default [0, 0, -9.81]). A single number g or [g]
    /// means [0, 0, g].
    pub gravity: Option<[f64; 3]>,
    /// Show this simulation in the built-in web viewer (default false).
    pub gui: Option<bool>,
}

/// Parameters naming just a simulation.
#[derive(JsonSchema)]
pub struct SimRef {
    /// Simulation id (from create_simulation or list_simulations).
    pub sim_id: String,
}

/// step_simulation parameters.
#[derive(JsonSchema)]
pub struct Step {
    /// Simulation id.
    pub sim_id: String,
    /// Number of fixed timesteps to take (default 1, at most --max-steps).
    pub steps: Option<u64>,
    /// Also return `trajectory`: poses sampled every this many steps (get_trajectory's form).
    pub sample_every: Option<u64>,
    /// Objects to sample (default all).
    pub sample_objects: Option<Vec<u32>>,
}

/// set_timestep parameters.
#[derive(JsonSchema)]
pub struct SetTimestep {
    /// Simulation id.
    pub sim_id: String,
    /// Seconds per step (> 0; PyBullet's default is 1/240).
    pub timestep: f64,
}

/// add_box parameters.
#[derive(JsonSchema)]
pub struct AddBox {
    /// Simulation id.
    pub sim_id: String,
    /// HALF-extents [hx, hy, hz] in metres (each > 0).
    pub dimensions: [f64; 3],
    /// World position [x, y, z] of the box centre.
    pub position: [f64; 3],
    /// Mass in kg (default 1; 0 = static).
    pub mass: Option<f64>,
    /// RGBA (or RGB) color, components in [0, 1].
    pub color: Option<Vec<f64>>,
    /// Orientation quaternion [x, y, z, w] (default identity).
    pub orientation: Option<[f64; 4]>,
}

/// add_sphere parameters.
#[derive(JsonSchema)]
pub struct AddSphere {
    /// Simulation id.
    pub sim_id: String,
    /// Radius in metres (> 0).
    pub radius: f64,
    /// World position [x, y, z] of the centre.
    pub position: [f64; 3],
    /// Mass in kg (default 1; 0 = static).
    pub mass: Option<f64>,
    /// RGBA (or RGB) color, components in [0, 1].
    pub color: Option<Vec<f64>>,
    /// Orientation quaternion [x, y, z, w] (default identity).
    pub orientation: Option<[f64; 4]>,
}

/// add_cylinder / add_capsule parameters.
#[derive(JsonSchema)]
pub struct AddRound {
    /// Simulation id.
    pub sim_id: String,
    /// Radius in metres (> 0).
    pub radius: f64,
    /// Height in metres (> 0): full height for a cylinder, the cylindrical part for a capsule.
    /// The axis is the body's local z.
    pub height: f64,
    /// World position [x, y, z] of the centre.
    pub position: [f64; 3],
    /// Mass in kg (default 1; 0 = static).
    pub mass: Option<f64>,
    /// RGBA (or RGB) color, components in [0, 1].
    pub color: Option<Vec<f64>>,
    /// Orientation quaternion [x, y, z, w] (default identity).
    pub orientation: Option<[f64; 4]>,
}

/// Parameters naming an object.
#[derive(JsonSchema)]
pub struct ObjectRef {
    /// Simulation id.
    pub sim_id: String,
    /// Object id (from add_* or load_urdf).
    pub object_id: u32,
}

/// set_object_pose parameters.
#[derive(JsonSchema)]
pub struct SetPose {
    /// Simulation id.
    pub sim_id: String,
    /// Object id.
    pub object_id: u32,
    /// New world position [x, y, z].
    pub position: [f64; 3],
    /// New orientation quaternion [x, y, z, w] (normalised; default identity).
    pub orientation: Option<[f64; 4]>,
}

/// apply_force parameters.
#[derive(JsonSchema)]
pub struct ApplyForce {
    /// Simulation id.
    pub sim_id: String,
    /// Object id.
    pub object_id: u32,
    /// Force [fx, fy, fz] in newtons, world frame.
    pub force: [f64; 3],
    /// World point where the force acts (default: the centre of mass, so no torque).
    pub position: Option<[f64; 3]>,
    /// Link index (-1 = base, the only link of a primitive).
    pub link_index: Option<i64>,
}

/// apply_torque parameters.
#[derive(JsonSchema)]
pub struct ApplyTorque {
    /// Simulation id.
    pub sim_id: String,
    /// Object id.
    pub object_id: u32,
    /// Torque [tx, ty, tz] in N·m, world frame.
    pub torque: [f64; 3],
    /// Link index (-1 = base).
    pub link_index: Option<i64>,
}

/// set_object_velocity parameters.
#[derive(JsonSchema)]
pub struct SetVelocity {
    /// Simulation id.
    pub sim_id: String,
    /// Object id.
    pub object_id: u32,
    /// Linear velocity [vx, vy, vz] in m/s.
    pub linear_velocity: Option<[f64; 3]>,
    /// Angular velocity [wx, wy, wz] in rad/s (world frame).
    pub angular_velocity: Option<[f64; 3]>,
}

/// change_dynamics parameters: give at least one property; each must be ≥ 0.
#[derive(JsonSchema)]
pub struct ChangeDynamics {
    /// Simulation id.
    pub sim_id: String,
    /// Object id.
    pub object_id: u32,
    /// Link index (-1 = base).
    pub link_index: Option<i64>,
    /// Mass in kg (0 makes the body static).
    pub mass: Option<f64>,
    /// Coulomb friction coefficient (combined by multiplying, as in Bullet).
    pub lateral_friction: Option<f64>,
    /// Spinning friction (stored and reported; rapier does not simulate it).
    pub spinning_friction: Option<f64>,
    /// Rolling friction (stored and reported; rapier does not simulate it).
    pub rolling_friction: Option<f64>,
    /// Restitution (combined by multiplying: a ball bounces only if the ground's is > 0 too).
    pub restitution: Option<f64>,
    /// Linear damping (PyBullet default 0.04).
    pub linear_damping: Option<f64>,
    /// Angular damping (PyBullet default 0.04).
    pub angular_damping: Option<f64>,
    /// Contact stiffness (stored and reported; rapier's contact softness is global).
    pub contact_stiffness: Option<f64>,
    /// Contact damping (stored and reported; rapier's contact softness is global).
    pub contact_damping: Option<f64>,
}

/// get_dynamics_info parameters.
#[derive(JsonSchema)]
pub struct DynamicsRef {
    /// Simulation id.
    pub sim_id: String,
    /// Object id.
    pub object_id: u32,
    /// Link index (-1 = base).
    pub link_index: Option<i64>,
}

/// undo / redo parameters.
#[derive(JsonSchema)]
pub struct Count {
    /// Simulation id.
    pub sim_id: String,
    /// How many state-changing events to move over (default 1).
    pub count: Option<u64>,
}

/// get_history parameters.
#[derive(JsonSchema)]
pub struct HistoryPage {
    /// Simulation id.
    pub sim_id: String,
    /// Return events with seq greater than this (default 0: from the start).
    pub since_seq: Option<u64>,
    /// At most this many events (1–1000, default 50).
    pub limit: Option<u64>,
}

/// fork_simulation parameters.
#[derive(JsonSchema)]
pub struct Fork {
    /// The simulation to fork.
    pub sim_id: String,
    /// A state-changing event of it to start from (default: its current head).
    pub at_seq: Option<u64>,
}

/// save_simulation parameters.
#[derive(JsonSchema)]
pub struct Save {
    /// Simulation id.
    pub sim_id: String,
    /// Where to write the JSON file, relative to the workspace (folders are created).
    pub file_path: String,
}

/// load_simulation parameters.
#[derive(JsonSchema)]
pub struct Load {
    /// A saved JSON file, relative to the workspace.
    pub file_path: String,
    /// Show the loaded simulation in the web viewer (default false).
    pub gui: Option<bool>,
}

/// load_urdf parameters.
#[derive(JsonSchema)]
pub struct LoadUrdf {
    /// Simulation id.
    pub sim_id: String,
    /// URDF file relative to the workspace, or a built-in: plane.urdf, cube.urdf, sphere.urdf.
    pub file_path: String,
    /// World position [x, y, z] of the base link frame (default [0, 0, 0]).
    pub position: Option<[f64; 3]>,
    /// Base orientation [x, y, z, w] (default identity).
    pub orientation: Option<[f64; 4]>,
    /// Fix the base to the world (default false; a base of mass 0 is static anyway).
    pub use_fixed_base: Option<bool>,
}

/// Parameters naming a joint of an object.
#[derive(JsonSchema)]
pub struct JointRef {
    /// Simulation id.
    pub sim_id: String,
    /// Object id of the robot.
    pub object_id: u32,
    /// Joint index (PyBullet numbering, from 0).
    pub joint_index: u32,
}

/// set_joint_motor_control parameters.
#[derive(JsonSchema)]
pub struct MotorControl {
    /// Simulation id.
    pub sim_id: String,
    /// Object id of the robot.
    pub object_id: u32,
    /// Joint index (PyBullet numbering).
    pub joint_index: u32,
    /// POSITION_CONTROL, VELOCITY_CONTROL or TORQUE_CONTROL.
    pub control_mode: String,
    /// Target position (rad or m); required for POSITION_CONTROL.
    pub target_position: Option<f64>,
    /// Target velocity (default 0).
    pub target_velocity: Option<f64>,
    /// Maximum effort (POSITION/VELOCITY; default the URDF effort limit, else 500) or the
    /// torque to apply (TORQUE_CONTROL; required).
    pub force: Option<f64>,
    /// Position gain (default 0.1).
    pub position_gain: Option<f64>,
    /// Velocity gain (default 1.0).
    pub velocity_gain: Option<f64>,
}

/// calculate_inverse_kinematics parameters.
#[derive(JsonSchema)]
pub struct InverseKinematics {
    /// Simulation id.
    pub sim_id: String,
    /// Object id of the robot.
    pub object_id: u32,
    /// The link whose frame must reach the target.
    pub end_effector_link_index: u32,
    /// Target position [x, y, z] (world).
    pub target_position: [f64; 3],
    /// Target orientation [x, y, z, w] (world), optional.
    pub target_orientation: Option<[f64; 4]>,
    /// Lower limits, one per movable joint (default: the URDF's).
    pub lower_limits: Option<Vec<f64>>,
    /// Upper limits, one per movable joint (default: the URDF's).
    pub upper_limits: Option<Vec<f64>>,
    /// Joint ranges, one per movable joint (accepted for PyBullet compatibility).
    pub joint_ranges: Option<Vec<f64>>,
    /// Starting configuration, one per movable joint (default: the current one).
    pub rest_poses: Option<Vec<f64>>,
}

/// generate_revolute_joint parameters.
#[derive(JsonSchema)]
pub struct GenerateRevolute {
    /// box, sphere or cylinder.
    pub parent_shape: String,
    /// box, sphere or cylinder.
    pub child_shape: String,
    /// Box half-extents [hx, hy, hz], sphere [radius], cylinder [radius, height].
    pub parent_dimensions: Vec<f64>,
    /// As parent_dimensions.
    pub child_dimensions: Vec<f64>,
    /// Parent mass in kg (default 1).
    pub parent_mass: Option<f64>,
    /// Child mass in kg (default 1).
    pub child_mass: Option<f64>,
    /// Joint axis in the parent frame (default [0, 0, 1]).
    pub joint_axis: Option<[f64; 3]>,
    /// Joint position in the parent frame (default [0, 0, 0]).
    pub joint_origin: Option<[f64; 3]>,
    /// Lower limit in rad (default -3.14159).
    pub joint_lower_limit: Option<f64>,
    /// Upper limit in rad (default 3.14159).
    pub joint_upper_limit: Option<f64>,
    /// Effort limit (default 100).
    pub max_effort: Option<f64>,
    /// Velocity limit (default 10).
    pub max_velocity: Option<f64>,
    /// Where to write, relative to the workspace (default generated/revolute_<n>.urdf).
    pub output_path: Option<String>,
}

/// create_constraint parameters (PyBullet's createConstraint, plus revolute).
#[derive(JsonSchema)]
pub struct CreateConstraint {
    /// Simulation id.
    pub sim_id: String,
    /// The parent object.
    pub parent_id: u32,
    /// The child object, or -1 for the world.
    pub child_id: i64,
    /// fixed, prismatic, spherical (PyBullet's point2point) or revolute.
    pub joint_type: String,
    /// Free axis of a prismatic or revolute joint, in the parent's constraint frame
    /// (default [0, 0, 1]).
    pub joint_axis: Option<[f64; 3]>,
    /// Joint position in the parent's body frame (default [0, 0, 0]).
    pub parent_frame_position: Option<[f64; 3]>,
    /// Joint position in the child's body frame, or in world coordinates when child_id is -1
    /// (default [0, 0, 0]).
    pub child_frame_position: Option<[f64; 3]>,
    /// Joint orientation in the parent's frame, quaternion [x, y, z, w] (default identity).
    pub parent_frame_orientation: Option<[f64; 4]>,
    /// Joint orientation in the child's frame (world when child_id is -1; default identity).
    pub child_frame_orientation: Option<[f64; 4]>,
}

/// remove_constraint parameters.
#[derive(JsonSchema)]
pub struct ConstraintRef {
    /// Simulation id.
    pub sim_id: String,
    /// Constraint id (from create_constraint).
    pub constraint_id: u32,
}

/// ray_test parameters.
#[derive(JsonSchema)]
pub struct RayTest {
    /// Simulation id.
    pub sim_id: String,
    /// Start of the ray, world [x, y, z].
    pub ray_from: [f64; 3],
    /// End of the ray, world [x, y, z].
    pub ray_to: [f64; 3],
}

/// ray_test_batch parameters.
#[derive(JsonSchema)]
pub struct RayTestBatch {
    /// Simulation id.
    pub sim_id: String,
    /// Starts of the rays (at least 1, at most --max-rays).
    pub rays_from: Vec<[f64; 3]>,
    /// Ends of the rays, as many as rays_from.
    pub rays_to: Vec<[f64; 3]>,
}

/// get_collisions_for_pair parameters.
#[derive(JsonSchema)]
pub struct CollisionPair {
    /// Simulation id.
    pub sim_id: String,
    /// Object A (contact normals point from B to A).
    pub obj_a: u32,
    /// Object B.
    pub obj_b: u32,
}

/// compute_view_matrix parameters.
#[derive(JsonSchema)]
pub struct ViewMatrix {
    /// Camera position [x, y, z].
    pub camera_eye_position: [f64; 3],
    /// Point looked at [x, y, z].
    pub camera_target_position: [f64; 3],
    /// Up direction [x, y, z] (not parallel to the view direction).
    pub camera_up_vector: [f64; 3],
}

/// compute_view_matrix_from_yaw_pitch parameters (roll 0).
#[derive(JsonSchema)]
pub struct ViewMatrixYawPitch {
    /// Distance from the camera to the target (m).
    pub distance: f64,
    /// Yaw in degrees.
    pub yaw: f64,
    /// Pitch in degrees.
    pub pitch: f64,
    /// Point looked at [x, y, z].
    pub target_position: [f64; 3],
    /// 2 = z up (default), 1 = y up.
    pub up_axis_index: Option<u8>,
}

/// compute_projection_matrix parameters.
#[derive(JsonSchema)]
pub struct ProjectionMatrix {
    /// Vertical field of view in degrees, in (0, 180).
    pub fov: f64,
    /// Width / height, > 0.
    pub aspect: f64,
    /// Near clipping distance, > 0.
    pub near_plane: f64,
    /// Far clipping distance, > near_plane.
    pub far_plane: f64,
}

/// get_camera_image parameters.
#[derive(JsonSchema)]
pub struct CameraImage {
    /// Simulation id.
    pub sim_id: String,
    /// Image width in pixels (width x height at most --max-image-px).
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// 16 floats, column-major (from compute_view_matrix*); default: the simulation's viewer
    /// camera (set_camera).
    pub view_matrix: Option<Vec<f64>>,
    /// 16 floats, column-major (from compute_projection_matrix); default: fov 60, the image's
    /// aspect, near 0.01, far 100.
    pub projection_matrix: Option<Vec<f64>>,
    /// Accepted for PyBullet compatibility and ignored (there is one CPU renderer).
    pub renderer: Option<serde_json::Value>,
    /// Also return the depth of every pixel (metres along the view axis, row-major).
    pub include_depth: Option<bool>,
    /// Also return the object id of every pixel (-1 background, row-major).
    pub include_segmentation: Option<bool>,
}

/// enable_debug_visualization parameters.
#[derive(JsonSchema)]
pub struct DebugVisualization {
    /// Simulation id.
    pub sim_id: String,
    /// Draw contact points (default true).
    pub show_contacts: Option<bool>,
    /// Draw body frames (default false).
    pub show_frames: Option<bool>,
}

/// set_camera parameters.
#[derive(JsonSchema)]
pub struct SetCamera {
    /// Simulation id.
    pub sim_id: String,
    /// Distance from the camera to the target (m, > 0).
    pub distance: f64,
    /// Yaw in degrees.
    pub yaw: f64,
    /// Pitch in degrees (negative looks down).
    pub pitch: f64,
    /// The point looked at [x, y, z].
    pub target: [f64; 3],
}
