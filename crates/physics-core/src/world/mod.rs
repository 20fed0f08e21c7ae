//! The deterministic state machine: a rapier3d world plus our own tables.
//!
//! `World::apply` is the only way state changes. It reads nothing but the command it is given:
//! no clock, no randomness, no files, no environment (physics-core's clippy.toml bans them for
//! this crate). Iteration is always in id order (`BTreeMap`). A snapshot is the whole
//! rapier `PhysicsWorld` (broad and narrow phase included) plus our tables, so restoring one and
//! continuing is bit-identical to never having stopped.

pub mod actuators;
pub mod sensors;
mod bodies;
pub mod constraints;
pub mod dynamics;
pub mod facts;
pub mod filters;
mod hash;
mod hash_tree;
pub mod ik;
pub mod joint_trajectory;
pub mod mjcf;
pub mod mjcf_equality;
pub mod mjcf_mesh;
pub mod mjcf_options;
pub mod mjcf_pairs;
mod robot;
pub mod scene;
mod step_forces;
mod threads;
pub mod urdf;
pub mod xml_guard;

pub use threads::{set_step_threads, step_threads};

use std::collections::{BTreeMap, BTreeSet};
use std::sync::OnceLock;

use rapier3d::prelude::*;
use serde::{Deserialize, Serialize};

use crate::command::{Command, Shape};
use crate::engine::EngineRule;
use crate::outputs::{Created, Message, Outcome, Stepped, TimestepSet};
use crate::value::r32s;

pub use hash::{HashRules, STATE_HASH_V2, STATE_HASH_VERSION};
pub use robot::{Robot, RobotLink, DEFAULT_MOTOR_FORCE};

/// The robot model a LoadUrdf command's blobs describe (the check and the fold share it);
/// `rules` come from the event's own flags (see `urdf::UrdfRules`).
pub fn urdf_model(
    urdf: &crate::command::Blob,
    meshes: &std::collections::BTreeMap<String, crate::command::Blob>,
    rules: urdf::UrdfRules,
) -> Result<urdf::RobotModel, crate::value::Refusal> {
    if !urdf.is_loaded() || meshes.values().any(|m| !m.is_loaded()) {
        return Err("the URDF or one of its meshes is missing from the event".into());
    }
    let text = std::str::from_utf8(&urdf.bytes).map_err(|_| "file_path is not a valid URDF: it is not UTF-8 text".to_string())?;
    let bytes: std::collections::BTreeMap<String, Vec<u8>> =
        meshes.iter().map(|(k, b)| (k.clone(), b.bytes.to_vec())).collect();
    urdf::build(text, &bytes, rules)
}

/// PyBullet's default timestep.
pub const DEFAULT_TIMESTEP: f32 = 1.0 / 240.0;
/// PyBullet's default linear and angular damping.
pub const DEFAULT_DAMPING: f32 = 0.04;
/// PyBullet's default lateral friction.
pub const DEFAULT_FRICTION: f32 = 0.5;

/// What a body is, beyond its rapier body and collider (saved files and reports need it).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
#[serde(rename_all = "snake_case")]
pub enum ObjectKind {
    /// A primitive made by add_box / add_sphere / add_cylinder / add_capsule.
    Primitive {
        /// Its shape and dimensions.
        shape: Shape,
    },
    /// A robot loaded from a URDF.
    Robot {
        /// Its links, joints and motors.
        robot: Box<Robot>,
    },
    /// A robot loaded from a MuJoCo MJCF model (last, so older encodings are unchanged).
    Mjcf {
        /// Its links, joints and motors (`urdf_hash` is the MJCF text's blob).
        robot: Box<Robot>,
        /// Its bodies, what is ignored, and the worldbody's static body under a free base.
        mjcf: Box<mjcf::MjcfInfo>,
    },
}

impl ObjectKind {
    /// The robot, for URDF and MJCF objects alike.
    pub fn robot(&self) -> Option<&Robot> {
        match self {
            ObjectKind::Robot { robot } | ObjectKind::Mjcf { robot, .. } => Some(robot),
            ObjectKind::Primitive { .. } => None,
        }
    }

    /// The robot, mutably.
    pub fn robot_mut(&mut self) -> Option<&mut Robot> {
        match self {
            ObjectKind::Robot { robot } | ObjectKind::Mjcf { robot, .. } => Some(robot),
            ObjectKind::Primitive { .. } => None,
        }
    }
}

/// Dynamics properties rapier has no per-body equivalent for: stored, reported and saved.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct DynamicsExtras {
    /// PyBullet rolling friction (not simulated by rapier).
    pub rolling_friction: f32,
    /// PyBullet spinning friction (not simulated by rapier).
    pub spinning_friction: f32,
    /// PyBullet contact stiffness; −1 = engine default (rapier's softness is global).
    pub contact_stiffness: f32,
    /// PyBullet contact damping; −1 = engine default.
    pub contact_damping: f32,
}

impl Default for DynamicsExtras {
    fn default() -> Self {
        Self {
            rolling_friction: 0.0,
            spinning_friction: 0.0,
            contact_stiffness: -1.0,
            contact_damping: -1.0,
        }
    }
}

/// One object of the simulation: its rapier handles and what rapier does not hold.
#[derive(Serialize, Deserialize, Clone, Debug)]
pub struct Object {
    /// The rapier body.
    pub body: RigidBodyHandle,
    /// Its single collider.
    pub collider: ColliderHandle,
    /// What kind of object it is.
    pub kind: ObjectKind,
    /// RGBA color for rendering, if given.
    pub color: Option<[f32; 4]>,
    /// The mass the user asked for (kept when the body is made static, for saved files).
    pub mass: f32,
    /// Properties stored for fidelity with PyBullet's API.
    pub extras: DynamicsExtras,
}

