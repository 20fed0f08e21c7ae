//! Commands: the validated, self-contained form of every state-changing tool call.
//!
//! A `Command` is what the log stores and what `World::apply` folds. It is built by an adapter
//! from the client's JSON (shape checks, in `value.rs`), then checked against the current world
//! and the limits (`Command::validate`): ids exist, limits hold. Once accepted, applying it cannot
//! fail. Commands are serialised with serde_json (`float_roundtrip`), so decoding an event gives
//! back exactly the command that was applied. Never change what an existing variant means: add
//! a new one and bump `EVENT_VERSION`.

use std::collections::BTreeMap;
use std::sync::Arc;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::limits::Limits;
use crate::value::Refusal;
use crate::world::World;

/// Version of the event encoding and of tool results; stored with every event so old versions
/// can be upcast. `replay` re-checks result hashes only for events of this version.
/// 2: values reported as set (mass, timestep, time as PyBullet computes it); a cancelled
/// step records the steps it took.
/// 3: every state-changing result says where it landed (`head_seq`, `time`: `outputs::Landed`).
/// 4: get_camera_image without a view matrix frames the scene until set_camera is called, and
/// reports the camera used (results of version-3 reads are re-checked under version 3's rule).
/// 5: a simulation created under it records state hash v2 (`world::HashRules`: a Merkle tree
/// over objects, so a change to one object costs the same at any world size); results are as
/// version 4's.
/// 6: create_simulation records the engine rule the world steps under (`engine::EngineRule`:
/// rule 2 computes robots' dynamics over their tree), so step results of new simulations
/// differ from rule 1's in the last bits; get_camera_image's depth gives the background (the
/// far plane) as the f32 it is, like every other depth value (`100.0`, not
/// `99.99999999997188`); enable_joint_force_torque_sensor: get_joint_state reports a sensed
/// joint's reaction wrench (`reaction_forces`, zeros as before on every other joint); results
/// are otherwise as version 5's.
/// 7: set_joint_trajectory (a new command; get_joint_state of a joint following one adds
/// `trajectory`); get_closest_points (a new read);
/// load_mjcf records `actuators` and builds the model's MuJoCo actuators (its result lists
/// them) and keeps its sensors (get_sensor_data); set_actuator_controls; older loads fold as
/// before (their actuators and sensors stay ignored).
/// Every other result of version 6 is unchanged.
/// 8: step_simulation's `measure` is part of its command and its answers (exact) of its
/// recorded result (`measure::RECORDED_SINCE`); a version-7 step was measured in the reply only.
/// 8 also: load_mjcf records `constraints` and builds the model's `<equality>` constraints
/// (`connect`, `weld`, linear `joint`) and fixed tendons as actuator transmissions
/// (`world::mjcf_equality`) and keeps its `touch` sensors; its `ignored` names only what of
/// them is not built. Older loads fold as before (these elements stay ignored).
/// 9: create_simulation records engine rule 3 (`engine::EngineRule::TreeMultibodyPerStep`:
/// robots' mass matrices factorised once per step), so step results of new simulations differ
/// from rule 2's; worlds of older roots keep their recorded rule.
/// Also 9: load_mjcf records `ball_joints_and_pairs` and builds the model's ball joints (one joint
/// index each; get_joint_state gives a quaternion and an angular velocity) and its `<contact>
/// <pair>`s with their friction; get_joint_info and get_simulation_info list an MJCF model's
/// equality constraints and tendons. Older loads fold as before (ball joints refused, pairs,
/// constraints and tendons as version 8 left them).
/// 10: create_simulation records engine rule 4 (`engine::EngineRule::QuietStepForces`: the
/// step's one-step forces leave awake bodies unmarked), so step results of new simulations whose
/// bodies actuators or torque-control motors drive differ from rule 3's in the last bits;
/// worlds of older roots keep their recorded rule.
pub const EVENT_VERSION: u32 = 10;

/// The event version from which a chain's root records state hash v2.
pub const STATE_HASH_V2_SINCE: u32 = 5;

/// The state hash rules of a chain whose root was recorded under event version `version`.
pub fn hash_rules_of(version: u32) -> crate::world::HashRules {
    match version >= STATE_HASH_V2_SINCE {
        true => crate::world::HashRules::V2,
        false => crate::world::HashRules::V1,
    }
}

/// The oldest event version whose results are re-checked: from it on, every result is computed
/// under the rules of the version that recorded it (version 4 changed only get_camera_image's,
/// which is re-run under version 3's rule for version-3 reads). Older results were computed
/// under rules that are gone; their state hashes are still checked.
pub const RESULTS_RECHECKED_SINCE: u32 = 3;

/// Whether a result recorded under event version `version` is re-checked (see above).
pub fn result_rechecked(version: u32) -> bool {
    (RESULTS_RECHECKED_SINCE..=EVENT_VERSION).contains(&version)
}

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

/// Bytes a command needs (a URDF's text, a mesh), kept once in the log's `blobs` table under
/// their blake3 and referenced from the event by that hash. It serialises as the hash alone, so
/// events stay small; whoever decodes an event fills the bytes back in with `Command::hydrate`.
#[derive(Clone, Debug, PartialEq)]
pub struct Blob {
    /// blake3 (hex) of the bytes.
    pub hash: String,
    /// The bytes; empty until hydrated.
    pub bytes: Arc<Vec<u8>>,
}

impl Blob {
    /// A blob holding `bytes`.
    pub fn new(bytes: Vec<u8>) -> Blob {
        Blob {
            hash: crate::digest::content_hash(&bytes),
            bytes: Arc::new(bytes),
        }
    }

