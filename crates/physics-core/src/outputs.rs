//! Tool results: the `structuredContent` of every tool, with the field names of the old
//! PyBullet server. Each type derives `JsonSchema` so the MCP layer can declare it as the
//! tool's `outputSchema`. Floats are f64 holding the shortest decimal of the engine's f32
//! (see `value::r32`), so `0.1` reads as `0.1`.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Where a state-changing call landed in its simulation's log: the event it became (the head
/// after it) and the simulated time after it, so an agent can name an interval for
/// get_trajectory or render_animation without get_history (docs/tools.md "An agent's budget").
/// The world knows no seqs, so the log sets it (`Outcome::land`); it is recorded and hashed
/// with the result from event version 3 on.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, Copy, PartialEq)]
pub struct Landed {
    /// The event this call became: the head after it.
    pub head_seq: u64,
    /// Simulated time after it, in seconds.
    pub time: f64,
}

/// A plain confirmation for tools whose old result was a bare string.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Message {
    /// What happened, in one sentence.
    pub message: String,
    /// Where the call landed (event version 3 on): the head after it and the time.
    #[serde(flatten)]
    pub landed: Option<Landed>,
}

impl Message {
    /// A message result.
    pub fn new(message: impl Into<String>) -> Self {
        Self {
            landed: None,
            message: message.into(),
        }
    }
}

/// Result of create_simulation.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Created {
    /// The new simulation's id (a UUID).
    pub simulation_id: String,
    /// Gravity [gx, gy, gz] in m/s².
    pub gravity: [f64; 3],
    /// Whether the web viewer follows this simulation.
    pub gui_enabled: bool,
    /// Its label, when it was given one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Where the viewer page is, when gui is on.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub viewer_url: Option<String>,
    /// Where the call landed (event version 3 on): the head after it and the time.
    #[serde(flatten)]
    pub landed: Option<Landed>,
}

/// One row of list_simulations.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct SimulationSummary {
    /// Simulation id.
    pub simulation_id: String,
    /// Its label, when it was given one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Number of objects.
    pub objects: usize,
    /// Simulated time in seconds.
    pub simulation_time: f64,
}

/// Result of list_simulations.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct SimulationList {
    /// The live simulations, ordered by id.
    pub simulations: Vec<SimulationSummary>,
    /// Simulations whose logs are damaged (never served), ordered by id; every call on one
    /// answers `Simulation {id} is damaged: {reason}`.
    #[serde(default)]
    pub damaged: Vec<DamagedSimulation>,
}

/// A simulation whose log could not be opened or folded back (list_simulations): reported
/// so an operator can inspect the file, never served.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct DamagedSimulation {
    /// Simulation id (the log file's name).
    pub simulation_id: String,
    /// Why, in one sentence (naming the first bad event where known).
    pub reason: String,
}

/// Result of step_simulation.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Stepped {
    /// Simulation id.
    pub simulation_id: String,
    /// Steps actually taken (fewer than asked only if the call was cancelled).
    pub steps_taken: u64,
    /// Simulated time after the steps, in seconds.
    pub current_time: f64,
    /// Samples taken during this call (with sample_every). Output only: never part of the
    /// recorded result or its hash, so the step event is exactly a plain step's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trajectory: Option<Trajectory>,
    /// Answers to `measure`, computed at every step of this call. Part of the recorded result
    /// (exact) from event version 8 (`measure::RECORDED_SINCE`), so replay re-checks them; the
    /// reply rounds them like the samples unless `detail: "full"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measures: Option<Vec<Measured>>,
    /// Where the call landed (event version 3 on): the head after it and the time.
    #[serde(flatten)]
    pub landed: Option<Landed>,
}

/// Result of get_trajectory (and step_simulation's `trajectory`): samples of an interval of
/// the chain, columnar (one array per quantity, one entry per sample) so a long run costs few
/// tokens; each value is bit for bit what get_object_state / get_joint_state said then.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, PartialEq)]
pub struct Trajectory {
    /// The event whose resulting state is the first sample.
    pub from_seq: u64,
    /// The event whose resulting state is the last sample.
    pub to_seq: u64,
    /// Steps between samples.
    pub every: u64,
    /// Number of samples.
    pub samples: usize,
    /// Simulated time of each sample (s).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub times: Vec<f64>,
    /// The simulation's step count at each sample.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub steps: Vec<u64>,
    /// The event each sample is in (the step event in progress, or the event just applied).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub seqs: Vec<u64>,
    /// One track per object (absent when the table went to `output_path`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub objects: Vec<ObjectTrack>,
    /// The file the whole table was written to (then the result is this summary).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output_path: Option<String>,
    /// Objects left out of `objects` because every sample of theirs was bit-identical (at
    /// rest or static throughout); `detail: "full"` lists them too.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub unmoved: Vec<u32>,
    /// Answers to `measure`, computed at every step of the interval (not only at samples).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measures: Option<Vec<Measured>>,
}