/// Viewer settings (enable_debug_visualization / set_camera); part of the state hash.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct Viewer {
    /// Draw contact points.
    pub show_contacts: bool,
    /// Draw body frames.
    pub show_frames: bool,
    /// Camera distance to target (m).
    pub distance: f32,
    /// Camera yaw (degrees).
    pub yaw: f32,
    /// Camera pitch (degrees).
    pub pitch: f32,
    /// Camera target point.
    pub target: [f32; 3],
}

impl Viewer {
    /// Whether the camera is still the one every world starts with (distance 5, yaw 50, pitch
    /// −35, at the origin): pictures without a camera of their own frame the scene while it is
    /// (`seeing::framing`; so set_camera back to the initial camera means "frame it"), read off
    /// these hashed settings with no state of its own.
    pub fn camera_is_initial(&self) -> bool {
        let d = Viewer::default();
        (self.distance, self.yaw, self.pitch, self.target) == (d.distance, d.yaw, d.pitch, d.target)
    }
}

impl Default for Viewer {
    fn default() -> Self {
        Self {
            show_contacts: true,
            show_frames: false,
            distance: 5.0,
            yaw: 50.0,
            pitch: -35.0,
            target: [0.0, 0.0, 0.0],
        }
    }
}

/// Values kept as the client gave them, so results report them as set (docs/tools.md "Conventions": a
/// mass of 3.5 reads 3.5; time is PyBullet's f64 `n × dt`). The engine runs on f32 copies, whose
/// effects the state hash covers; these only shape what results say, so they are snapshotted
/// (restore → identical results) but not hashed (old logs keep their hashes).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct AsGiven {
    /// The timestep as last given (f64; PyBullet's default 1/240 before any set_timestep).
    pub timestep_s: f64,
    /// Reported time when that timestep was set.
    pub time_at_timestep_s: f64,
    /// Steps taken when that timestep was set.
    pub steps_at_timestep: u64,
    /// Robot link masses as set (the URDF's inertial, or change_dynamics), by (object, link):
    /// rapier keeps 1/m, which does not always invert back to m in f32.
    pub link_masses: BTreeMap<(u32, u32), f32>,
}

impl Default for AsGiven {
    fn default() -> Self {
        Self {
            timestep_s: 1.0 / 240.0,
            time_at_timestep_s: 0.0,
            steps_at_timestep: 0,
            link_masses: BTreeMap::new(),
        }
    }
}

/// Everything `apply` can change besides rapier's own sets.
#[derive(Serialize, Deserialize, Clone, Debug, Default)]
pub struct Tables {
    /// Objects by id (ordered, so iteration is deterministic).
    pub objects: BTreeMap<u32, Object>,
    /// The id the next object gets (rewound by undo like everything else).
    pub next_object_id: u32,
    /// The id the next constraint gets.
    pub next_constraint_id: u32,
    /// Simulated time in seconds (sum of the timesteps taken).
    pub time_s: f64,
    /// Steps taken since creation.
    pub steps: u64,
    /// Objects carrying a force/torque that must be cleared after the next step.
    pub pending_wrench: BTreeSet<u32>,
    /// Viewer settings.
    pub viewer: Viewer,
    /// Constraints by id.
    pub constraints: BTreeMap<u32, constraints::Constraint>,
    /// Values as the client gave them (reported, not hashed).
    pub as_given: AsGiven,
    /// Collision filters, pairs and markers the agent set (hashed when any).
    pub filters: filters::Filters,
    /// Joints whose force/torque sensor is on, as (object id, joint index): get_joint_state
    /// reports their reaction wrench. Not in the v3–v6 table encodings: snapshot version 7
    /// carries it beside the tables, written only when a sensor is on.
    #[serde(skip)]
    pub joint_sensors: BTreeSet<(u32, u32)>,
    /// Joints following a set_joint_trajectory path, by (object id, joint index). Not in the
    /// table encodings: snapshot version 9 carries it after the sensors, written only when a
    /// trajectory is followed.
    #[serde(skip)]
    pub joint_trajectories: BTreeMap<(u32, u32), joint_trajectory::JointTrajectory>,
    /// MJCF robots' actuators and their held controls, by object id (loads of event version 7
    /// on). Not in the table encodings: snapshot version 10 carries it in
    /// [`SnapshotExtensions`], written only when a robot has actuators.
    #[serde(skip)]
    pub actuation: BTreeMap<u32, actuators::Actuation>,
    /// MJCF robots' sensors (get_sensor_data), by object id (loads of event version 7 on).
    /// Not in the table encodings: snapshot version 10 carries them in [`SnapshotExtensions`],
    /// written only when a robot has actuators or sensors.
    #[serde(skip)]
    pub mjcf_sensors: BTreeMap<u32, Vec<sensors::Sensor>>,
    /// MJCF actuators driving a fixed tendon, by (object id, actuator index) (loads of event
    /// version 8 on). Not in the table encodings: snapshot version 11 carries it after version
    /// 10's extensions, written only when a robot has one.
    #[serde(skip)]
    pub transmissions: BTreeMap<(u32, u32), actuators::Transmission>,
    /// MJCF `<contact><pair>`s with their friction, by object id (loads of event version 9).
    /// Not in the table encodings: snapshot version 12 carries them after version 11's
    /// transmissions, written only when a robot has one.
    #[serde(skip)]
    pub contact_pairs: BTreeMap<u32, Vec<mjcf_pairs::PairFriction>>,
    /// MJCF models' equality constraints and fixed tendons as get_simulation_info and
    /// get_joint_info list them, by object id (loads of event version 9). Snapshot version 12
    /// carries them beside the contact pairs, written only when a robot has some.
    #[serde(skip)]
    pub mjcf_elements: BTreeMap<u32, mjcf_equality::Elements>,
}

/// The tables as snapshot version 3 encoded them (before `filters`): they restore exactly,
/// with no filters, so version-3 snapshots are still folded on.
#[derive(Deserialize)]
struct TablesV3 {
    objects: BTreeMap<u32, Object>,
    next_object_id: u32,
    next_constraint_id: u32,
    time_s: f64,
    steps: u64,
    pending_wrench: BTreeSet<u32>,
    viewer: Viewer,
    constraints: BTreeMap<u32, constraints::Constraint>,
    as_given: AsGiven,
}

