//! Robot tools: load_urdf, joints, motors, joint trajectories, inverse kinematics,
//! generate_revolute_joint.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};

use crate::params::lenient::NumList;
use crate::params::{self, GenerateRevolute, JointTrajectory, LoadUrdf, MotorControl, MotorControlArray};
use crate::mcp::PhysicsServer;
use crate::command::{Command, ControlMode, MotorSpec};
use crate::outputs::{GeneratedUrdf, IkSolution, JointInfo, JointState, Message, NumJoints, UrdfLoaded};
use crate::sim::reads;
use crate::value::Refusal;

fn control_mode(text: &str) -> Result<ControlMode, Refusal> {
    match text {
        "POSITION_CONTROL" => Ok(ControlMode::PositionControl),
        "VELOCITY_CONTROL" => Ok(ControlMode::VelocityControl),
        "TORQUE_CONTROL" => Ok(ControlMode::TorqueControl),
        "PD_CONTROL" | "STABLE_PD_CONTROL" => Err(format!(
            "control_mode {text} is not supported; use POSITION_CONTROL, a PD motor with position_gain and velocity_gain"
        )),
        other => Err(format!("control_mode must be POSITION_CONTROL, VELOCITY_CONTROL or TORQUE_CONTROL; got {other}")),
    }
}

/// One joint's motor from its values; `at` names the entry in refusals ("" alone, "[i]" in
/// an array call: the array parameters are the single ones' names in the plural).
struct MotorValues {
    target_position: Option<f32>,
    target_velocity: Option<f32>,
    force: Option<f32>,
    position_gain: Option<f32>,
    velocity_gain: Option<f32>,
}

fn motor_spec(mode: ControlMode, v: MotorValues, plural: bool, at: &str) -> Result<MotorSpec, Refusal> {
    let name = |one: &str, many: &str| if plural { format!("{many}{at}") } else { one.to_string() };
    let target_position = match (mode, v.target_position) {
        (ControlMode::PositionControl, None) => {
            return Err(format!("{} is required for POSITION_CONTROL", name("target_position", "target_positions")))
        }
        (_, t) => t.unwrap_or(0.0),
    };
    if mode == ControlMode::TorqueControl && v.force.is_none() {
        return Err(format!("{} is required for TORQUE_CONTROL (it is the torque applied each step)", name("force", "forces")));
    }
    let gain = |g: Option<f32>, default: f32, one: &str, many: &str| match g {
        Some(g) if g.is_nan() || g < 0.0 => Err(format!("{} must be a finite number >= 0; got {g}", name(one, many))),
        g => Ok(g.unwrap_or(default)),
    };
    Ok(MotorSpec {
        mode,
        target_position,
        target_velocity: v.target_velocity.unwrap_or(0.0),
        force: v.force,
        position_gain: gain(v.position_gain, 0.1, "position_gain", "position_gains")?,
        velocity_gain: gain(v.velocity_gain, 1.0, "velocity_gain", "velocity_gains")?,
    })
}

pub(super) fn decide_motor(p: MotorControl) -> Result<Command, Refusal> {
    let object_id = p.object_id.0;
    let joint_index = p.joint_index.get();
    let joint_index = u32::try_from(joint_index)
        .map_err(|_| format!("Joint index {joint_index} out of range: object {object_id} has no such joint"))?;
    let values = MotorValues {
        target_position: p.target_position.map(|t| t.0),
        target_velocity: p.target_velocity.map(|v| v.0),
        force: p.force.map(|f| f.0),
        position_gain: p.position_gain.map(|g| g.0),
        velocity_gain: p.velocity_gain.map(|g| g.0),
    };
    let motor = motor_spec(control_mode(&p.control_mode.0)?, values, false, "")?;
    Ok(Command::SetJointMotor { object_id, joint_index, motor })
}

pub(super) fn decide_motor_array(p: MotorControlArray) -> Result<Command, Refusal> {
    let object_id = p.object_id.0;
    let mode = control_mode(&p.control_mode.0)?;
    let n = p.joint_indices.len();
    if n == 0 {
        return Err("joint_indices must name at least one joint".into());
    }
    // Each list, when given, has one entry per joint.
    let list = |l: Option<NumList>, name: &str| -> Result<Option<Vec<f32>>, Refusal> {
        match l {
            Some(l) if l.0.len() != n => Err(format!("{name} must have one entry per joint index ({n}); got {}", l.0.len())),
            Some(l) => l.0.iter().enumerate().map(|(i, x)| crate::value::number(&format!("{name}[{i}]"), &serde_json::json!(x))).collect::<Result<Vec<_>, _>>().map(Some),
            None => Ok(None),
        }
    };
    let (tp, tv, f, pg, vg) = (
        list(p.target_positions, "target_positions")?,
        list(p.target_velocities, "target_velocities")?,
        list(p.forces, "forces")?,
        list(p.position_gains, "position_gains")?,
        list(p.velocity_gains, "velocity_gains")?,
    );
    let at = |l: &Option<Vec<f32>>, i: usize| l.as_ref().map(|v| v[i]);
    let mut motors = Vec::with_capacity(n);
    for (i, j) in p.joint_indices.iter().enumerate() {
        let joint = u32::try_from(j.get())
            .map_err(|_| format!("joint_indices[{i}] = {} is out of range: object {object_id} has no such joint", j.get()))?;
        let values = MotorValues { target_position: at(&tp, i), target_velocity: at(&tv, i), force: at(&f, i), position_gain: at(&pg, i), velocity_gain: at(&vg, i) };
        motors.push((joint, motor_spec(mode, values, true, &format!("[{i}]"))?));
    }
    Ok(Command::SetJointMotors { object_id, motors })
}