    /// A blob over bytes shared with others (one file read once for many commands of a
    /// request holds its bytes once).
    pub fn from_shared(bytes: Arc<Vec<u8>>) -> Blob {
        Blob { hash: crate::digest::content_hash(&bytes), bytes }
    }

    /// Whether the bytes are present and match the hash.
    pub fn is_loaded(&self) -> bool {
        blake3::hash(&self.bytes).to_hex().as_str() == self.hash
    }
}

impl Serialize for Blob {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.hash)
    }
}

impl<'de> Deserialize<'de> for Blob {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Blob, D::Error> {
        Ok(Blob {
            hash: String::deserialize(d)?,
            bytes: Arc::new(Vec::new()),
        })
    }
}

/// A model (a URDF robot, an MJCF model) parsed from a command's blobs ahead of its check and
/// its apply, so a load parses once and can do so before its simulation is locked. It rides
/// beside the command and is never recorded: a decoded event has none and parses its blobs,
/// which give the same model. It is not part of the command's meaning (equal whatever it holds).
#[derive(Clone)]
pub struct Parsed<T>(Option<Arc<T>>);

impl<T> Default for Parsed<T> {
    fn default() -> Self {
        Parsed(None)
    }
}

impl<T> Parsed<T> {
    /// The model, when it was parsed ahead.
    pub fn get(&self) -> Option<&Arc<T>> {
        self.0.as_ref()
    }
}

impl<T> PartialEq for Parsed<T> {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl<T> std::fmt::Debug for Parsed<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.is_some() { "Parsed" } else { "NotParsed" })
    }
}

/// Models parsed ahead within one request, by what they were parsed from, so a batch that
/// loads one robot many times parses it once.
#[derive(Default)]
pub struct ParsedModels {
    urdf: BTreeMap<ModelKey, Arc<crate::world::urdf::RobotModel>>,
    mjcf: BTreeMap<ModelKey, Arc<crate::world::mjcf::Prepared>>,
}

/// What names a parsed model: its text's hash, the options it is parsed with, and each mesh
/// by its name and hash.
type ModelKey = (String, String, Vec<(String, String)>);

/// The key of a model's blobs and options.
fn model_key(main: &Blob, meshes: &BTreeMap<String, Blob>, options: &str) -> ModelKey {
    (main.hash.clone(), options.to_string(), meshes.iter().map(|(n, b)| (n.clone(), b.hash.clone())).collect())
}

/// Where decoded events find their blobs' bytes: a log's `blobs` table, a saved file's map.
pub trait BlobSource {
    /// The bytes stored under `hash`, if any.
    fn blob(&self, hash: &str) -> Option<Vec<u8>>;
}

/// For decoding events that carry no blobs (roots, counting steps).
pub struct NoBlobs;

impl BlobSource for NoBlobs {
    fn blob(&self, _hash: &str) -> Option<Vec<u8>> {
        None
    }
}

/// A joint motor's control mode (PyBullet's names).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum ControlMode {
    /// Drive toward a target position (and velocity).
    PositionControl,
    /// Drive toward a target velocity.
    VelocityControl,
    /// Apply a given torque (force for prismatic joints) each step.
    TorqueControl,
}

impl ControlMode {
    /// PyBullet's name for the mode.
    pub fn name(self) -> &'static str {
        match self {
            ControlMode::PositionControl => "POSITION_CONTROL",
            ControlMode::VelocityControl => "VELOCITY_CONTROL",
            ControlMode::TorqueControl => "TORQUE_CONTROL",
        }
    }
}