/// `TablesV3`'s encoding of today's tables (those without filters), borrowed.
#[derive(Serialize)]
struct TablesV3Ref<'a> {
    objects: &'a BTreeMap<u32, Object>,
    next_object_id: u32,
    next_constraint_id: u32,
    time_s: f64,
    steps: u64,
    pending_wrench: &'a BTreeSet<u32>,
    viewer: &'a Viewer,
    constraints: &'a BTreeMap<u32, constraints::Constraint>,
    as_given: &'a AsGiven,
}

impl From<TablesV3> for Tables {
    fn from(t: TablesV3) -> Self {
        Tables {
            objects: t.objects,
            next_object_id: t.next_object_id,
            next_constraint_id: t.next_constraint_id,
            time_s: t.time_s,
            steps: t.steps,
            pending_wrench: t.pending_wrench,
            viewer: t.viewer,
            constraints: t.constraints,
            as_given: t.as_given,
            filters: filters::Filters::default(),
            joint_sensors: BTreeSet::new(),
            joint_trajectories: BTreeMap::new(),
            actuation: BTreeMap::new(),
            mjcf_sensors: BTreeMap::new(),
            transmissions: BTreeMap::new(),
            contact_pairs: BTreeMap::new(),
            mjcf_elements: BTreeMap::new(),
        }
    }
}

/// The tables as snapshot version 2 encoded them (before `as_given`).
#[derive(Deserialize)]
struct TablesV2 {
    objects: BTreeMap<u32, Object>,
    next_object_id: u32,
    next_constraint_id: u32,
    time_s: f64,
    steps: u64,
    pending_wrench: BTreeSet<u32>,
    viewer: Viewer,
    constraints: BTreeMap<u32, constraints::Constraint>,
}

impl TablesV2 {
    /// Version-2 tables with the given values approximated from the engine's: good for
    /// checking hashes, not for folding on (`World::foldable_snapshot` says which is which).
    fn upgrade(self, dt: f32) -> Tables {
        Tables {
            as_given: AsGiven {
                timestep_s: crate::value::r32(dt),
                time_at_timestep_s: self.time_s,
                steps_at_timestep: self.steps,
                link_masses: BTreeMap::new(),
            },
            objects: self.objects,
            next_object_id: self.next_object_id,
            next_constraint_id: self.next_constraint_id,
            time_s: self.time_s,
            steps: self.steps,
            pending_wrench: self.pending_wrench,
            viewer: self.viewer,
            constraints: self.constraints,
            filters: filters::Filters::default(),
            joint_sensors: BTreeSet::new(),
            joint_trajectories: BTreeMap::new(),
            actuation: BTreeMap::new(),
            mjcf_sensors: BTreeMap::new(),
            transmissions: BTreeMap::new(),
            contact_pairs: BTreeMap::new(),
            mjcf_elements: BTreeMap::new(),
        }
    }
}

/// The tables as snapshot version 1 encoded them (before constraints): old snapshots in logs
/// and saved files still restore.
#[derive(Deserialize)]
struct TablesV1 {
    objects: BTreeMap<u32, Object>,
    next_object_id: u32,
    next_constraint_id: u32,
    time_s: f64,
    steps: u64,
    pending_wrench: BTreeSet<u32>,
    viewer: Viewer,
}

impl From<TablesV1> for TablesV2 {
    fn from(t: TablesV1) -> Self {
        TablesV2 {
            objects: t.objects,
            next_object_id: t.next_object_id,
            next_constraint_id: t.next_constraint_id,
            time_s: t.time_s,
            steps: t.steps,
            pending_wrench: t.pending_wrench,
            viewer: t.viewer,
            constraints: BTreeMap::new(),
        }
    }
}

/// A simulation's state: rapier's world plus our tables. Identity (`simulation_id`) and the
/// `gui` flag live beside it and are neither hashed nor snapshotted.
///
/// The fields are private: everything that changes the state goes through `apply` (so it is
/// in the log), and readers get read-only views (`physics`, `objects`, …) or the query
/// methods below.
pub struct World {
    simulation_id: String,
    gui: bool,
    /// The simulation's optional label (its own root command's `name`): identity, like the id.
    name: Option<String>,
    physics: PhysicsWorld,
    tables: Tables,
    /// The scene index of the current state, built on first use and dropped by every `apply`.
    /// A pure function of `physics` and `tables`, neither hashed nor snapshotted: a restored
    /// world builds the same index from the same state when first asked.
    scene: OnceLock<scene::Scene>,
    /// Which state hash this world's chain records (`hash` module doc).
    hash_rules: HashRules,
    /// The v2 hash's Merkle tree over the objects, kept between calls: a cache of a pure
    /// function of the state, neither hashed nor snapshotted.
    digests: hash::Digests,
    /// Which arithmetic the engine steps with, for the world's life (`engine::EngineRule`):
    /// from its root, carried by snapshots of version 7.
    engine_rule: EngineRule,
}

/// Hook called during long steps with the steps done so far; returning false stops early.
pub type StepControl<'a> = &'a mut (dyn FnMut(u64) -> bool + Send);

/// Hook that sees the world after every simulated step of a step command (re-simulation
/// samples, live viewer progress). It gets a shared borrow, so it cannot change the state:
/// results and state hashes are the same with or without it.
pub type StepObserver<'a> = &'a mut (dyn FnMut(&World) + Send);