/// set_joint_trajectory's arguments → the command (the joints are checked against the world
/// later, `World::check_trajectory`).
pub(super) fn decide_trajectory(p: JointTrajectory) -> Result<Command, Refusal> {
    let object_id = p.object_id.0;
    let joint_indices = p
        .joint_indices
        .iter()
        .enumerate()
        .map(|(i, j)| u32::try_from(j.get()).map_err(|_| format!("joint_indices[{i}] = {} is out of range: object {object_id} has no such joint", j.get())))
        .collect::<Result<Vec<_>, _>>()?;
    let f32s = |l: Option<NumList>, name: &str| -> Result<Option<Vec<f32>>, Refusal> {
        l.map(|l| l.0.iter().enumerate().map(|(i, x)| crate::value::number(&format!("{name}[{i}]"), &serde_json::json!(x))).collect()).transpose()
    };
    let rows = |l: Vec<NumList>| l.into_iter().map(|r| r.0).collect::<Vec<_>>();
    let trajectory = crate::world::joint_trajectory::TrajectorySpec {
        joint_indices,
        times: p.times.0,
        positions: rows(p.positions),
        velocities: p.velocities.map(rows),
        forces: f32s(p.forces, "forces")?,
        position_gains: f32s(p.position_gains, "position_gains")?,
        velocity_gains: f32s(p.velocity_gains, "velocity_gains")?,
    };
    Ok(Command::SetJointTrajectory { object_id, trajectory })
}

#[tool_router(router = robot_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Load a URDF (workspace path or plane/cube/sphere.urdf); PyBullet joint numbering, no motors.
    #[tool(input_schema = schema_for_type::<params::LoadUrdf>())]
    async fn load_urdf(&self, args: JsonObject) -> Result<Json<UrdfLoaded>, String> {
        self.change_reading("load_urdf", args, |p: LoadUrdf, reader| crate::files::urdf::load_urdf_command(reader, &p))
            .await
    }

    /// Number of joints (fixed ones included; 0 for primitives).
    #[tool(input_schema = schema_for_type::<params::ObjectRef>(), annotations(read_only_hint = true))]
    async fn get_num_joints(&self, args: JsonObject) -> Result<Json<NumJoints>, String> {
        self.read("get_num_joints", args, |sim, p| reads::num_joints(&sim.read_context(), &p)).await
    }

    /// A joint's name, type, limits (lower 0, upper -1: none), axis and links.
    #[tool(input_schema = schema_for_type::<params::JointRef>(), annotations(read_only_hint = true))]
    async fn get_joint_info(&self, args: JsonObject) -> Result<Json<JointInfo>, String> {
        self.read("get_joint_info", args, |sim, p| reads::joint_info(&sim.read_context(), &p)).await
    }

    /// A joint's position, velocity, reaction forces (zeros), last motor torque.
    #[tool(input_schema = schema_for_type::<params::JointRef>(), annotations(read_only_hint = true))]
    async fn get_joint_state(&self, args: JsonObject) -> Result<Json<JointState>, String> {
        self.read("get_joint_state", args, |sim, p| reads::joint_state(&sim.read_context(), &p)).await
    }

    /// Set a joint motor until changed: POSITION_/VELOCITY_CONTROL drive to targets with at
    /// most force; TORQUE_CONTROL applies force.
    #[tool(input_schema = schema_for_type::<params::MotorControl>())]
    async fn set_joint_motor_control(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("set_joint_motor_control", args, decide_motor).await
    }

    /// set_joint_motor_control for several joints in one change; lists in joint order.
    #[tool(input_schema = schema_for_type::<params::MotorControlArray>())]
    async fn set_joint_motor_control_array(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("set_joint_motor_control_array", args, decide_motor_array).await
    }

    /// Joints follow a cubic path through timed waypoints as the sim steps (docs/tools.md).
    #[tool(input_schema = schema_for_type::<params::JointTrajectory>())]
    async fn set_joint_trajectory(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("set_joint_trajectory", args, decide_trajectory).await
    }

    /// IK to the end effector's link frame; see docs/tools.md.
    #[tool(input_schema = schema_for_type::<params::InverseKinematics>(), annotations(read_only_hint = true))]
    async fn calculate_inverse_kinematics(&self, args: JsonObject) -> Result<Json<IkSolution>, String> {
        self.read("calculate_inverse_kinematics", args, |sim, p| {
            reads::inverse_kinematics(&sim.read_context(), &p)
        })
        .await
    }

    /// Write a 2-link revolute URDF; see docs/tools.md.
    #[tool(input_schema = schema_for_type::<params::GenerateRevolute>())]
    async fn generate_revolute_joint(&self, args: JsonObject) -> Result<Json<GeneratedUrdf>, String> {
        let reg = self.reg.clone();
        let p: GenerateRevolute = params::parse("generate_revolute_joint", &args)?;
        tokio::task::spawn_blocking(move || crate::files::urdf::generate_revolute_joint(reg.sandbox(), &p))
            .await
            .map_err(|_| "Internal error: nothing was written".to_string())?
            .map(Json)
    }
}
