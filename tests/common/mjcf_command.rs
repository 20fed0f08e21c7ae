//! load_mjcf's command as the server records it today (parent filter and actuators on, at the
//! origin, no keyframe), for the tests and the MJCF benchmark that drive a `World` directly (the bench
//! includes this file by path).

use physics_mcp::command::{Blob, Command};

/// load_mjcf of `bytes`, recorded as read from `file_path`.
pub fn load_mjcf(file_path: &str, bytes: &[u8], use_model_options: bool) -> Command {
    Command::LoadMjcf {
        file_path: file_path.into(),
        mjcf: Blob::new(bytes.to_vec()),
        meshes: Default::default(),
        position: [0.0; 3],
        orientation: [0.0, 0.0, 0.0, 1.0],
        fixed_base: false,
        keyframe: None,
        parent_filter: true,
        use_model_options,
        actuators: true,
        constraints: true,
        ball_joints_and_pairs: true,
        parsed: Default::default(),
    }
}