impl World {
    /// Builds the world a root `CreateSimulation` command describes, under today's state hash
    /// (v2) and the engine rule the root records (rule 1 when it records none); a root
    /// recorded before event version 5 is folded `with_hash_rules(HashRules::V1)`.
    pub fn create(cmd: &Command) -> Option<(World, Outcome)> {
        let Command::CreateSimulation {
            simulation_id,
            gravity,
            gui,
            name,
            engine_rule,
        } = cmd
        else {
            return None;
        };
        let engine_rule = EngineRule::of_root(*engine_rule);
        let mut physics = PhysicsWorld {
            gravity: Vector::from_array(*gravity),
            ..Default::default()
        };
        physics.integration_parameters.dt = DEFAULT_TIMESTEP;
        physics.integration_parameters.multibody_dynamics = engine_rule.multibody_dynamics();
        let world = World {
            simulation_id: simulation_id.clone(),
            gui: *gui,
            name: name.clone(),
            physics,
            tables: Tables::default(),
            scene: OnceLock::new(),
            hash_rules: HashRules::V2,
            digests: Default::default(),
            engine_rule,
        };
        let out = Created {
            landed: None,
            simulation_id: simulation_id.clone(),
            gravity: r32s(*gravity),
            gui_enabled: *gui,
            name: name.clone(),
            viewer_url: None,
        };
        Some((world, Outcome::Created(out)))
    }

    /// The same world under the state hash `rules` (a chain keeps the rules its root was
    /// recorded under: `command::hash_rules_of`).
    pub fn with_hash_rules(mut self, rules: HashRules) -> World {
        self.hash_rules = rules;
        self
    }

    /// The state hash rules this world records.
    pub fn hash_rules(&self) -> HashRules {
        self.hash_rules
    }

    /// The engine rule this world steps under (from its root; forks and loads keep their
    /// parent's).
    pub fn engine_rule(&self) -> EngineRule {
        self.engine_rule
    }

    /// The same state under another identity (a fork's root in replay).
    pub fn with_identity(mut self, simulation_id: &str, gui: bool) -> World {
        self.simulation_id = simulation_id.to_string();
        self.gui = gui;
        self
    }

    /// The same state under another label (a fork's or load's own `name`, or none).
    pub fn with_name(mut self, name: Option<String>) -> World {
        self.name = name;
        self
    }

    /// The simulation's label, if it was given one.
    pub fn name(&self) -> Option<&str> {
        self.name.as_deref()
    }

    /// The simulation's id (for error messages).
    pub fn simulation_id(&self) -> &str {
        &self.simulation_id
    }

    /// Whether the simulation was created with `gui = true`.
    pub fn gui(&self) -> bool {
        self.gui
    }

    /// Whether an object with this id exists.
    pub fn has_object(&self, id: u32) -> bool {
        self.tables.objects.contains_key(&id)
    }

    /// Number of objects.
    pub fn object_count(&self) -> usize {
        self.tables.objects.len()
    }

    /// The id the next object will get: ids are given in order and never reused, so an id at
    /// or past it never named an object of this world's chain (the viewer refuses such an
    /// inspection without re-simulating the chain).
    pub fn next_object_id(&self) -> u32 {
        self.tables.next_object_id
    }

    /// Current timestep in seconds.
    pub fn timestep(&self) -> f32 {
        self.physics.integration_parameters.dt
    }

    /// The timestep as the client gave it (what results report).
    pub fn timestep_given(&self) -> f64 {
        self.tables.as_given.timestep_s
    }

    /// Simulated time as results report it: PyBullet's f64 arithmetic — the time at the last
    /// set_timestep plus the steps since, times the timestep as given (0.004166666666666667
    /// after one default step). The engine's own clock (`tables.time_s`, summed f32 steps) is
    /// what the state hash covers.
    pub fn current_time(&self) -> f64 {
        let g = &self.tables.as_given;
        g.time_at_timestep_s + self.tables.steps.saturating_sub(g.steps_at_timestep) as f64 * g.timestep_s
    }

    /// The rapier world, read-only: sensing reads its colliders, contact pairs and integration
    /// parameters (contacts, frames); changes go through `apply`, so they are logged.
    pub fn physics(&self) -> &PhysicsWorld {
        &self.physics
    }

    /// Gravity (m/s²) as the engine holds it (get_simulation_info and saved files report it).
    pub fn gravity(&self) -> [f32; 3] {
        self.physics.gravity.to_array()
    }

    /// Steps taken since creation (simulation info and the viewer report it).
    pub fn steps(&self) -> u64 {
        self.tables.steps
    }

    /// The engine's clock: the sum of the f32 timesteps taken, which the state hash covers
    /// (files saved before event version 2 wrote it as their time; `current_time` is what
    /// results report).
    pub fn engine_time(&self) -> f64 {
        self.tables.time_s
    }

    /// Viewer settings (camera and debug drawing), for the viewer and get_camera_image's
    /// default camera.
    pub fn viewer(&self) -> &Viewer {
        &self.tables.viewer
    }

    /// Every object with its id, in id order (saved files list them).
    pub fn objects(&self) -> impl Iterator<Item = (u32, &Object)> {
        self.tables.objects.iter().map(|(id, o)| (*id, o))
    }

    /// Every collider where it is now, with a tree over them (rays, camera, contacts' owners).
    /// Built at most once per state — consecutive reads of an unchanged world share it — and
    /// exactly as a fresh build would be, so results never depend on whether it was cached.
    pub fn scene(&self) -> &scene::Scene {
        self.scene.get_or_init(|| scene::Scene::new(self))
    }

    /// Applies an accepted command and returns its result. Cannot fail for a command that
    /// passed `Command::validate`; `control` may stop a long step early (the steps done stay).
    pub fn apply(&mut self, cmd: &Command, control: StepControl) -> Outcome {
        self.apply_observed(cmd, control, &mut |_| {})
    }

    /// `apply` with `observe` called after every step a step command takes (read-only; the
    /// result and the state are exactly those of `apply`).
    pub fn apply_observed(&mut self, cmd: &Command, control: StepControl, observe: StepObserver) -> Outcome {
        // Any command may move, add or remove colliders: the scene index is rebuilt on demand.
        self.scene.take();
        // What it may change among the objects, for the state hash's kept tree: marked before
        // (an observer may ask for the hash mid-step) and again after (what changed after the
        // observer asked is stale too).
        let touched = hash::touched_by(cmd, self.tables.next_object_id);
        self.digests.mark(touched.clone());
        let out = self.apply_unmarked(cmd, control, observe);
        self.digests.mark(touched);
        out
    }