/// A motor setting as set_joint_motor_control gives it; `force` None = the URDF effort limit
/// (else 500), resolved when applied.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct MotorSpec {
    /// The control mode.
    pub mode: ControlMode,
    /// Target position (POSITION_CONTROL).
    pub target_position: f32,
    /// Target velocity.
    pub target_velocity: f32,
    /// Maximum effort (POSITION/VELOCITY) or the torque itself (TORQUE).
    pub force: Option<f32>,
    /// PyBullet's positionGain.
    pub position_gain: f32,
    /// PyBullet's velocityGain.
    pub velocity_gain: f32,
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
        self.fields().iter().filter(|(_, v)| v.is_some()).map(|(n, _)| *n).collect()
    }

    /// Every property with its parameter name, in a fixed order (names, validation).
    pub fn fields(&self) -> [(&'static str, Option<f32>); 9] {
        [
            ("mass", self.mass),
            ("lateral_friction", self.lateral_friction),
            ("spinning_friction", self.spinning_friction),
            ("rolling_friction", self.rolling_friction),
            ("restitution", self.restitution),
            ("linear_damping", self.linear_damping),
            ("angular_damping", self.angular_damping),
            ("contact_stiffness", self.contact_stiffness),
            ("contact_damping", self.contact_damping),
        ]
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
        /// An optional label shown beside the id (`value::label`); not part of the state.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        name: Option<String>,
        /// The engine rule the world steps under for its life (`engine::EngineRule`), chosen by
        /// the server (`engine::ENGINE_RULE`); absent in roots recorded before event version 6,
        /// which step under rule 1.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        engine_rule: Option<crate::engine::EngineRule>,
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
        /// An optional label shown beside the id (`value::label`); not part of the state.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        name: Option<String>,
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
        /// An optional label shown beside the id (`value::label`); not part of the state.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        name: Option<String>,
    },
    /// Advance time by `steps` fixed timesteps.
    StepSimulation {
        /// Number of steps actually taken (a cancelled call records the steps it did).
        steps: u64,
        /// The measures asked (event version `measure::RECORDED_SINCE` on): their answers,
        /// taken at every step, are part of the recorded result. Absent when none were asked,
        /// so such a step is encoded as before.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        measure: Option<Vec<crate::measure::Spec>>,
    },
    /// Change the fixed timestep.
    SetTimestep {
        /// Seconds per step, as the engine runs it.
        timestep: f32,
        /// The timestep as the client gave it, which reported time is computed with
        /// (PyBullet's f64 arithmetic). Absent in events recorded before event version 2:
        /// then the f32's shortest decimal.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        timestep_given: Option<f64>,
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
        /// Whether it takes part in contacts; false makes a marker (rays and the camera still
        /// see it). Omitted when true, so events recorded before markers re-encode byte for byte.
        #[serde(default = "yes", skip_serializing_if = "is_true")]
        collides: bool,
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
    /// Load a URDF robot: its text and every mesh it uses travel with the event as blobs.
    LoadUrdf {
        /// The path as the client gave it (reported, saved).
        file_path: String,
        /// The URDF text.
        urdf: Blob,
        /// Mesh bytes by the file name written in the URDF.
        meshes: BTreeMap<String, Blob>,
        /// World position of the base link frame.
        position: [f32; 3],
        /// Orientation of the base (normalised).
        orientation: [f32; 4],
        /// Fix the base to the world.
        fixed_base: bool,
        /// Continuous joints report the lower/upper their `<limit>` gives (as PyBullet does).
        /// Set by every load_urdf since; events recorded before the field existed decode as
        /// false and fold to the robot they always did ([0, −1]), so their hashes still match.
        /// Omitted when false, so such events re-encode byte for byte.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        continuous_limits_from_file: bool,
        /// Revolute and prismatic joints read `lower`/`upper` from the `<limit>` attributes
        /// present, a missing one as PyBullet's 0 / −1 (so effort/velocity alone means no
        /// limit). Set by every load_urdf since; older events decode as false and fold to the
        /// robot they always did (a missing attribute read as 0), so their hashes still match.
        /// Omitted when false, so such events re-encode byte for byte.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        revolute_prismatic_limits_from_file: bool,
        /// Which links have an inertial is read as PyBullet 3.2.7 reads it (`UrdfRules`): past
        /// the XML declaration, so pybullet_data's objects (`<?xml version="0.0" ?>`) get their
        /// own masses, not 1 kg each; a `world` link without one has mass 0. Set by every
        /// load_urdf since; older events decode as false and fold to the robot they always did.
        /// Omitted when false, so such events re-encode byte for byte.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        inertials_as_pybullet: bool,
        /// The robot parsed ahead (`Command::ready`), never recorded.
        #[serde(skip)]
        parsed: Parsed<crate::world::urdf::RobotModel>,
    },
    /// Set (or replace) a joint motor; it acts on every later step.
    SetJointMotor {
        /// The robot.
        object_id: u32,
        /// PyBullet joint index.
        joint_index: u32,
        /// The motor.
        motor: MotorSpec,
    },
    /// Set several joints' motors in one call (set_joint_motor_control_array): each as
    /// `SetJointMotor` would, in order (a joint named twice keeps the last).
    SetJointMotors {
        /// The robot.
        object_id: u32,
        /// (PyBullet joint index, its motor), in the order given.
        motors: Vec<(u32, MotorSpec)>,
    },
    /// PyBullet's collision filter group and mask of an object's base (−1) or link
    /// (set_collision_filter_group_mask), tested as PyBullet tests them (`pybullet_test`;
    /// `world::filters`).
    SetCollisionFilter {
        /// The object.
        object_id: u32,
        /// −1 = the base; ≥ 0 a link.
        link_index: i32,
        /// The groups it belongs to.
        group: u32,
        /// The groups it touches.
        mask: u32,
        /// PyBullet's own test (a pair touches when either part's group meets the other's
        /// mask; static parts are group 2, mask all but 2): every command made now. False
        /// (absent) in events of the first release, which tested both ways with every part at
        /// group 1, mask all — those logs fold as they were recorded.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        pybullet_test: bool,
    },
    /// Contacts between two parts (object, link) off or back on (set_collision_filter_pair).
    SetCollisionPair {
        /// One part: (object id, link index; −1 = the base).
        a: (u32, i32),
        /// The other part.
        b: (u32, i32),
        /// On (true) or off.
        enable: bool,
    },
    /// Teleport one joint to a position and velocity (reset_joint_state, PyBullet's
    /// resetJointState); the links below it follow through forward kinematics.
    ResetJointState {
        /// The robot.
        object_id: u32,
        /// PyBullet joint index.
        joint_index: u32,
        /// New joint position (rad or m; MJCF: qpos, `ref` included).
        target_value: f32,
        /// New joint velocity (rad/s or m/s).
        target_velocity: f32,
    },
    /// Join two objects (or an object and the world) with an impulse joint.
    CreateConstraint {
        /// What joins what, and where.
        spec: ConstraintSpec,
    },
    /// Remove a constraint.
    RemoveConstraint {
        /// Its id.
        constraint_id: u32,
    },
    /// What the viewer draws besides the bodies (enable_debug_visualization).
    SetDebugVisualization {
        /// Draw contact points.
        show_contacts: bool,
        /// Draw body frames.
        show_frames: bool,
    },
    /// The viewer's camera (set_camera); also the default camera of get_camera_image.
    SetCamera {
        /// Distance from the target (m, > 0).
        distance: f32,
        /// Yaw in degrees.
        yaw: f32,
        /// Pitch in degrees.
        pitch: f32,
        /// The point looked at.
        target: [f32; 3],
    },
    /// Load a MuJoCo MJCF model: its text, `<include>`s already spliced in by the adapter,
    /// travels with the event as a blob (replay reads no files).
    LoadMjcf {
        /// The path as the client gave it (reported, saved).
        file_path: String,
        /// The MJCF text with every `<include>` spliced in.
        mjcf: Blob,
        /// Mesh bytes by the `<mesh file>` written in the model (read at load, relative to the
        /// main file and `<compiler meshdir/assetdir>`). Omitted when empty, so events of models
        /// without meshes, recorded before meshes were supported, re-encode byte for byte.
        #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
        meshes: BTreeMap<String, Blob>,
        /// World position of the model's frame (the worldbody's, or the free root's offset).
        position: [f32; 3],
        /// Orientation of the model's frame (normalised).
        orientation: [f32; 4],
        /// Fix a free-joint root to the world.
        fixed_base: bool,
        /// The `<key name>` whose qpos the joints start at (None: qpos0).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        keyframe: Option<String>,
        /// MuJoCo's parent filter across a body's joints: a body with several joints (a chain
        /// of massless spacer links) touches neither its parent body, as in MuJoCo, and not
        /// only its spacer. Set by every load_mjcf since; events recorded before the field
        /// existed decode as false and fold to the robot they always did (a multi-joint body —
        /// a humanoid's thigh — colliding with its parent, the pelvis), so their hashes still
        /// match. Omitted when false, so such events re-encode byte for byte.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        parent_filter: bool,
        /// The model's `<option timestep>` and `gravity` become the simulation's (opt-in,
        /// load_mjcf's `use_model_options`): MuJoCo's own step and gravity for the model, as
        /// set_timestep and a gravity of that value would set them. Its solver options
        /// (`iterations`, `integrator`, …) have no equivalent in the engine and stay listed in
        /// `ignored`. Omitted when false, so events recorded before it re-encode byte for byte
        /// and fold as they did.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        use_model_options: bool,
        /// The model's `<actuator>`s are simulated (`world::actuators`) and its `<sensor>`s kept
        /// for get_sensor_data (`world::sensors`), event version 7: set by every load_mjcf
        /// since. Events recorded before decode as false and fold as they did (actuators and
        /// sensors listed in `ignored`); omitted when false, so they re-encode byte for byte.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        actuators: bool,
        /// The model's `<equality>` constraints and fixed tendons (actuator transmissions) are
        /// built (`world::mjcf_equality`), event version 8: set by every load_mjcf since.
        /// Events recorded before decode as false and fold as they did (listed in `ignored`);
        /// omitted when false, so they re-encode byte for byte.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        constraints: bool,
        /// The model's ball joints and `<contact><pair>`s are built, a static world body is added
        /// for a connect/weld only when one is built, tendon attributes from `<default>` classes
        /// are listed in `ignored`, and the model's equality constraints and tendons are listed
        /// (`world::mjcf_listing`), event version 9: set by every load_mjcf since. Events
        /// recorded before decode as false and fold as they did (a ball joint refused; pairs in
        /// `ignored`); omitted when false, so they re-encode byte for byte.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        ball_joints_and_pairs: bool,
        /// The model parsed ahead (`Command::ready`), never recorded.
        #[serde(skip)]
        parsed: Parsed<crate::world::mjcf::Prepared>,
    },
    /// Set an MJCF robot's actuator controls (set_actuator_controls, MuJoCo's `data.ctrl`),
    /// held until changed. Event version 7.
    SetActuatorControls {
        /// The robot.
        object_id: u32,
        /// The controls, in actuator order or by name.
        controls: ActuatorControls,
    },
    /// Turn a joint's force/torque sensor on or off (enable_joint_force_torque_sensor,
    /// PyBullet's enableJointForceTorqueSensor): while on, get_joint_state reports the joint's
    /// reaction wrench. Event version 6.
    EnableJointForceTorqueSensor {
        /// The robot.
        object_id: u32,
        /// PyBullet joint index.
        joint_index: u32,
        /// On (true) or off.
        enable: bool,
    },
    /// The joints' position motors follow a time-parameterised path as the world steps
    /// (set_joint_trajectory; `world::joint_trajectory`), replacing their motors and any path
    /// they followed. Event version 7.
    SetJointTrajectory {
        /// The robot.
        object_id: u32,
        /// The joints, waypoints and motor settings.
        trajectory: crate::world::joint_trajectory::TrajectorySpec,
    },
}

/// set_actuator_controls' controls: one per actuator in the model's order, or some by name.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
#[serde(rename_all = "snake_case")]
pub enum ActuatorControls {
    /// Every actuator's control, in order.
    InOrder(Vec<f64>),
    /// Some actuators' controls by name (the others keep theirs).
    ByName(BTreeMap<String, f64>),
}

/// The kinds of constraint create_constraint makes (PyBullet's names, plus revolute).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ConstraintType {
    /// All six relative degrees of freedom locked.
    Fixed,
    /// Free translation along the axis only.
    Prismatic,
    /// Free rotation about the anchor point (PyBullet's point-to-point).
    Spherical,
    /// Free rotation about the axis only.
    Revolute,
}