/// One answer to a `measure` (docs/tools.md "Measures"): what was asked, echoed, and its
/// value and time, so an agent reads "how high, when" instead of scanning samples.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, PartialEq)]
pub struct Measured {
    /// The object measured (object measures).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub object_id: Option<u32>,
    /// The pair measured (first_contact).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pair: Option<[u32; 2]>,
    /// What was measured: peak_height, lowest_height, first, settled, travel, final_tilt, first_contact.
    pub what: String,
    /// The condition of `first`, as asked.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub when: Option<std::collections::BTreeMap<String, f64>>,
    /// The value (m, m/s, degrees); null when the condition never held.
    pub value: Option<f64>,
    /// Simulated time of the value (s); null when it never held or is not a moment (travel).
    pub time: Option<f64>,
}

/// One object's samples; null where the object does not exist at a sample.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, PartialEq)]
pub struct ObjectTrack {
    /// The object.
    pub object_id: u32,
    /// Base positions (n × 3); left out when `fields` asks for other columns.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub positions: Vec<Option<[f64; 3]>>,
    /// Base x (n; with `fields` holding "x").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<Vec<Option<f64>>>,
    /// Base y (n; with `fields` holding "y").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y: Option<Vec<Option<f64>>>,
    /// Base z (n; with `fields` holding "z").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub z: Option<Vec<Option<f64>>>,
    /// Base orientations [x, y, z, w] (n × 4); left out when `fields` does not ask for them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub orientations: Vec<Option<[f64; 4]>>,
    /// Linear velocities (n × 3, with include_velocities).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub linear_velocities: Option<Vec<Option<[f64; 3]>>>,
    /// Angular velocities (n × 3, with include_velocities).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angular_velocities: Option<Vec<Option<[f64; 3]>>>,
    /// Joint positions (n × joints, robots; PyBullet joint order).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint_positions: Option<Vec<Option<Vec<f64>>>>,
    /// Joint velocities (n × joints, robots with include_velocities).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint_velocities: Option<Vec<Option<Vec<f64>>>>,
}

/// Result of set_timestep.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct TimestepSet {
    /// Confirmation.
    pub message: String,
    /// The new timestep in seconds.
    pub timestep: f64,
    /// Where the call landed (event version 3 on): the head after it and the time.
    #[serde(flatten)]
    pub landed: Option<Landed>,
}

/// Result of add_box / add_sphere / add_cylinder / add_capsule.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct ObjectAdded {
    /// The new object's id.
    pub object_id: u32,
    /// box, sphere, cylinder or capsule.
    pub shape: String,
    /// Where it was placed.
    pub position: [f64; 3],
    /// Where the call landed (event version 3 on): the head after it and the time.
    #[serde(flatten)]
    pub landed: Option<Landed>,
}

/// Result of get_object_state.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct ObjectState {
    /// World position of the body origin (m).
    pub position: [f64; 3],
    /// Orientation quaternion [x, y, z, w].
    pub orientation: [f64; 4],
    /// Linear velocity (m/s).
    pub linear_velocity: [f64; 3],
    /// Angular velocity (rad/s, world frame).
    pub angular_velocity: [f64; 3],
}

/// Result of get_link_state (PyBullet's getLinkState with computeLinkVelocity and
/// computeForwardKinematics): the link's own frame and its centre-of-mass frame, both in the
/// world, and the velocity of its centre of mass.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct LinkState {
    /// World position of the link frame (the URDF link frame, or the MJCF body frame) (m).
    pub link_world_position: [f64; 3],
    /// Orientation of the link frame [x, y, z, w].
    pub link_world_orientation: [f64; 4],
    /// World position of the centre of mass (m).
    pub com_world_position: [f64; 3],
    /// Orientation of the inertial (principal axes) frame [x, y, z, w].
    pub com_world_orientation: [f64; 4],
    /// Linear velocity of the centre of mass (m/s).
    pub linear_velocity: [f64; 3],
    /// Angular velocity (rad/s, world frame).
    pub angular_velocity: [f64; 3],
}

/// Result of change_dynamics.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct DynamicsChanged {
    /// Confirmation.
    pub message: String,
    /// Names of the properties that were set.
    pub changed: Vec<String>,
    /// Where the call landed (event version 3 on): the head after it and the time.
    #[serde(flatten)]
    pub landed: Option<Landed>,
}