    /// `apply_observed` without the hash bookkeeping.
    fn apply_unmarked(&mut self, cmd: &Command, control: StepControl, observe: StepObserver) -> Outcome {
        match cmd {
            Command::CreateSimulation { .. }
            | Command::ForkSimulation { .. }
            | Command::LoadSimulation { .. } => {
                Outcome::Message(Message::new("a root event changes nothing in an existing world"))
            }
            Command::StepSimulation { steps, .. } => {
                let taken = self.step(*steps, control, observe);
                Outcome::Stepped(Stepped {
                    landed: None,
                    simulation_id: self.simulation_id.clone(),
                    steps_taken: taken,
                    current_time: self.current_time(),
                    trajectory: None,
                    measures: None,
                })
            }
            Command::SetTimestep { timestep, timestep_given } => {
                let given = timestep_given.unwrap_or_else(|| crate::value::r32(*timestep));
                self.set_timestep(*timestep, given);
                Outcome::TimestepSet(TimestepSet {
                    landed: None,
                    message: format!("Timestep set to {given} s"),
                    timestep: given,
                })
            }
            Command::LoadUrdf { file_path, urdf, meshes, position, orientation, fixed_base, parsed, .. } => {
                let model = match parsed.get() {
                    Some(m) => Ok(urdf::RobotModel::clone(m)),
                    None => urdf_model(urdf, meshes, cmd.urdf_rules()),
                };
                match model {
                    Ok(model) => {
                        let pose = Pose::from_parts(
                            Vector::from_array(*position),
                            Rotation::from_xyzw(orientation[0], orientation[1], orientation[2], orientation[3]),
                        );
                        self.insert_robot(model, file_path, (urdf, meshes), pose, *fixed_base).into()
                    }
                    Err(why) => Outcome::Message(Message::new(why)),
                }
            }
            Command::LoadMjcf {
                file_path,
                mjcf,
                meshes,
                position,
                orientation,
                fixed_base,
                keyframe,
                parent_filter,
                use_model_options,
                actuators,
                constraints,
                ball_joints_and_pairs,
                parsed,
            } => {
                let prepared = match parsed.get() {
                    Some(p) => Ok(mjcf::Prepared::clone(p)),
                    None => mjcf::prepare_blob(mjcf, meshes, keyframe.as_deref()),
                };
                match prepared {
                    Ok(prepared) => {
                        let pose = Pose::from_parts(
                            Vector::from_array(*position),
                            Rotation::from_xyzw(orientation[0], orientation[1], orientation[2], orientation[3]),
                        );
                        let options = prepared.options();
                        let mut loaded = self.insert_mjcf(prepared, file_path, (mjcf, meshes), pose, (*fixed_base, *parent_filter, *actuators, *constraints, *ball_joints_and_pairs), keyframe.as_deref());
                        if *use_model_options {
                            self.use_model_options(&mut loaded, options);
                        }
                        loaded.into()
                    }
                    Err(why) => Outcome::Message(Message::new(why)),
                }
            }
            Command::SetActuatorControls { object_id, controls } => {
                Outcome::Message(Message::new(self.set_actuator_controls(*object_id, controls)))
            }
            Command::SetJointMotor { object_id, joint_index, motor } => {
                self.end_trajectory(*object_id, *joint_index);
                Outcome::Message(Message::new(self.set_motor(*object_id, *joint_index, motor)))
            }
            Command::SetJointMotors { object_id, motors } => {
                for (j, m) in motors {
                    self.end_trajectory(*object_id, *j);
                    self.set_motor(*object_id, *j, m);
                }
                let joints: Vec<u32> = motors.iter().map(|(j, _)| *j).collect();
                let mode = motors.first().map_or("", |(_, m)| m.mode.name());
                Outcome::Message(Message::new(format!("Motors of joints {joints:?} of object {object_id} set to {mode}")))
            }
            Command::SetCollisionFilter { object_id, link_index, group, mask, pybullet_test } => {
                Outcome::Message(Message::new(self.set_collision_filter(*object_id, *link_index, (*group, *mask), *pybullet_test)))
            }
            Command::SetCollisionPair { a, b, enable } => Outcome::Message(Message::new(self.set_collision_pair(*a, *b, *enable))),
            Command::ResetJointState { object_id, joint_index, target_value, target_velocity } => {
                Outcome::Message(Message::new(self.reset_joint(*object_id, *joint_index, *target_value, *target_velocity)))
            }
            Command::SetJointTrajectory { object_id, trajectory } => {
                Outcome::Message(Message::new(self.set_trajectory(*object_id, trajectory)))
            }
            Command::EnableJointForceTorqueSensor { object_id, joint_index, enable } => {
                let key = (*object_id, *joint_index);
                let state = if *enable {
                    self.tables.joint_sensors.insert(key);
                    "on"
                } else {
                    self.tables.joint_sensors.remove(&key);
                    "off"
                };
                Outcome::Message(Message::new(format!("Force/torque sensor of joint {joint_index} of object {object_id} {state}")))
            }
            Command::CreateConstraint { spec } => self.insert_constraint(spec).into(),
            Command::SetDebugVisualization { show_contacts, show_frames } => {
                self.tables.viewer.show_contacts = *show_contacts;
                self.tables.viewer.show_frames = *show_frames;
                Outcome::Message(Message::new(format!(
                    "Debug visualization: contacts {}, frames {}",
                    if *show_contacts { "shown" } else { "hidden" },
                    if *show_frames { "shown" } else { "hidden" }
                )))
            }
            Command::SetCamera { distance, yaw, pitch, target } => {
                let v = &mut self.tables.viewer;
                (v.distance, v.yaw, v.pitch, v.target) = (*distance, *yaw, *pitch, *target);
                Outcome::Message(Message::new(format!(
                    "Camera set: distance {distance} m, yaw {yaw}°, pitch {pitch}°, target {:?}",
                    crate::value::r32s(*target)
                )))
            }
            Command::RemoveConstraint { constraint_id } => {
                self.remove_constraint(*constraint_id);
                Outcome::Message(Message::new(format!("Constraint {constraint_id} removed")))
            }
            other => self.apply_body_command(other).into(),
        }
    }

