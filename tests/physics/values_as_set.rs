//! A value the user set reads back as set — `change_dynamics(mass=3.5)` read
//! `3.4999998` (rapier keeps 1/m) — and time is PyBullet's f64 `n × dt`
//! (`0.004166666666666667` after one default step, not `0.004166666883975267`).

use crate::common;

use common::Server;
use serde_json::json;

#[tokio::test(flavor = "multi_thread")]
async fn every_settable_value_reads_back_as_set() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let color = [0.1, 0.7, 0.3, 0.9];
    for (tool, extra) in [
        ("add_box", json!({"dimensions": [0.1, 0.7, 3.5]})),
        ("add_sphere", json!({"radius": 0.7})),
        ("add_cylinder", json!({"radius": 0.1, "height": 0.7})),
        ("add_capsule", json!({"radius": 0.1, "height": 3.5})),
    ] {
        let mut args = json!({"sim_id": sim, "position": [0, 0, 5], "mass": 3.5, "color": color});
        args.as_object_mut().unwrap().extend(extra.as_object().unwrap().clone());
        c.call(tool, args).await;
    }
    let robot = c.call("load_urdf", json!({"sim_id": sim, "file_path": "iiwa14.urdf", "position": [2, 0, 0]})).await;
    let robot = robot["object_id"].as_u64().unwrap();
    let set = json!({"mass": 3.5, "lateral_friction": 0.7, "restitution": 0.1, "linear_damping": 0.1,
                     "angular_damping": 0.7, "rolling_friction": 0.1, "spinning_friction": 0.7,
                     "contact_stiffness": 3.5, "contact_damping": 0.1});
    for (object_id, link_index) in [(0, -1), (1, -1), (2, -1), (3, -1), (robot, -1), (robot, 2), (robot, 6)] {
        let mut args = set.clone();
        args.as_object_mut().unwrap().extend(
            json!({"sim_id": sim, "object_id": object_id, "link_index": link_index}).as_object().unwrap().clone(),
        );
        c.call("change_dynamics", args).await;
        let info = c.call("get_dynamics_info", json!({"sim_id": sim, "object_id": object_id, "link_index": link_index})).await;
        for (k, v) in set.as_object().unwrap() {
            assert_eq!(&info[k], v, "{k} of object {object_id} link {link_index}: {info}");
        }
    }
    // A robot link's mass from the URDF reads as written (iiwa link 3, link_4: 2.7 kg).
    let link = c.call("get_dynamics_info", json!({"sim_id": sim, "object_id": robot, "link_index": 3})).await;
    assert_eq!(link["mass"], json!(2.7));
    // Dimensions and colours as given, in the simulation summary and the saved file.
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    let dims: Vec<_> = info["objects"].as_array().unwrap()[..4].iter().map(|o| o["dimensions"].clone()).collect();
    assert_eq!(dims, [json!([0.1, 0.7, 3.5]), json!([0.7]), json!([0.1, 0.7]), json!([0.1, 3.5])]);
    c.call("save_simulation", json!({"sim_id": sim, "file_path": "values.json"})).await;
    let saved: serde_json::Value =
        serde_json::from_slice(&std::fs::read(server.workspace.join("values.json")).unwrap()).unwrap();
    for o in &saved["objects"].as_array().unwrap()[..4] {
        assert_eq!(o["color"], json!(color));
        assert_eq!(o["mass"], json!(3.5));
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn time_is_steps_times_the_timestep_as_given() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.call("add_sphere", json!({"sim_id": sim, "radius": 0.1, "position": [0, 0, 1]})).await;
    let one = c.step(&sim, 1).await;
    assert_eq!(one["current_time"], json!(0.004166666666666667));
    let n = 1 + 239;
    let t = c.step(&sim, 239).await["current_time"].as_f64().unwrap();
    assert_eq!(t, n as f64 * (1.0 / 240.0));
    let set = c.call("set_timestep", json!({"sim_id": sim, "timestep": 0.01})).await;
    assert_eq!(set["timestep"], json!(0.01));
    let m = 37;
    let t2 = c.step(&sim, m).await["current_time"].as_f64().unwrap();
    assert_eq!(t2, n as f64 * (1.0 / 240.0) + m as f64 * 0.01);
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    assert_eq!((info["timestep"].as_f64(), info["current_time"].as_f64()), (Some(0.01), Some(t2)));
    let listed = c.call("list_simulations", json!({})).await;
    assert_eq!(listed["simulations"][0]["simulation_time"].as_f64(), Some(t2));
    // Undo reports the time it went back to, the same way.
    let undone = c.call("undo", json!({"sim_id": sim, "count": 2})).await;
    assert_eq!(undone["current_time"].as_f64(), Some(n as f64 * (1.0 / 240.0)));
    // A timestep with no exact f32 (1/3 s) still counts in the f64 given.
    c.call("redo", json!({"sim_id": sim, "count": 2})).await;
    c.call("set_timestep", json!({"sim_id": sim, "timestep": 1.0 / 3.0})).await;
    let t3 = c.step(&sim, 3).await["current_time"].as_f64().unwrap();
    assert_eq!(t3, t2 + 3.0 * (1.0 / 3.0));
    // Restart: the same reported time from the log.
    drop(c);
    server.kill();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    assert_eq!(info["current_time"].as_f64(), Some(t3));
    let v = c.call("verify_simulation", json!({"sim_id": sim})).await;
    assert_eq!(v["ok"], true);
}
