//! Robot tools: load_urdf, joints, motors, inverse kinematics, generate_revolute_joint.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};

use crate::params::lenient::NonNegative;
use crate::params::{self, GenerateRevolute, LoadUrdf, MotorControl};
use crate::mcp::PhysicsServer;
use crate::command::{Command, ControlMode, MotorSpec};
use crate::outputs::{GeneratedUrdf, IkSolution, JointInfo, JointState, Message, NumJoints, UrdfLoaded};
use crate::sim::reads;
use crate::value::Refusal;

pub(super) fn decide_motor(p: MotorControl) -> Result<Command, Refusal> {
    let object_id = p.object_id.0;
    let joint_index = p.joint_index.get();
    let joint_index = u32::try_from(joint_index)
        .map_err(|_| format!("Joint index {joint_index} out of range: object {object_id} has no such joint"))?;
    let mode = match p.control_mode.0.as_str() {
        "POSITION_CONTROL" => ControlMode::PositionControl,
        "VELOCITY_CONTROL" => ControlMode::VelocityControl,
        "TORQUE_CONTROL" => ControlMode::TorqueControl,
        other => {
            return Err(format!(
                "control_mode must be POSITION_CONTROL, VELOCITY_CONTROL or TORQUE_CONTROL; got {other}"
            ))
        }
    };
    let force = p.force.map(|f| f.0);
    let target_position = match (mode, p.target_position) {
        (ControlMode::PositionControl, None) => {
            return Err("target_position is required for POSITION_CONTROL".into())
        }
        (_, t) => t.map_or(0.0, |t| t.0),
    };
    if mode == ControlMode::TorqueControl && force.is_none() {
        return Err("force is required for TORQUE_CONTROL (it is the torque applied each step)".into());
    }
    let gain = |g: Option<NonNegative>, default: f32| g.map_or(default, |g| g.0);
    Ok(Command::SetJointMotor {
        object_id,
        joint_index,
        motor: MotorSpec {
            mode,
            target_position,
            target_velocity: p.target_velocity.map_or(0.0, |v| v.0),
            force,
            position_gain: gain(p.position_gain, 0.1),
            velocity_gain: gain(p.velocity_gain, 1.0),
        },
    })
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

    /// Set a joint motor until changed: POSITION_/VELOCITY_CONTROL drive to the targets with at
    /// most force; TORQUE_CONTROL applies force.
    #[tool(input_schema = schema_for_type::<params::MotorControl>())]
    async fn set_joint_motor_control(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("set_joint_motor_control", args, decide_motor).await
    }

    /// Joint positions (per movable joint) reaching the target within limits.
    #[tool(input_schema = schema_for_type::<params::InverseKinematics>(), annotations(read_only_hint = true))]
    async fn calculate_inverse_kinematics(&self, args: JsonObject) -> Result<Json<IkSolution>, String> {
        self.read("calculate_inverse_kinematics", args, |sim, p| {
            reads::inverse_kinematics(&sim.read_context(), &p)
        })
        .await
    }

    /// Write a two-link revolute URDF for load_urdf.
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