    /// The engine steps `dt` from now on, reported as `given` (the value as the caller wrote it):
    /// the current time so far is kept, later steps add `given` each (set_timestep, and
    /// load_mjcf's `use_model_options`).
    pub(super) fn set_timestep(&mut self, dt: f32, given: f64) {
        let (now, steps) = (self.current_time(), self.tables.steps);
        let g = &mut self.tables.as_given;
        (g.timestep_s, g.time_at_timestep_s, g.steps_at_timestep) = (given, now, steps);
        self.physics.integration_parameters.dt = dt;
    }

    /// Advances `n` steps, clearing one-step forces after the first. Returns the steps taken.
    fn step(&mut self, n: u64, control: StepControl, observe: StepObserver) -> u64 {
        self.in_pool(|w| w.step_here(n, control, observe))
    }

    /// [`World::step`] on the calling thread.
    fn step_here(&mut self, n: u64, control: StepControl, observe: StepObserver) -> u64 {
        const CHECK_EVERY: u64 = 64;
        let mut taken = 0;
        let excluded = filters::ContactFilter::of(self);
        // The rule's arithmetic, whatever the parameters were restored or copied with (rapier
        // does not serialise this choice).
        self.physics.integration_parameters.multibody_dynamics = self.engine_rule.multibody_dynamics();
        while taken < n {
            self.follow_trajectories();
            let watches = self.drive_motors();
            self.drive_actuators();
            if excluded.is_empty() {
                self.physics.step();
            } else {
                self.physics.step_with_events(&excluded, &());
            }
            if !watches.is_empty() {
                self.record_motor_torques(watches);
            }
            self.clear_pending_wrench();
            self.integrate_activations();
            self.tables.time_s += self.physics.integration_parameters.dt as f64;
            self.tables.steps += 1;
            taken += 1;
            // The bodies moved: an observer reading the scene index must see this step's poses.
            self.scene.take();
            observe(self);
            if taken % CHECK_EVERY == 0 && taken < n && !control(taken) {
                break;
            }
        }
        taken
    }

    /// Serialises the complete state (rapier sets with their caches, plus our tables).
    pub fn snapshot(&self) -> Vec<u8> {
        // Sized up front (≈ 4.5 KB per body in a settled pile): growing a multi-MB Vec by
        // doubling copies it several times, a sizeable part of the snapshot's cost.
        let hint = 64 * 1024 + 6 * 1024 * self.physics.bodies.len();
        let out = Vec::with_capacity(hint);
        let t = &self.tables;
        // A world that never used the collision filters is encoded as version 3 was, byte for
        // byte: its snapshots (and their hashes, which logs and tests record) stay as they were.
        let encoded = if !t.contact_pairs.is_empty() || !t.mjcf_elements.is_empty() {
            // Version 12: version 11's followed by the MJCF contact pairs and listed elements.
            let rules = SnapshotRules { hash_v2: self.hash_rules == HashRules::V2, engine_rule: self.engine_rule };
            let ext = SnapshotExtensions { actuation: t.actuation.clone(), mjcf_sensors: t.mjcf_sensors.clone() };
            postcard::to_extend(&(12u32, &self.physics, t, rules, &t.joint_sensors, &t.joint_trajectories, ext, &t.transmissions, (&t.contact_pairs, &t.mjcf_elements)), out)
        } else if !t.transmissions.is_empty() {
            // Version 11: version 10's followed by the tendon transmissions.
            let rules = SnapshotRules { hash_v2: self.hash_rules == HashRules::V2, engine_rule: self.engine_rule };
            let ext = SnapshotExtensions { actuation: t.actuation.clone(), mjcf_sensors: t.mjcf_sensors.clone() };
            postcard::to_extend(&(11u32, &self.physics, t, rules, &t.joint_sensors, &t.joint_trajectories, ext, &t.transmissions), out)
        } else if !t.actuation.is_empty() || !t.mjcf_sensors.is_empty() {
            // Version 10: version 9's followed by the MJCF actuators and their held controls.
            let rules = SnapshotRules { hash_v2: self.hash_rules == HashRules::V2, engine_rule: self.engine_rule };
            let ext = SnapshotExtensions { actuation: t.actuation.clone(), mjcf_sensors: t.mjcf_sensors.clone() };
            postcard::to_extend(&(10u32, &self.physics, t, rules, &t.joint_sensors, &t.joint_trajectories, ext), out)
        } else if !t.joint_trajectories.is_empty() {
            // Version 9: version 8's followed by the joint trajectories being followed.
            let rules = SnapshotRules { hash_v2: self.hash_rules == HashRules::V2, engine_rule: self.engine_rule };
            postcard::to_extend(&(9u32, &self.physics, t, rules, &t.joint_sensors, &t.joint_trajectories), out)
        } else if !t.joint_sensors.is_empty() {
            // Version 8: version 7's followed by the joint force/torque sensors that are on.
            let rules = SnapshotRules { hash_v2: self.hash_rules == HashRules::V2, engine_rule: self.engine_rule };
            postcard::to_extend(&(8u32, &self.physics, t, rules, &t.joint_sensors), out)
        } else if self.engine_rule != EngineRule::Upstream {
            // Version 7: the engine rule (and the state hash rules) travel with the snapshot.
            let rules = SnapshotRules { hash_v2: self.hash_rules == HashRules::V2, engine_rule: self.engine_rule };
            postcard::to_extend(&(7u32, &self.physics, t, rules), out)
        } else if self.hash_rules == HashRules::V2 {
            // Version 6 is version 5's encoding in a world whose chain records state hash v2.
            postcard::to_extend(&(6u32, &self.physics, t), out)
        } else if t.filters.is_empty() {
            let v3 = self.tables_v3_ref();
            postcard::to_extend(&(3u32, &self.physics, v3), out)
        } else if !t.filters.pybullet_test {
            // Filters of the first release, before `pybullet_test`: as version 4 wrote them.
            let v3 = self.tables_v3_ref();
            postcard::to_extend(&(4u32, &self.physics, v3, t.filters.v4()), out)
        } else {
            postcard::to_extend(&(5u32, &self.physics, t), out)
        };
        encoded.unwrap_or_default()
    }