/// Result of get_dynamics_info: the values in force.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct DynamicsInfo {
    /// Mass in kg (0 for a static body).
    pub mass: f64,
    /// Coulomb friction coefficient.
    pub lateral_friction: f64,
    /// Principal moments of inertia (kg·m²) about the centre of mass.
    pub local_inertia_diagonal: [f64; 3],
    /// Centre of mass in the body frame.
    pub local_inertia_pos: [f64; 3],
    /// Orientation of the principal inertia axes in the body frame [x, y, z, w].
    pub local_inertia_orn: [f64; 4],
    /// Coefficient of restitution.
    pub restitution: f64,
    /// Rolling friction (stored; not simulated by rapier).
    pub rolling_friction: f64,
    /// Spinning friction (stored; not simulated by rapier).
    pub spinning_friction: f64,
    /// Contact damping (−1 = engine default).
    pub contact_damping: f64,
    /// Contact stiffness (−1 = engine default).
    pub contact_stiffness: f64,
    /// dynamic, static or kinematic.
    pub body_type: String,
    /// Collision margin (rapier's contact skin, m).
    pub collision_margin: f64,
    /// Linear damping.
    pub linear_damping: f64,
    /// Angular damping.
    pub angular_damping: f64,
}

/// One object in get_simulation_info.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct ObjectSummary {
    /// Object id.
    pub object_id: u32,
    /// primitive (or urdf).
    #[serde(rename = "type")]
    pub kind: String,
    /// Shape name.
    pub shape: String,
    /// Shape dimensions (box half-extents, [radius], [radius, height]).
    pub dimensions: Vec<f64>,
    /// Mass in kg (0 = static).
    pub mass: f64,
    /// Current position.
    pub position: [f64; 3],
    /// An MJCF model's actuators (absent when none: only loads of event version 7 have any).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub actuators: Vec<ActuatorInfo>,
    /// An MJCF model's sensors by name (get_sensor_data; absent when none, as `actuators`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sensors: Vec<String>,
    /// An MJCF model's equality constraints (absent when none: only loads of event version 9
    /// list them, so earlier results are unchanged).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub equality: Vec<ModelElement>,
    /// An MJCF model's fixed tendons (absent when none, as `equality`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub tendons: Vec<ModelElement>,
}

/// An MJCF equality constraint or fixed tendon, as get_simulation_info lists it: what the model
/// has and whether it is simulated.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, PartialEq)]
pub struct ModelElement {
    /// Its name (`#k` when unnamed, k its index among its kind).
    pub name: String,
    /// `connect`, `weld`, `joint` or `tendon` (an equality constraint); `fixed` (a tendon).
    #[serde(rename = "type")]
    pub kind: String,
    /// The hinge or slide joints it names, by joint index (absent when none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub joints: Vec<u32>,
    /// Whether it is simulated (false: the load's `ignored` says why).
    pub built: bool,
}

/// Result of batch: each call's result as that tool returns it, in order, and where the
/// log stands after the last call.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Batched {
    /// One result per call.
    pub results: Vec<serde_json::Value>,
    /// The head after the batch.
    pub head_seq: u64,
    /// Simulated time after the batch, in seconds (with head_seq: where it landed).
    pub time: f64,
    /// The state hash after the batch.
    pub state_hash: String,
}

/// Result of run_sweep: one entry per variant, in the order given.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Swept {
    /// The variants' outcomes.
    pub variants: Vec<SweptVariant>,
    /// Variant indices, highest rank_by metric first (with rank_by).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ranking: Option<Vec<usize>>,
}

/// One variant of a sweep after its calls and steps.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct SweptVariant {
    /// Its index in `variants`.
    pub index: usize,
    /// The fork's id, when kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub simulation_id: Option<String>,
    /// Its state hash at the end (equal to doing the same by hand).
    pub state_hash: String,
    /// The observed objects' final states.
    pub objects: Vec<SweptObject>,
    /// Poses sampled while stepping (when observe.every is given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trajectory: Option<Trajectory>,
    /// Observed objects left out of `objects` because they did not move at all during the
    /// steps (no speed, no spin, the same pose and joint positions); `detail: "full"` lists
    /// them too.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub unmoved: Vec<u32>,
    /// Answers to observe.measure, computed at every step of the variant.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measures: Option<Vec<Measured>>,
    /// The call arguments this variant sets differently from some other variant, as
    /// "tool.argument" (or "tool[k].argument" when a tool is called twice) → its value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub varied: Option<serde_json::Map<String, serde_json::Value>>,
}

/// An object's final state in a sweep's variant.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct SweptObject {
    /// Object id.
    pub object_id: u32,
    /// World position of the body origin (m).
    pub position: [f64; 3],
    /// Orientation quaternion [x, y, z, w].
    pub orientation: [f64; 4],
    /// Linear velocity (m/s), with observe.include_velocities.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub linear_velocity: Option<[f64; 3]>,
    /// Angular velocity (rad/s), with observe.include_velocities.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angular_velocity: Option<[f64; 3]>,
    /// Net distance (m) from its position before the steps (after the variant's calls) to
    /// its final one.
    pub displacement: f64,
    /// Highest speed (m/s) after any of the steps.
    pub peak_speed: f64,
}