impl ConstraintType {
    /// The name the tools use.
    pub fn name(self) -> &'static str {
        match self {
            ConstraintType::Fixed => "fixed",
            ConstraintType::Prismatic => "prismatic",
            ConstraintType::Spherical => "spherical",
            ConstraintType::Revolute => "revolute",
        }
    }

    /// Parses a tool's `joint_type` (PyBullet's `point2point` is accepted for spherical).
    pub fn parse(s: &str) -> Option<Self> {
        Some(match s.to_ascii_lowercase().as_str() {
            "fixed" | "joint_fixed" => ConstraintType::Fixed,
            "prismatic" | "joint_prismatic" => ConstraintType::Prismatic,
            "spherical" | "point2point" | "joint_point2point" => ConstraintType::Spherical,
            "revolute" | "joint_revolute" => ConstraintType::Revolute,
            _ => return None,
        })
    }
}

/// A constraint as create_constraint describes it (PyBullet's frames: the parent frame in the
/// parent's body frame, the child frame in the child's, or in world coordinates when the child
/// is the world; the axis in the parent's constraint frame).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct ConstraintSpec {
    /// The parent object.
    pub parent_id: u32,
    /// The child object, or None for the world (−1 in the tools).
    pub child_id: Option<u32>,
    /// The kind of joint.
    pub joint_type: ConstraintType,
    /// Unit axis (prismatic, revolute).
    pub joint_axis: [f32; 3],
    /// Joint position in the parent's frame.
    pub parent_frame_position: [f32; 3],
    /// Joint position in the child's frame (world frame for the world).
    pub child_frame_position: [f32; 3],
    /// Joint orientation in the parent's frame (normalised).
    pub parent_frame_orientation: [f32; 4],
    /// Joint orientation in the child's frame (normalised).
    pub child_frame_orientation: [f32; 4],
}