    /// The tables as version 3 encoded them (everything but the filters), borrowed.
    fn tables_v3_ref(&self) -> TablesV3Ref<'_> {
        let t = &self.tables;
        TablesV3Ref {
            objects: &t.objects,
            next_object_id: t.next_object_id,
            next_constraint_id: t.next_constraint_id,
            time_s: t.time_s,
            steps: t.steps,
            pending_wrench: &t.pending_wrench,
            viewer: &t.viewer,
            constraints: &t.constraints,
            as_given: &t.as_given,
        }
    }

    /// A working copy of this world that continues exactly as this one would (what
    /// `restore(snapshot())` gives, without the encoding): a batch applies its calls to a
    /// copy and keeps it only if every call is accepted. The pipelines and the CCD solver are
    /// per-step workspaces, left out exactly as a snapshot leaves them out.
    pub fn duplicate(&self) -> World {
        let p = &self.physics;
        World {
            simulation_id: self.simulation_id.clone(),
            gui: self.gui,
            name: self.name.clone(),
            physics: PhysicsWorld {
                gravity: p.gravity,
                integration_parameters: p.integration_parameters,
                islands: p.islands.clone(),
                broad_phase: p.broad_phase.clone(),
                narrow_phase: p.narrow_phase.clone(),
                bodies: p.bodies.clone(),
                colliders: p.colliders.clone(),
                impulse_joints: p.impulse_joints.clone(),
                multibody_joints: p.multibody_joints.clone(),
                soft_bodies: p.soft_bodies.clone(),
                ..Default::default()
            },
            tables: self.tables.clone(),
            scene: OnceLock::new(),
            hash_rules: self.hash_rules,
            digests: self.digests.duplicate(),
            engine_rule: self.engine_rule,
        }
    }

    /// Rebuilds a world from `snapshot` bytes. Identity comes from the caller (a fork or load
    /// restores another simulation's snapshot under a new id).
    pub fn restore(simulation_id: &str, gui: bool, bytes: &[u8]) -> Result<World, String> {
        let bad = |e: postcard::Error| format!("snapshot does not decode: {e}");
        let (version, _): (u32, &[u8]) = postcard::take_from_bytes(bytes).map_err(bad)?;
        let mut rules = SnapshotRules { hash_v2: version == 6, engine_rule: EngineRule::Upstream };
        let (mut physics, tables) = match version {
            11 | 12 => {
                type V11 = (
                    u32,
                    PhysicsWorld,
                    Tables,
                    SnapshotRules,
                    BTreeSet<(u32, u32)>,
                    BTreeMap<(u32, u32), joint_trajectory::JointTrajectory>,
                    SnapshotExtensions,
                    BTreeMap<(u32, u32), actuators::Transmission>,
                );
                // Version 12 is version 11's encoding followed by the contact pairs and listed
                // elements (postcard writes a tuple's fields one after another, unframed).
                let ((_, physics, mut tables, recorded, sensors, trajectories, ext, transmissions), rest): (V11, &[u8]) =
                    postcard::take_from_bytes(bytes).map_err(bad)?;
                rules = recorded;
                tables.joint_sensors = sensors;
                tables.joint_trajectories = trajectories;
                tables.actuation = ext.actuation;
                tables.mjcf_sensors = ext.mjcf_sensors;
                tables.transmissions = transmissions;
                if version == 12 {
                    type Since12 = (BTreeMap<u32, Vec<mjcf_pairs::PairFriction>>, BTreeMap<u32, mjcf_equality::Elements>);
                    (tables.contact_pairs, tables.mjcf_elements) = postcard::from_bytes::<Since12>(rest).map_err(bad)?;
                }
                (physics, tables)
            }
            10 => {
                type V10 = (u32, PhysicsWorld, Tables, SnapshotRules, BTreeSet<(u32, u32)>, BTreeMap<(u32, u32), joint_trajectory::JointTrajectory>, SnapshotExtensions);
                let (_, physics, mut tables, recorded, sensors, trajectories, ext): V10 = postcard::from_bytes(bytes).map_err(bad)?;
                rules = recorded;
                tables.joint_sensors = sensors;
                tables.joint_trajectories = trajectories;
                tables.actuation = ext.actuation;
                tables.mjcf_sensors = ext.mjcf_sensors;
                (physics, tables)
            }
            9 => {
                type V9 = (u32, PhysicsWorld, Tables, SnapshotRules, BTreeSet<(u32, u32)>, BTreeMap<(u32, u32), joint_trajectory::JointTrajectory>);
                let (_, physics, mut tables, recorded, sensors, trajectories): V9 = postcard::from_bytes(bytes).map_err(bad)?;
                rules = recorded;
                tables.joint_sensors = sensors;
                tables.joint_trajectories = trajectories;
                (physics, tables)
            }
            8 => {
                let (_, physics, mut tables, recorded, sensors): (u32, PhysicsWorld, Tables, SnapshotRules, BTreeSet<(u32, u32)>) =
                    postcard::from_bytes(bytes).map_err(bad)?;
                rules = recorded;
                tables.joint_sensors = sensors;
                (physics, tables)
            }
            7 => {
                let (_, physics, tables, recorded): (u32, PhysicsWorld, Tables, SnapshotRules) =
                    postcard::from_bytes(bytes).map_err(bad)?;
                rules = recorded;
                (physics, tables)
            }
            5 | 6 => {
                let (_, physics, tables): (u32, PhysicsWorld, Tables) =
                    postcard::from_bytes(bytes).map_err(bad)?;
                (physics, tables)
            }
            4 => {
                // Version 4's tables are version 3's followed by the first release's filters.
                let (_, physics, tables, filters): (u32, PhysicsWorld, TablesV3, filters::FiltersV4) =
                    postcard::from_bytes(bytes).map_err(bad)?;
                let mut tables: Tables = tables.into();
                tables.filters = filters.into();
                (physics, tables)
            }
            3 => {
                let (_, physics, tables): (u32, PhysicsWorld, TablesV3) =
                    postcard::from_bytes(bytes).map_err(bad)?;
                (physics, tables.into())
            }
            2 => {
                let (_, physics, tables): (u32, PhysicsWorld, TablesV2) =
                    postcard::from_bytes(bytes).map_err(bad)?;
                let dt = physics.integration_parameters.dt;
                (physics, tables.upgrade(dt))
            }
            1 => {
                let (_, physics, tables): (u32, PhysicsWorld, TablesV1) =
                    postcard::from_bytes(bytes).map_err(bad)?;
                let dt = physics.integration_parameters.dt;
                (physics, TablesV2::from(tables).upgrade(dt))
            }
            v => return Err(format!("snapshot version {v} is not supported")),
        };
        physics.integration_parameters.multibody_dynamics = rules.engine_rule.multibody_dynamics();
        Ok(World {
            simulation_id: simulation_id.to_string(),
            gui,
            name: None,
            physics,
            tables,
            scene: OnceLock::new(),
            hash_rules: if rules.hash_v2 { HashRules::V2 } else { HashRules::V1 },
            digests: Default::default(),
            engine_rule: rules.engine_rule,
        })
    }

    /// Whether a fold may start from these snapshot bytes: versions 1 and 2 restore (their
    /// hashes can be checked) but lack the values as given, so results computed on them could
    /// differ from a fold from the root's; versions 3 and 4 lack only state they could not have
    /// had (filters; PyBullet's filter test), so they restore exactly; folds start at such a
    /// snapshot or the root.
    pub fn foldable_snapshot(bytes: &[u8]) -> bool {
        postcard::take_from_bytes::<u32>(bytes).is_ok_and(|(v, _)| (3..=SNAPSHOT_VERSION).contains(&v))
    }

    /// blake3 (hex) over the canonical encoding of everything `apply` can change, under this
    /// world's rules (`hash` module doc; v2 re-hashes only the objects changed since last asked).
    pub fn state_hash(&self) -> String {
        hash::state_hash(self)
    }

    /// `state_hash` recomputed from nothing, ignoring the kept tree: what the incremental hash
    /// must always equal (the property tests compare them after every event).
    pub fn state_hash_from_scratch(&self) -> String {
        hash::state_hash_from_scratch(self)
    }
}