/// Result of get_simulation_info.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct SimulationInfo {
    /// Simulation id.
    pub simulation_id: String,
    /// Its label, when it was given one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Gravity [gx, gy, gz].
    pub gravity: [f64; 3],
    /// Seconds per step.
    pub timestep: f64,
    /// Simulated time in seconds.
    pub current_time: f64,
    /// Steps taken since creation.
    pub steps: u64,
    /// Whether the viewer follows this simulation.
    pub gui_enabled: bool,
    /// The objects, by id.
    pub objects: Vec<ObjectSummary>,
    /// The constraints, by id.
    pub constraints: Vec<serde_json::Value>,
    /// The state-changing event the world reflects.
    pub head_seq: u64,
    /// The last event appended, of any kind.
    pub last_seq: u64,
    /// blake3 of the state.
    pub state_hash: String,
}

/// An event named in undo/redo results.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct EventRef {
    /// The event's seq.
    pub seq: u64,
    /// The tool it recorded.
    pub tool: String,
}

/// Result of undo.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Undone {
    /// The state-changing events undone, most recent first.
    pub undone: Vec<EventRef>,
    /// The event the world now reflects.
    pub head_seq: u64,
    /// Simulated time after the undo.
    pub current_time: f64,
    /// State hash after the undo.
    pub state_hash: String,
}

/// Result of redo.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Redone {
    /// The state-changing events re-applied, oldest first.
    pub redone: Vec<EventRef>,
    /// The event the world now reflects.
    pub head_seq: u64,
    /// Simulated time after the redo.
    pub current_time: f64,
    /// State hash after the redo.
    pub state_hash: String,
}

/// One event in get_history.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct HistoryEvent {
    /// Position in the log.
    pub seq: u64,
    /// root, change, move, read or refused.
    pub kind: String,
    /// For root/change events: the state-changing event it was applied on.
    pub parent: Option<u64>,
    /// The tool called.
    pub tool: String,
    /// The arguments as sent, less sim_id unless detail is full (over 64 KB: `{"blob": hash,
    /// "bytes": n}`).
    pub arguments: serde_json::Value,
    /// Accepted (true) or refused.
    pub ok: bool,
    /// Whether it changed the world (root/change).
    pub mutates: bool,
    /// Copied from the simulation this one was forked or loaded from.
    pub inherited: bool,
    /// What happened: the recorded result (an object, or its message; unless detail is full,
    /// without the sim's own id, hashes short and fields over 256 bytes by their size),
    /// "refused: why", or what a read returned in one line ("read" if logged before that was).
    pub summary: serde_json::Value,
    /// The state hash after the event: its first 12 hex unless detail is full.
    pub state_hash: String,
}

/// Result of get_history.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct History {
    /// Events with seq > since_seq, ascending, at most `limit`.
    pub events: Vec<HistoryEvent>,
    /// The state-changing event the world reflects.
    pub head_seq: u64,
    /// The last event appended, of any kind.
    pub last_seq: u64,
    /// Fewer than `limit` events were returned to keep the reply within the reply budget:
    /// ask again from the last seq returned.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub truncated: bool,
}

/// Result of fork_simulation.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Forked {
    /// The new simulation's id.
    pub simulation_id: String,
    /// Its label, when it was given one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The simulation it was forked from.
    pub parent_id: String,
    /// The event of the parent it starts from.
    pub at_seq: u64,
    /// Its state hash (equal to the parent's at at_seq).
    pub state_hash: String,
    /// Where the viewer page is, when gui is on (HTTP only).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub viewer_url: Option<String>,
    /// Where the new simulation's own root landed: its seq (the head) and the time there.
    #[serde(flatten)]
    pub landed: Option<Landed>,
}

/// Where a refold first disagreed with the log.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Divergence {
    /// The event.
    pub seq: u64,
    /// The hash the log recorded.
    pub expected: String,
    /// The hash the refold produced.
    pub actual: String,
}

/// Result of verify_simulation.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Verified {
    /// True when every event and snapshot on the head's chain checked out.
    pub ok: bool,
    /// State-changing events refolded and checked.
    pub events_checked: u64,
    /// Snapshots whose bytes and state were checked.
    pub snapshots_checked: u64,
    /// The current state hash.
    pub state_hash: String,
    /// The first disagreement, if any.
    pub first_divergence: Option<Divergence>,
}

/// Result of save_simulation.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Saved {
    /// Confirmation.
    pub message: String,
    /// Where the file was written (inside the workspace).
    pub file_path: String,
    /// The state hash saved (a load gives a simulation with this hash).
    pub state_hash: String,
}

/// Result of load_simulation.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Loaded {
    /// The new simulation's id.
    pub simulation_id: String,
    /// Its label, when it was given one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The file it was loaded from.
    pub file_path: String,
    /// Its state hash (equal to the saved one for files with history).
    pub state_hash: String,
    /// Where the viewer page is, when gui is on (HTTP only).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub viewer_url: Option<String>,
    /// Where the new simulation's own root landed: its seq (the head) and the time there.
    #[serde(flatten)]
    pub landed: Option<Landed>,
}

