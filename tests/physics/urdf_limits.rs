//! A revolute or prismatic joint whose `<limit>` leaves out `lower` and/or `upper`.
//! PyBullet 3.2.7 reads each attribute on its own (a missing lower is 0, a missing upper −1)
//! and enforces the pair only when lower ≤ upper; we used to read a missing one as 0 and lock
//! the joint at [0, 0]. The reference is pybullet's own (`scripts/urdf_joint_limits.py` wrote
//! `tests/fixtures/pybullet_joint_limits.json`); old load_urdf events keep folding as before.

use crate::common;

use common::Server;
use serde_json::{json, Value};

fn reference() -> Value {
    serde_json::from_str(include_str!("../fixtures/pybullet_joint_limits.json")).expect("pybullet_joint_limits.json")
}

/// Reported limits and the motion a velocity motor gets, up and down, over MCP/HTTP, against
/// pybullet's: free joints run to about ±1, an upper-only limit stops the joint at [0, upper].
#[tokio::test(flavor = "multi_thread")]
async fn partial_limits_are_read_and_enforced_as_pybullet_does() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let r = reference();
    let joints = r["joints"].as_array().unwrap();
    for (direction, key) in [(1.0, "position_after_velocity_up"), (-1.0, "position_after_velocity_down")] {
        let sim = c.new_sim(json!({"gravity": r["gravity"]})).await;
        let load = json!({"sim_id": sim, "file_path": r["file"], "use_fixed_base": r["use_fixed_base"]});
        let id = c.call("load_urdf", load).await["object_id"].as_u64().unwrap();
        for wj in joints {
            let j = wj["joint_index"].as_u64().unwrap();
            let info = c.call("get_joint_info", json!({"sim_id": sim, "object_id": id, "joint_index": j})).await;
            assert_eq!(info["joint_name"], wj["joint_name"]);
            for field in ["lower_limit", "upper_limit", "max_force", "max_velocity"] {
                assert_eq!(info[field].as_f64(), wj[field].as_f64(), "{field}: ours {info}, pybullet {wj}");
            }
            let m = json!({"sim_id": sim, "object_id": id, "joint_index": j, "control_mode": r["control_mode"],
                           "target_velocity": direction, "force": r["force"]});
            c.call("set_joint_motor_control", m).await;
        }
        c.step(&sim, r["steps"].as_u64().unwrap()).await;
        for wj in joints {
            let j = wj["joint_index"].as_u64().unwrap();
            let s = c.call("get_joint_state", json!({"sim_id": sim, "object_id": id, "joint_index": j})).await;
            let (got, want) = (s["joint_position"].as_f64().unwrap(), wj[key].as_f64().unwrap());
            eprintln!("REPORT {} ({key}): ours {got}, pybullet {want}", wj["joint_name"]);
            assert!((got - want).abs() < 0.01, "{} {key}: ours {got}, pybullet {want}", wj["joint_name"]);
        }
    }
}

/// Compatibility (docs/log-format.md): a load_urdf event recorded before the flag decodes without it,
/// re-encodes byte for byte and folds to the robot it always did — a missing attribute read as
/// 0, so effort/velocity alone gives [0, 0] — so old logs' state hashes still match; the same
/// load as a new event reads PyBullet's limits and hashes differently.
#[test]
fn old_load_urdf_events_keep_their_limits() {
    use physics_mcp::command::{Blob, BlobSource, Command};
    struct Bytes(Vec<u8>);
    impl BlobSource for Bytes {
        fn blob(&self, _hash: &str) -> Option<Vec<u8>> {
            Some(self.0.clone())
        }
    }
    let text = include_bytes!("../fixtures/joint_limits.urdf").to_vec();
    let old_json = format!(
        r#"{{"op":"load_urdf","file_path":"joint_limits.urdf","urdf":"{}","meshes":{{}},"position":[0.0,0.0,0.0],"orientation":[0.0,0.0,0.0,1.0],"fixed_base":true,"continuous_limits_from_file":true}}"#,
        Blob::new(text.clone()).hash
    );
    let mut old: Command = serde_json::from_str(&old_json).unwrap();
    assert_eq!(serde_json::to_string(&old).unwrap(), old_json, "an old event re-encodes unchanged");
    old.hydrate(&Bytes(text)).unwrap();
    let mut new = old.clone();
    let Command::LoadUrdf { revolute_prismatic_limits_from_file, .. } = &mut new else { panic!("{new:?}") };
    assert!(!*revolute_prismatic_limits_from_file);
    *revolute_prismatic_limits_from_file = true;

    let (mut old_world, mut new_world) = (common::empty_world("old"), common::empty_world("new"));
    old_world.apply(&old, &mut |_| true);
    new_world.apply(&new, &mut |_| true);
    let limits = |w: &physics_mcp::world::World, j: usize| {
        let info = w.joint_info(0, j).unwrap();
        [info.lower_limit, info.upper_limit]
    };
    let old_limits: Vec<_> = (0..6).map(|j| limits(&old_world, j)).collect();
    let before = [[0.0, 0.0], [-0.5, 0.0], [0.0, 0.25], [0.0, 0.0], [-0.5, 0.0], [-0.38, 0.0]];
    assert_eq!(old_limits, before, "an old event folds as it always did");
    let r = reference();
    for (j, wj) in r["joints"].as_array().unwrap().iter().enumerate() {
        let want = [wj["lower_limit"].as_f64().unwrap(), wj["upper_limit"].as_f64().unwrap()];
        assert_eq!(limits(&new_world, j), want, "a new event, joint {j}");
    }
    assert_ne!(old_world.state_hash(), new_world.state_hash());
}