/// Version of the snapshot encoding (2 added constraints to the tables, 3 the values as given,
/// 4 the collision filters, written only for worlds that have any — others are written as 3;
/// 5 PyBullet's filter test (`Filters::pybullet_test`), written only for worlds that use it —
/// worlds with the first release's filters are written as 4; 6 is 5's encoding in a world
/// whose chain records state hash v2 (every world created from event version 5 on), so the
/// rules travel with forks and loads; worlds of older chains are still written as 3, 4 or 5;
/// 7 is 5's encoding followed by [`SnapshotRules`], written for worlds of an engine rule after
/// rule 1 (every world created from event version 6 on), so the rule travels with forks,
/// loads and restarts; 8 is 7's followed by the joint force/torque sensors that are on
/// (`Tables::joint_sensors`), written only for a world with one; 9 is 8's followed by the
/// joint trajectories being followed (`Tables::joint_trajectories`), written only for a world
/// with one; 10 is 9's followed by [`SnapshotExtensions`] (the MJCF actuators and their held
/// controls, and the MJCF sensors), written only for a world with some (9 and 10 are both event version 7's: two
/// features of one release, merged); 11 is 10's followed by the MJCF tendon transmissions
/// (`Tables::transmissions`, event version 8), written only for a world with one; 12 is 11's
/// followed by the MJCF contact pairs and listed equality constraints and tendons
/// (`Tables::contact_pairs`, `Tables::mjcf_elements`, event version 9), written only for a
/// world with some; every other world is written as before, byte for byte; 1
/// to 5 still restore, under state hash v1 and engine rule 1, 6 under v2 and rule 1).
pub const SNAPSHOT_VERSION: u32 = 12;

/// The state a version-10 snapshot carries after version 9's.
#[derive(Serialize, Deserialize, Clone, Debug, Default)]
struct SnapshotExtensions {
    /// `Tables::actuation`.
    actuation: BTreeMap<u32, actuators::Actuation>,
    /// `Tables::mjcf_sensors`.
    mjcf_sensors: BTreeMap<u32, Vec<sensors::Sensor>>,
}

/// The rules a version-7 to -10 snapshot carries after the tables: the world's state hash rules
/// and engine rule, which older versions imply (`SNAPSHOT_VERSION`).
#[derive(Serialize, Deserialize, Clone, Copy, Debug)]
struct SnapshotRules {
    /// State hash v2 (else v1).
    hash_v2: bool,
    /// The engine rule.
    engine_rule: EngineRule,
}

impl From<bodies::BodyOutcome> for Outcome {
    fn from(o: bodies::BodyOutcome) -> Outcome {
        match o {
            bodies::BodyOutcome::Added(v) => v.into(),
            bodies::BodyOutcome::Changed(v) => v.into(),
            bodies::BodyOutcome::Message(v) => v.into(),
        }
    }
}