/// Result of load_urdf.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct UrdfLoaded {
    /// The robot's object id.
    pub object_id: u32,
    /// The path as given.
    pub file_path: String,
    /// Base position [x, y, z].
    pub position: [f64; 3],
    /// Number of joints (fixed ones included, as PyBullet counts).
    pub num_joints: usize,
    /// Where the call landed (event version 3 on): the head after it and the time.
    #[serde(flatten)]
    pub landed: Option<Landed>,
}

/// One MJCF body and the link that carries its frame (load_mjcf's `bodies`).
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, PartialEq)]
pub struct MjcfBodyLink {
    /// The `<body name>` (MuJoCo's empty name for an unnamed body).
    pub name: String,
    /// The link of its last joint; a jointless (welded) body shares its parent's link; −1 is
    /// the base (the worldbody, or the free-joint root).
    pub link_index: i32,
}

/// Result of load_mjcf.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct MjcfLoaded {
    /// The robot's object id.
    pub object_id: u32,
    /// The path as given.
    pub file_path: String,
    /// Base position [x, y, z].
    pub position: [f64; 3],
    /// Number of joints: one per hinge or slide joint.
    pub num_joints: usize,
    /// Every `<body>` in file order with the link that carries its frame.
    pub bodies: Vec<MjcfBodyLink>,
    /// What of the file is not simulated, one sentence each.
    pub ignored: Vec<String>,
    /// The actuators, in order (set_actuator_controls).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub actuators: Vec<ActuatorInfo>,
    /// Where the call landed (event version 3 on): the head after it and the time.
    #[serde(flatten)]
    pub landed: Option<Landed>,
}

/// One MuJoCo actuator of a loaded model.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, PartialEq)]
pub struct ActuatorInfo {
    /// Name.
    pub name: String,
    /// motor, position, velocity, intvelocity, damper, general.
    pub r#type: String,
    /// Joint driven.
    pub joint_index: u32,
    /// When limited.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ctrlrange: Option<[f64; 2]>,
    /// When limited.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forcerange: Option<[f64; 2]>,
}

/// Result of get_sensor_data: MuJoCo's `sensordata`, sensor by sensor in the model's order.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, PartialEq)]
pub struct SensorData {
    /// One entry per sensor read.
    pub sensors: Vec<SensorReading>,
}

/// One MuJoCo sensor's values (docs/tools.md "MJCF models").
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, PartialEq)]
pub struct SensorReading {
    /// Its name.
    pub name: String,
    /// Its MJCF type (jointpos, framequat, force, …).
    pub r#type: String,
    /// Its values (a quaternion is [w, x, y, z], as MuJoCo's).
    pub data: Vec<f64>,
}

/// Result of get_num_joints.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct NumJoints {
    /// Number of joints (0 for primitives).
    pub num_joints: usize,
}

/// Result of get_joint_info.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct JointInfo {
    /// PyBullet joint index.
    pub joint_index: usize,
    /// URDF joint name.
    pub joint_name: String,
    /// revolute, continuous, prismatic or fixed.
    pub joint_type: String,
    /// Lower limit (0 with upper −1 means no limit).
    pub lower_limit: f64,
    /// Upper limit.
    pub upper_limit: f64,
    /// URDF effort limit (0 when not given).
    pub max_force: f64,
    /// URDF velocity limit (0 when not given).
    pub max_velocity: f64,
    /// Axis in the joint frame.
    pub joint_axis: [f64; 3],
    /// The child link's name.
    pub link_name: String,
    /// The parent link's index (−1 = the base).
    pub parent_index: i32,
    /// The MJCF actuators driving this joint (absent when none: only loads of event version 7
    /// have any, so earlier results are unchanged).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub actuators: Vec<ActuatorInfo>,
    /// The MJCF equality constraints naming this joint, by name (absent when none: only loads
    /// of event version 9 list them).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub equality: Vec<String>,
    /// The MJCF fixed tendons through this joint, by name (absent when none, as `equality`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub tendons: Vec<String>,
}

/// Result of get_joint_state.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct JointState {
    /// Position (rad or m); a ball joint's is a quaternion [x, y, z, w].
    pub joint_position: JointValue,
    /// Velocity (rad/s or m/s); a ball joint's is an angular velocity [wx, wy, wz] (child frame).
    pub joint_velocity: JointValue,
    /// Reaction wrench [Fx, Fy, Fz, Mx, My, Mz] (child link frame, moment about its centre of
    /// mass) while the joint's force/torque sensor is on; zeros otherwise, as PyBullet.
    pub reaction_forces: [f64; 6],
    /// Torque (or force) the motor applied in the last step.
    pub motor_torque: f64,
    /// Where the joint is on the set_joint_trajectory path it follows; absent when it follows
    /// none (event version 7: no earlier state has one, so earlier results are unchanged).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trajectory: Option<TrajectoryState>,
}