fn yes() -> bool {
    true
}

fn is_true(b: &bool) -> bool {
    *b
}

fn base_link() -> i32 {
    -1
}

/// Refuses a new object once the simulation holds `--max-objects`.
fn room_for_object(world: &World, limits: &Limits) -> Result<(), Refusal> {
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

/// `name` must hold finite numbers.
/// A motor's own values: finite numbers, a maximum effort ≥ 0.
fn motor_values(motor: &MotorSpec) -> Result<(), Refusal> {
    finite("target_position", &[motor.target_position])?;
    finite("target_velocity", &[motor.target_velocity])?;
    finite("position_gain", &[motor.position_gain])?;
    finite("velocity_gain", &[motor.velocity_gain])?;
    match (motor.mode, motor.force) {
        (_, None) => Ok(()),
        (ControlMode::TorqueControl, Some(f)) => finite("force", &[f]),
        (_, Some(f)) => non_negative("force", f),
    }
}

fn finite(name: &str, v: &[f32]) -> Result<(), Refusal> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(format!("{name} must be finite numbers; got {v:?}"))
    }
}

/// `name` must be a finite number > 0.
fn positive(name: &str, x: f32) -> Result<(), Refusal> {
    if x.is_finite() && x > 0.0 {
        Ok(())
    } else {
        Err(format!("{name} must be a finite number > 0; got {x}"))
    }
}

/// `name` must be a finite number ≥ 0.
fn non_negative(name: &str, x: f32) -> Result<(), Refusal> {
    if x.is_finite() && x >= 0.0 {
        Ok(())
    } else {
        Err(format!("{name} must be a finite number >= 0; got {x}"))
    }
}

/// `name` must be a unit quaternion [x, y, z, w] (commands hold them normalised).
fn unit_quaternion(name: &str, q: &[f32; 4]) -> Result<(), Refusal> {
    finite(name, q)?;
    let norm = q.iter().map(|x| x * x).sum::<f32>().sqrt();
    if (norm - 1.0).abs() <= 1e-4 {
        Ok(())
    } else {
        Err(format!("{name} must be a unit quaternion [x, y, z, w]; got {q:?} (length {norm})"))
    }
}

/// `name` must be a finite, non-zero vector.
fn non_zero(name: &str, v: &[f32; 3]) -> Result<(), Refusal> {
    finite(name, v)?;
    if v.iter().any(|x| *x != 0.0) {
        Ok(())
    } else {
        Err(format!("{name} must be a non-zero vector; got {v:?}"))
    }
}

/// The standard "object not found" sentence (docs/tools.md).
pub fn object_not_found(object_id: u32, sim_id: &str) -> Refusal {
    format!("Object {object_id} not found in simulation {sim_id}")
}

/// The standard "constraint not found" sentence (docs/tools.md).
pub fn constraint_not_found(constraint_id: u32, sim_id: &str) -> Refusal {
    format!("Constraint {constraint_id} not found in simulation {sim_id}")
}

impl Command {
    /// The command as it was carried out, given its result: a step_simulation cancelled part
    /// way took fewer steps than asked, and that is what folding the log must repeat. Logs
    /// written before event version 2 recorded the steps asked; their result says the truth.
    pub fn as_done(self, result: &serde_json::Value) -> Command {
        self.as_taken(result.get("steps_taken").and_then(serde_json::Value::as_u64))
    }

    /// How a URDF load reads joint limits and inertials (its recorded flags; today's rules otherwise).
    pub fn urdf_rules(&self) -> crate::world::urdf::UrdfRules {
        match self {
            Command::LoadUrdf { continuous_limits_from_file, revolute_prismatic_limits_from_file, inertials_as_pybullet, .. } => {
                crate::world::urdf::UrdfRules {
                    continuous: *continuous_limits_from_file,
                    revolute_prismatic: *revolute_prismatic_limits_from_file,
                    pybullet_inertials: *inertials_as_pybullet,
                }
            }
            _ => crate::world::urdf::UrdfRules { continuous: true, revolute_prismatic: true, pybullet_inertials: true },
        }
    }