/// A joint's position or velocity: one number for a hinge or slide joint, several for a ball
/// joint (a quaternion [x, y, z, w]; an angular velocity [wx, wy, wz] in the child's joint
/// frame), as PyBullet's `getJointStateMultiDof` gives them. Untagged, so a one-number joint's
/// state encodes exactly as before ball joints existed.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, PartialEq)]
#[serde(untagged)]
pub enum JointValue {
    /// A hinge's or slide's coordinate or speed.
    Scalar(f64),
    /// A ball joint's quaternion or angular velocity.
    Multi(Vec<f64>),
}

impl JointValue {
    /// One number for lists of one value per joint (get_trajectory, sweeps): the value itself,
    /// or a ball joint's rotation angle (rad, from the quaternion's w) or angular speed (rad/s).
    pub fn scalar(&self) -> f64 {
        match self {
            JointValue::Scalar(x) => *x,
            JointValue::Multi(v) if v.len() == 4 => 2.0 * v[3].abs().min(1.0).acos(),
            JointValue::Multi(v) => v.iter().map(|x| x * x).sum::<f64>().sqrt(),
        }
    }
}

/// A joint's place on the trajectory it follows.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, PartialEq)]
pub struct TrajectoryState {
    /// Seconds since set_joint_trajectory.
    pub elapsed: f64,
    /// Seconds from the call to the last waypoint.
    pub duration: f64,
    /// Index of the next waypoint (times[i]) to reach.
    pub next_waypoint: usize,
}

/// Result of calculate_inverse_kinematics.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct IkSolution {
    /// One position per movable joint, in PyBullet joint order.
    pub joint_positions: Vec<f64>,
    /// Distance (m) from the end-effector link frame to the target position.
    pub position_error: f64,
    /// Angle (rad) between the reached and the target orientation (0 without a target).
    pub orientation_error: f64,
    /// Solver iterations used (all restarts included).
    pub iterations: usize,
}

/// Result of generate_revolute_joint.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct GeneratedUrdf {
    /// Where the URDF was written (absolute).
    pub urdf_path: String,
    /// Parent link shape.
    pub parent_shape: String,
    /// Child link shape.
    pub child_shape: String,
    /// Always "revolute".
    pub joint_type: String,
    /// Joint axis.
    pub joint_axis: [f64; 3],
    /// [lower, upper] in rad.
    pub joint_limits: [f64; 2],
}

/// One built-in model of list_models (the catalog's line and what a load of it builds).
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, PartialEq)]
pub struct ModelListing {
    /// The name load_urdf / load_mjcf take as `file_path`.
    pub name: String,
    /// "urdf" (load_urdf) or "mjcf" (load_mjcf).
    pub format: String,
    /// Joints as get_num_joints counts them.
    pub joints: usize,
    /// Joints that move (one degree of freedom each).
    pub dofs: usize,
    /// Mass of the moving bodies in kg (a fixed base and an MJCF floor excluded).
    pub mass: f64,
    /// Whether the base stands fixed when loaded as is.
    pub fixed_base: bool,
    /// What it is, in one line.
    pub description: String,
    /// Its licence (NOTICE has the texts).
    pub license: String,
}

/// Result of list_models.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, PartialEq)]
pub struct Models {
    /// The built-in models that match the filter, in the library's order.
    pub models: Vec<ModelListing>,
}

/// Result of write_file.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct FileWritten {
    /// The file written, relative to the workspace.
    pub path: String,
    /// Its size in bytes.
    pub bytes: u64,
}

/// One entry of list_files.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct FileEntry {
    /// Relative to the workspace (folders end with "/").
    pub path: String,
    /// Size in bytes (0 for a folder).
    pub bytes: u64,
    /// "file", "dir", "symlink" (not followed) or "other" (FIFO, socket, device).
    pub kind: String,
}

/// Result of list_files.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Files {
    /// The entries under the path, depth first in name order.
    pub entries: Vec<FileEntry>,
    /// Present and true when entries were left out (the listing's bound); `total` then says how many there are.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub truncated: bool,
    /// How many entries there are in all, when truncated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub total: Option<u64>,
}

/// Result of create_constraint.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct ConstraintCreated {
    /// Confirmation.
    pub message: String,
    /// The new constraint's id (per simulation, from 0).
    pub constraint_id: u32,
    /// fixed, prismatic, spherical or revolute.
    pub joint_type: String,
    /// Where the call landed (event version 3 on): the head after it and the time.
    #[serde(flatten)]
    pub landed: Option<Landed>,
}