    /// The command with its model parsed ahead (a load; anything else as it is), refused with
    /// the sentence the check would give for the model (the check's world-dependent parts,
    /// such as --max-objects, come later, under the simulation's lock): what a single call does
    /// before its simulation is locked.
    pub fn ready(self) -> Result<Command, Refusal> {
        self.ready_in(&mut ParsedModels::default())
    }

    /// `ready`, parsing each distinct model once within `models` (one request's).
    pub fn ready_in(mut self, models: &mut ParsedModels) -> Result<Command, Refusal> {
        let rules = self.urdf_rules();
        match &mut self {
            Command::LoadUrdf { urdf, meshes, parsed, .. } => {
                let key = model_key(urdf, meshes, &format!("{} {} {}", rules.continuous, rules.revolute_prismatic, rules.pybullet_inertials));
                let model = match models.urdf.get(&key) {
                    Some(m) => m.clone(),
                    None => {
                        let m = Arc::new(crate::world::urdf_model(urdf, meshes, rules)?);
                        models.urdf.insert(key, m.clone());
                        m
                    }
                };
                *parsed = Parsed(Some(model));
            }
            Command::LoadMjcf { mjcf, meshes, keyframe, parsed, .. } => {
                let key = model_key(mjcf, meshes, keyframe.as_deref().unwrap_or(""));
                let model = match models.mjcf.get(&key) {
                    Some(m) => m.clone(),
                    None => {
                        let m = Arc::new(crate::world::mjcf::prepare_blob(mjcf, meshes, keyframe.as_deref())?);
                        models.mjcf.insert(key, m.clone());
                        m
                    }
                };
                *parsed = Parsed(Some(model));
            }
            _ => {}
        }
        // After the parse: a model's joint anchors are checked on the model parsed here.
        self.within_extent()?;
        Ok(self)
    }