/// One ray's result (PyBullet's rayTest fields; a miss has object_id −1, hit_fraction 1 and
/// zero position and normal).
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, PartialEq)]
pub struct RayHit {
    /// Whether anything was hit.
    pub hit: bool,
    /// The object hit, or −1.
    pub object_id: i64,
    /// The link hit (−1 = base or a primitive).
    pub link_index: i64,
    /// Fraction of the way from ray_from to ray_to where the hit is (1 for a miss).
    pub hit_fraction: f64,
    /// World position of the hit.
    pub hit_position: [f64; 3],
    /// World surface normal at the hit (unit, facing the ray).
    pub hit_normal: [f64; 3],
}

/// Result of ray_test_batch: one result per ray, in the order given.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct RayBatch {
    /// The results, in the order of the rays (absent when they went to `output_path`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub results: Vec<RayHit>,
    /// Number of rays cast (only with output_path).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rays: Option<u64>,
    /// Number of rays that hit something (only with output_path).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hits: Option<u64>,
    /// The .json file the full results were written to (then the result is this summary).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output_path: Option<String>,
}

/// One contact point (PyBullet's getContactPoints fields).
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Contact {
    /// Object A.
    pub object_a: u32,
    /// Object B.
    pub object_b: u32,
    /// A's link (−1 = base or a primitive).
    pub link_index_a: i64,
    /// B's link.
    pub link_index_b: i64,
    /// World contact point on A.
    pub position_on_a: [f64; 3],
    /// World contact point on B.
    pub position_on_b: [f64; 3],
    /// Unit normal pointing from B to A.
    pub contact_normal: [f64; 3],
    /// Signed separation (negative = penetration), m.
    pub contact_distance: f64,
    /// Normal force the solver applied in the last step (N, ≥ 0).
    pub normal_force: f64,
}

/// Result of get_all_collisions / get_collisions_for_pair.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Contacts {
    /// Contact points of the last step.
    pub contacts: Vec<Contact>,
}

/// Result of compute_view_matrix and compute_view_matrix_from_yaw_pitch.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct ViewMatrix {
    /// 4×4 view matrix, column-major (OpenGL), as PyBullet returns it.
    pub view_matrix: Vec<f64>,
}

/// Result of compute_projection_matrix.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct ProjectionMatrix {
    /// 4×4 perspective projection matrix, column-major (OpenGL), as PyBullet returns it.
    pub projection_matrix: Vec<f64>,
}

/// How much of the image an object covers.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, PartialEq)]
pub struct VisibleObject {
    /// The object.
    pub object_id: u32,
    /// Pixels it covers.
    pub pixels: u64,
}

/// The camera a picture was taken with, so the agent can take the next one from the same
/// place or move it (set_camera's terms; only `source` when view matrices were given).
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, PartialEq)]
pub struct CameraUsed {
    /// How it was chosen: `view_matrix` (given), `given` (distance/yaw/pitch/target given,
    /// the rest framed), `set_camera` (the viewer camera set_camera placed) or `framed` (chosen
    /// to frame the objects that move, else all).
    pub source: String,
    /// Distance to the target (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distance: Option<f64>,
    /// Yaw (degrees).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub yaw: Option<f64>,
    /// Pitch (degrees, < 0 looks down).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pitch: Option<f64>,
    /// Point looked at.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<[f64; 3]>,
}

/// The structured part of get_camera_image (the PNG travels as an MCP image content).
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct CameraImage {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Objects seen, by id, with their pixel counts.
    pub visible_objects: Vec<VisibleObject>,
    /// Nearest and farthest depth of any object pixel, metres along the view axis (null if
    /// nothing is seen).
    pub depth_range: Option<[f64; 2]>,
    /// The camera used (results recorded before event version 4 have none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<CameraUsed>,
    /// Depth in metres along the view axis, row-major from the top-left (far plane where
    /// nothing is seen); only with include_depth.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth: Option<Vec<f64>>,
    /// Object id per pixel (−1 background), row-major; only with include_segmentation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub segmentation: Option<Vec<i64>>,
    /// The PNG file written (only with output_path; the image is then not inline).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub png_path: Option<String>,
    /// The depth array as a NumPy file (`<f4`, shape (height, width)); with output_path and
    /// include_depth.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth_path: Option<String>,
    /// The segmentation array as a NumPy file (`<i4`, shape (height, width)); with
    /// output_path and include_segmentation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub segmentation_path: Option<String>,
}

/// What `World::create` and `World::apply` return: the result of a state-changing command,
/// typed. It serialises as the inner result (untagged), so the JSON recorded in the log and
/// hashed is exactly that result's; adapters take the inner type back with `TryFrom`.
#[derive(Serialize, Debug, Clone)]
#[serde(untagged)]
pub enum Outcome {
    /// create_simulation.
    Created(Created),
    /// step_simulation.
    Stepped(Stepped),
    /// set_timestep.
    TimestepSet(TimestepSet),
    /// add_* tools.
    ObjectAdded(ObjectAdded),
    /// change_dynamics.
    DynamicsChanged(DynamicsChanged),
    /// load_urdf.
    UrdfLoaded(UrdfLoaded),
    /// create_constraint.
    ConstraintCreated(ConstraintCreated),
    /// load_mjcf.
    MjcfLoaded(MjcfLoaded),
    /// Every command whose result is a confirmation sentence.
    Message(Message),
}