    /// Sizes and positions within [`crate::limits::MAX_EXTENT_M`]: beyond it the engine
    /// panics on every later step (a 1.8e19 m box beside a mesh); velocities within
    /// [`crate::limits::MAX_SPEED`] (far beyond it a body freezes); an MJCF model's joint
    /// anchors and any model's joint axes too (parsed here unless parsed ahead). Checked at the edge only — `ready`, which
    /// a client's call and every command re-made from a saved file's readable fields go
    /// through — not in `validate`, so logs recorded before the bound fold as they always did.
    pub fn within_extent(&self) -> Result<(), Refusal> {
        let bound = crate::limits::MAX_EXTENT_M as f32;
        let near = |name: &str, v: &[f32]| match v.iter().all(|x| x.abs() <= bound) {
            true => Ok(()),
            false => Err(format!("{name} must be within {bound} m; got {v:?}")),
        };
        match self {
            Command::AddBody { shape, position, .. } => {
                near("position", position)?;
                near("dimensions", &shape.dimensions())
            }
            Command::SetObjectPose { position, .. } => near("position", position),
            Command::LoadUrdf { position, urdf, meshes, parsed, .. } => {
                near("position", position)?;
                let built;
                let model = match parsed.get() {
                    Some(model) => model.as_ref(),
                    None => {
                        built = crate::world::urdf_model(urdf, meshes, self.urdf_rules())?;
                        &built
                    }
                };
                model.joints_usable()
            }
            Command::LoadMjcf { position, mjcf, meshes, keyframe, parsed, .. } => {
                near("position", position)?;
                match parsed.get() {
                    Some(model) => model.joints_within_extent(),
                    None => crate::world::mjcf::prepare_blob(mjcf, meshes, keyframe.as_deref())?.joints_within_extent(),
                }
            }
            Command::SetObjectVelocity { linear_velocity, angular_velocity, .. } => {
                let speed = crate::limits::MAX_SPEED as f32;
                for (name, v) in [("linear_velocity", linear_velocity), ("angular_velocity", angular_velocity)] {
                    if let Some(v) = v.filter(|v| v.iter().any(|x| x.abs() > speed)) {
                        return Err(format!("{name} must be within {speed} per axis (the engine caps speed at 400 m/s); got {v:?}"));
                    }
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// A plain step_simulation of `steps` steps (no measures).
    pub fn step(steps: u64) -> Command {
        Command::StepSimulation { steps, measure: None }
    }

    /// `as_done` given the steps a step_simulation took (None: not a step result).
    pub fn as_taken(self, steps_taken: Option<u64>) -> Command {
        match self {
            Command::StepSimulation { steps, measure } => {
                Command::StepSimulation { steps: steps_taken.filter(|t| *t < steps).unwrap_or(steps), measure }
            }
            other => other,
        }
    }

    /// The command's own values, whatever the world: what the adapters' parsing guarantees,
    /// checked again for commands from files and logs (hostile or corrupt ones included).
    pub fn validate_values(&self) -> Result<(), Refusal> {
        let labelled = |name: &Option<String>| name.as_deref().map_or(Ok(()), |n| crate::value::label("name", n).map(|_| ()));
        match self {
            Command::CreateSimulation { gravity, name, .. } => finite("gravity", gravity).and_then(|()| labelled(name)),
            Command::ForkSimulation { name, .. } | Command::LoadSimulation { name, .. } => labelled(name),
            Command::StepSimulation { measure, .. } => crate::measure::check_values("measure", measure.as_deref().unwrap_or_default()),
            Command::SetTimestep { timestep, timestep_given } => {
                positive("timestep", *timestep)?;
                match timestep_given {
                    Some(t) if !(t.is_finite() && *t > 0.0) => Err(format!("timestep must be a finite number > 0; got {t}")),
                    _ => Ok(()),
                }
            }
            Command::AddBody { shape, position, orientation, mass, color, .. } => {
                for d in shape.dimensions() {
                    positive("dimensions", d)?;
                }
                finite("position", position)?;
                unit_quaternion("orientation", orientation)?;
                non_negative("mass", *mass)?;
                match color {
                    Some(c) if !c.iter().all(|x| (0.0..=1.0).contains(x)) => {
                        Err(format!("color must be numbers in [0, 1]; got {c:?}"))
                    }
                    _ => Ok(()),
                }
            }
            Command::SetObjectPose { position, orientation, .. }
            | Command::LoadUrdf { position, orientation, .. }
            | Command::LoadMjcf { position, orientation, .. } => {
                finite("position", position)?;
                unit_quaternion("orientation", orientation)
            }
            Command::ApplyForce { force, position, .. } => {
                finite("force", force)?;
                position.as_ref().map_or(Ok(()), |p| finite("position", p))
            }
            Command::ApplyTorque { torque, .. } => finite("torque", torque),
            Command::SetObjectVelocity { linear_velocity, angular_velocity, .. } => {
                linear_velocity.as_ref().map_or(Ok(()), |v| finite("linear_velocity", v))?;
                angular_velocity.as_ref().map_or(Ok(()), |v| finite("angular_velocity", v))
            }
            Command::ChangeDynamics { change, .. } => {
                change.fields().into_iter().filter_map(|(n, v)| v.map(|v| (n, v))).try_for_each(|(n, v)| non_negative(n, v))
            }
            Command::RemoveObject { .. } | Command::RemoveConstraint { .. } | Command::SetDebugVisualization { .. } => Ok(()),
            Command::SetJointMotor { motor, .. } => motor_values(motor),
            Command::SetJointMotors { motors, .. } => {
                if motors.is_empty() {
                    return Err("joint_indices must name at least one joint".into());
                }
                motors.iter().try_for_each(|(_, m)| motor_values(m))
            }
            Command::SetCollisionFilter { .. }
            | Command::SetCollisionPair { .. }
            | Command::EnableJointForceTorqueSensor { .. } => Ok(()),
            Command::SetJointTrajectory { trajectory: t, .. } => {
                let rows = t.positions.iter().chain(t.velocities.iter().flatten());
                let mut numbers = t.times.iter().chain(rows.flatten());
                if let Some(x) = numbers.find(|x| !x.is_finite()) {
                    return Err(format!("times, positions and velocities must be finite numbers; got {x}"));
                }
                for (name, list) in [("forces", &t.forces), ("position_gains", &t.position_gains), ("velocity_gains", &t.velocity_gains)] {
                    list.iter().flatten().try_for_each(|x| non_negative(name, *x))?;
                }
                Ok(())
            }
            Command::SetActuatorControls { controls, .. } => {
                let values: Vec<f64> = match controls {
                    ActuatorControls::InOrder(us) => us.clone(),
                    ActuatorControls::ByName(by) => by.values().copied().collect(),
                };
                match values.iter().find(|u| !u.is_finite()) {
                    Some(u) => Err(format!("controls must be finite numbers; got {u}")),
                    None => Ok(()),
                }
            }
            Command::ResetJointState { target_value, target_velocity, .. } => {
                finite("target_value", &[*target_value])?;
                finite("target_velocity", &[*target_velocity])
            }
            Command::CreateConstraint { spec } => {
                if matches!(spec.joint_type, ConstraintType::Prismatic | ConstraintType::Revolute) {
                    non_zero("joint_axis", &spec.joint_axis)?;
                }
                finite("joint_axis", &spec.joint_axis)?;
                finite("parent_frame_position", &spec.parent_frame_position)?;
                finite("child_frame_position", &spec.child_frame_position)?;
                unit_quaternion("parent_frame_orientation", &spec.parent_frame_orientation)?;
                unit_quaternion("child_frame_orientation", &spec.child_frame_orientation)
            }
            Command::SetCamera { distance, yaw, pitch, target } => {
                positive("distance", *distance)?;
                finite("yaw", &[*yaw])?;
                finite("pitch", &[*pitch])?;
                finite("target", target)
            }
        }
    }

    /// The blobs this command carries (stored beside its event).
    pub fn blobs(&self) -> Vec<&Blob> {
        match self {
            Command::LoadUrdf { urdf, meshes, .. } => {
                std::iter::once(urdf).chain(meshes.values()).collect()
            }
            Command::LoadMjcf { mjcf, meshes, .. } => std::iter::once(mjcf).chain(meshes.values()).collect(),
            _ => Vec::new(),
        }
    }

    /// Fills in the bytes of every blob from `src`, checking each against its hash.
    pub fn hydrate(&mut self, src: &dyn BlobSource) -> Result<(), String> {
        let blobs: Vec<&mut Blob> = match self {
            Command::LoadUrdf { urdf, meshes, .. } => std::iter::once(urdf).chain(meshes.values_mut()).collect(),
            Command::LoadMjcf { mjcf, meshes, .. } => std::iter::once(mjcf).chain(meshes.values_mut()).collect(),
            _ => Vec::new(),
        };
        if !blobs.is_empty() {
            for b in blobs {
                if b.is_loaded() {
                    continue;
                }
                let bytes = src.blob(&b.hash).ok_or_else(|| format!("blob {} is missing", b.hash))?;
                // Content-addressed: bytes that hash to something else are not this blob.
                let fresh = Blob::new(bytes);
                if fresh.hash != b.hash {
                    return Err(format!("blob {} does not match its hash", b.hash));
                }
                *b = fresh;
            }
            let loaded = self.blobs().iter().all(|b| b.is_loaded());
            if !loaded {
                return Err("a blob does not match its hash".into());
            }
        }
        Ok(())
    }

    /// The one validation every path uses — a tool call, a foreign saved file's events, a
    /// replayed or recovered log — so no value `World::apply` cannot take (a timestep ≤ 0, a
    /// zero quaternion, a zero axis, ±inf) reaches it whatever the source: the command's own
    /// values (`validate_values`), then against the current world and limits. An `Ok` here
    /// guarantees `World::apply` succeeds; an `Err` is the one-sentence reason naming the
    /// parameter, and nothing changes.
    pub fn validate(&self, world: &World, limits: &Limits) -> Result<(), Refusal> {
        self.validate_values()?;
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
            Command::StepSimulation { steps, measure } => {
                if *steps == 0 || *steps > limits.max_steps {
                    Err(format!(
                        "steps must be an integer from 1 to {} (--max-steps); got {steps}",
                        limits.max_steps
                    ))
                } else {
                    crate::measure::check_objects("measure", measure.as_deref().unwrap_or_default(), |id| world.has_object(id))
                }
            }
            Command::SetTimestep { .. }
            | Command::SetDebugVisualization { .. }
            | Command::SetCamera { .. } => Ok(()),
            Command::LoadUrdf { urdf, meshes, parsed, .. } => {
                room_for_object(world, limits)?;
                match parsed.get() {
                    Some(_) => Ok(()),
                    None => crate::world::urdf_model(urdf, meshes, self.urdf_rules()).map(|_| ()),
                }
            }
            Command::LoadMjcf { mjcf, meshes, keyframe, parsed, ball_joints_and_pairs, .. } => {
                room_for_object(world, limits)?;
                let built;
                let model = match parsed.get() {
                    Some(m) => m.as_ref(),
                    None => {
                        built = crate::world::mjcf::prepare_blob(mjcf, meshes, keyframe.as_deref())?;
                        &built
                    }
                };
                // Before event version 9 a ball joint was refused (no such load is in any log).
                match (model.ball_joint(), *ball_joints_and_pairs) {
                    (Some(name), false) => Err(format!("joint {name} is a ball joint, which is not supported (hinge and slide joints are)")),
                    _ => Ok(()),
                }
            }
            Command::SetJointMotor { object_id, joint_index, motor } => {
                exists(*object_id)?;
                world.check_motor(*object_id, *joint_index, motor)
            }
            Command::SetJointMotors { object_id, motors } => {
                exists(*object_id)?;
                motors.iter().try_for_each(|(j, m)| world.check_motor(*object_id, *j, m))
            }
            Command::SetCollisionFilter { object_id, link_index, .. } => {
                exists(*object_id)?;
                world.check_link(*object_id, *link_index)
            }
            Command::SetCollisionPair { a, b, .. } => {
                for (name, (id, link)) in [("a", a), ("b", b)] {
                    exists(*id)?;
                    world.check_link(*id, *link).map_err(|why| format!("link_index_{name}: {why}"))?;
                }
                if a == b {
                    return Err("object_id_a and object_id_b name the same part; a pair is two parts".into());
                }
                Ok(())
            }
            Command::ResetJointState { object_id, joint_index, .. } => {
                exists(*object_id)?;
                world.check_reset_joint(*object_id, *joint_index)
            }
            Command::EnableJointForceTorqueSensor { object_id, joint_index, .. } => {
                exists(*object_id)?;
                world.check_joint(*object_id, *joint_index as i64)?;
                // The reaction wrench is computed in joint space, one number per joint.
                world.robot(*object_id).map_or(Ok(()), |r| r.ball_joint_refusal(*object_id, "enable_joint_force_torque_sensor"))
            }
            Command::SetJointTrajectory { object_id, trajectory } => {
                exists(*object_id)?;
                world.check_trajectory(*object_id, trajectory)
            }
            Command::SetActuatorControls { object_id, controls } => {
                exists(*object_id)?;
                world.check_actuator_controls(*object_id, controls)
            }
            Command::AddBody { .. } => room_for_object(world, limits),
            Command::CreateConstraint { spec } => {
                exists(spec.parent_id)?;
                if let Some(child) = spec.child_id {
                    exists(child)?;
                    if child == spec.parent_id {
                        return Err(format!(
                            "child_id {child} is the parent itself: a constraint joins two different objects (or an object and the world, -1)"
                        ));
                    }
                }
                if world.constraint_count() >= limits.max_constraints {
                    return Err(format!(
                        "Constraint limit reached: {} constraints in simulation {} (--max-constraints)",
                        limits.max_constraints,
                        world.simulation_id()
                    ));
                }
                Ok(())
            }
            Command::RemoveConstraint { constraint_id } => {
                if world.has_constraint(*constraint_id) {
                    Ok(())
                } else {
                    Err(constraint_not_found(*constraint_id, world.simulation_id()))
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