impl Outcome {
    /// The result as the JSON value that is recorded and hashed (`to_string` of it is the
    /// logged text, as it always was).
    pub fn to_value(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or(serde_json::Value::Null)
    }

    /// The result as recorded for event `seq` of version 3 on: with where it landed (`Landed`),
    /// `time` being the world's simulated time after it.
    pub fn land(mut self, seq: u64, time: f64) -> Outcome {
        let landed = Some(Landed { head_seq: seq, time });
        match &mut self {
            Outcome::Created(r) => r.landed = landed,
            Outcome::Stepped(r) => r.landed = landed,
            Outcome::TimestepSet(r) => r.landed = landed,
            Outcome::ObjectAdded(r) => r.landed = landed,
            Outcome::DynamicsChanged(r) => r.landed = landed,
            Outcome::UrdfLoaded(r) => r.landed = landed,
            Outcome::ConstraintCreated(r) => r.landed = landed,
            Outcome::MjcfLoaded(r) => r.landed = landed,
            Outcome::Message(r) => r.landed = landed,
        }
        self
    }

    /// The steps a step_simulation took (None for other results).
    pub fn steps_taken(&self) -> Option<u64> {
        match self {
            Outcome::Stepped(s) => Some(s.steps_taken),
            _ => None,
        }
    }
}

/// `Outcome` from and back to each result type it holds.
macro_rules! outcome_variants {
    ($($variant:ident),*) => {$(
        impl From<$variant> for Outcome {
            fn from(v: $variant) -> Outcome {
                Outcome::$variant(v)
            }
        }
        impl TryFrom<Outcome> for $variant {
            type Error = Outcome;
            fn try_from(o: Outcome) -> Result<$variant, Outcome> {
                match o {
                    Outcome::$variant(v) => Ok(v),
                    other => Err(other),
                }
            }
        }
    )*};
}
outcome_variants!(Created, Stepped, TimestepSet, ObjectAdded, DynamicsChanged, UrdfLoaded, ConstraintCreated, MjcfLoaded, Message);

/// Result of get_joint_states: get_joint_state's answer for each joint asked, in order.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct JointStates {
    /// One per joint index given.
    pub joint_states: Vec<JointState>,
}

/// Result of get_link_states: get_link_state's answer for each link asked, in order.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct LinkStates {
    /// One per link index given.
    pub link_states: Vec<LinkState>,
}

/// Result of calculate_jacobian (world frame; one column per movable joint).
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Jacobian {
    /// 3 rows: the point's linear velocity per joint velocity.
    pub linear_jacobian: Vec<Vec<f64>>,
    /// 3 rows: the link's angular velocity per joint velocity.
    pub angular_jacobian: Vec<Vec<f64>>,
}

/// Result of calculate_mass_matrix.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct MassMatrix {
    /// Joint-space inertia, one row per movable joint.
    pub mass_matrix: Vec<Vec<f64>>,
}

/// Result of calculate_inverse_dynamics.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct InverseDynamics {
    /// Torque (or force) per movable joint.
    pub joint_forces: Vec<f64>,
}

/// Result of get_aabb: the world axis-aligned box around a part's collision shapes.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Aabb {
    /// Lowest corner.
    pub aabb_min: [f64; 3],
    /// Highest corner.
    pub aabb_max: [f64; 3],
}

/// One pair of closest points (PyBullet's getClosestPoints item): per pair of collision shapes
/// of A and B no farther apart than the query's distance.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct ClosestPoint {
    /// Object A.
    pub body_a: u32,
    /// Object B.
    pub body_b: u32,
    /// A's link (−1 = base or a primitive).
    pub link_index_a: i64,
    /// B's link.
    pub link_index_b: i64,
    /// World point on A's surface.
    pub position_on_a: [f64; 3],
    /// World point on B's surface.
    pub position_on_b: [f64; 3],
    /// Unit normal pointing from B to A.
    pub contact_normal_on_b: [f64; 3],
    /// Signed distance (negative = penetration), m.
    pub contact_distance: f64,
}

/// Result of get_closest_points.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct ClosestPoints {
    /// Closest points per shape pair, in A's then B's part order.
    pub points: Vec<ClosestPoint>,
}

/// One part (an object's base or link) whose box overlaps a query box.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone, PartialEq)]
pub struct PartRef {
    /// The object.
    pub object_id: u32,
    /// Its link (−1 = base).
    pub link_index: i64,
}

/// Result of get_overlapping_objects.
#[derive(Serialize, Deserialize, JsonSchema, Debug, Clone)]
pub struct Overlapping {
    /// Each overlapping part once, in object then link order.
    pub objects: Vec<PartRef>,
}
