//! Process-level determinism and durability: two server
//! processes agree hash for hash; a kill -9'd server restarts with every simulation exactly as
//! it was and continues like a twin that never stopped; the state hash covers what docs/log-format.md lists;
//! stdio works; the data directory is exclusively locked; --token is enforced; ending a session
//! answers 204.

use crate::common;

use common::{Client, Server};
use rmcp::model::CallToolRequestParams;
use rmcp::transport::streamable_http_client::StreamableHttpClientTransportConfig;
use rmcp::transport::{ConfigureCommandExt, StreamableHttpClientTransport, TokioChildProcess};
use rmcp::ServiceExt;
use serde_json::{json, Value};

/// A session script: every kind of state-changing call, returning the hash after each.
#[allow(clippy::approx_constant)] // 0.7071: a client's rounded quaternion, sent as a client would
async fn script(c: &Client, sim: &str) -> Vec<String> {
    let calls: Vec<(&str, Value)> = vec![
        ("add_box", json!({"dimensions": [5, 5, 0.5], "position": [0, 0, -0.5], "mass": 0})),
        ("add_box", json!({"dimensions": [0.2, 0.2, 0.2], "position": [0, 0, 1], "color": [1, 0, 0]})),
        ("add_sphere", json!({"radius": 0.2, "position": [0.1, 0, 2]})),
        ("add_cylinder", json!({"radius": 0.1, "height": 0.4, "position": [-0.3, 0, 1.5], "orientation": [0.3, 0, 0, 1]})),
        ("add_capsule", json!({"radius": 0.1, "height": 0.3, "position": [0.3, 0.2, 2.5]})),
        ("step_simulation", json!({"steps": 100})),
        ("apply_force", json!({"object_id": 1, "force": [50, 0, 100], "position": [0, 0.1, 1]})),
        ("apply_torque", json!({"object_id": 2, "torque": [0, 0, 5]})),
        ("step_simulation", json!({"steps": 37})),
        ("change_dynamics", json!({"object_id": 3, "mass": 4, "lateral_friction": 0.9, "restitution": 0.5})),
        ("set_object_velocity", json!({"object_id": 4, "linear_velocity": [1, 0, 3], "angular_velocity": [0, 2, 0]})),
        ("set_timestep", json!({"timestep": 0.002})),
        ("step_simulation", json!({"steps": 250})),
        ("set_object_pose", json!({"object_id": 2, "position": [1, 1, 1], "orientation": [0, 0, 0.7071, 0.7071]})),
        ("remove_object", json!({"object_id": 4})),
        ("step_simulation", json!({"steps": 500})),
    ];
    let mut hashes = Vec::new();
    for (tool, mut args) in calls {
        args["sim_id"] = json!(sim);
        c.call(tool, args).await;
        hashes.push(c.hash(sim).await);
    }
    hashes
}

#[tokio::test(flavor = "multi_thread")]
async fn the_same_calls_in_two_processes_give_identical_state_hashes() {
    let (d1, d2) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let (s1, s2) = (Server::start(d1.path(), &[]), Server::start(d2.path(), &[]));
    let (c1, c2) = (s1.client().await, s2.client().await);
    let (a, b) = (c1.new_sim(json!({})).await, c2.new_sim(json!({})).await);
    assert_ne!(a, b, "simulation ids are fresh UUIDs");
    assert_eq!(c1.hash(&a).await, c2.hash(&b).await, "the id must not be hashed");
    let (ha, hb) = (script(&c1, &a).await, script(&c2, &b).await);
    assert_eq!(ha, hb);
    let distinct: std::collections::BTreeSet<_> = ha.iter().collect();
    assert_eq!(distinct.len(), ha.len(), "every call changed the state");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_killed_server_restarts_with_every_simulation_and_continues_like_a_twin() {
    let dir = tempfile::tempdir().unwrap();
    let twin_dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let twin_server = Server::start(twin_dir.path(), &[]);
    let (c, twin) = (server.client().await, twin_server.client().await);
    let (sims, twins) = (
        vec![c.new_sim(json!({})).await, c.new_sim(json!({"gravity": -3.0})).await],
        vec![twin.new_sim(json!({})).await, twin.new_sim(json!({"gravity": -3.0})).await],
    );
    for (s, t) in sims.iter().zip(&twins) {
        script(&c, s).await;
        script(&twin, t).await;
    }
    // Enough events to cross a snapshot, then a few more after it.
    for _ in 0..70 {
        c.call("apply_force", json!({"sim_id": sims[0], "object_id": 1, "force": [0, 1, 0]})).await;
        c.step(&sims[0], 3).await;
        twin.call("apply_force", json!({"sim_id": twins[0], "object_id": 1, "force": [0, 1, 0]})).await;
        twin.step(&twins[0], 3).await;
    }
    let before: Vec<String> = futures_hashes(&c, &sims).await;
    let data = server.data.clone();
    server.kill();

    let server = Server::start(dir.path().join("..").join(dir.path().file_name().unwrap()).as_path(), &[]);
    assert_eq!(server.data.canonicalize().unwrap(), data.canonicalize().unwrap());
    // The old session is gone: the client must re-initialize.
    let stale = c
        .service
        .call_tool(CallToolRequestParams::new("list_simulations").with_arguments(Default::default()))
        .await;
    assert!(stale.is_err() || stale.unwrap().is_error == Some(true), "old session still served");
    let c = server.client().await;
    let listed = c.call("list_simulations", json!({})).await;
    let mut ids: Vec<String> = listed["simulations"].as_array().unwrap().iter()
        .map(|s| s["simulation_id"].as_str().unwrap().to_string()).collect();
    ids.sort();
    let mut expected = sims.clone();
    expected.sort();
    assert_eq!(ids, expected, "same simulation ids after restart");
    assert_eq!(futures_hashes(&c, &sims).await, before, "same state hashes after restart");
    for (s, t) in sims.iter().zip(&twins) {
        c.call("apply_torque", json!({"sim_id": s, "object_id": 1, "torque": [0, 0, 2]})).await;
        c.step(s, 300).await;
        twin.call("apply_torque", json!({"sim_id": t, "object_id": 1, "torque": [0, 0, 2]})).await;
        twin.step(t, 300).await;
        assert_eq!(c.hash(s).await, twin.hash(t).await, "restarted sim diverged from its twin");
        assert_eq!(c.state(s, 1).await, twin.state(t, 1).await);
    }
}

async fn futures_hashes(c: &Client, sims: &[String]) -> Vec<String> {
    let mut out = Vec::new();
    for s in sims {
        out.push(c.hash(s).await);
    }
    out
}

#[tokio::test(flavor = "multi_thread")]
async fn the_state_hash_covers_each_item_spec_lists() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    // A base scene; each probe forks it by replaying the same calls into a fresh sim, then
    // changes one item, and must see a different hash than the untouched base.
    async fn base(c: &Client, gravity: Value, color: Value) -> String {
        let s = c.new_sim(json!({"gravity": gravity})).await;
        c.call("add_box", json!({"sim_id": s, "dimensions": [1, 1, 0.1], "position": [0, 0, -0.1], "mass": 0})).await;
        c.call("add_box", json!({"sim_id": s, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 0.1], "color": color})).await;
        s
    }
    let g = json!([0, 0, -9.81]);
    let red = json!([1, 0, 0, 1]);
    let reference = base(&c, g.clone(), red.clone()).await;
    let h0 = c.hash(&reference).await;
    let probes: Vec<(&str, &str, Value)> = vec![
        ("pose", "set_object_pose", json!({"object_id": 1, "position": [0, 0, 0.2]})),
        ("orientation", "set_object_pose", json!({"object_id": 1, "position": [0, 0, 0.1], "orientation": [0, 0, 0.1, 1]})),
        ("linear velocity", "set_object_velocity", json!({"object_id": 1, "linear_velocity": [0, 0, 1e-3]})),
        ("angular velocity", "set_object_velocity", json!({"object_id": 1, "angular_velocity": [0, 0, 1e-3]})),
        ("mass properties", "change_dynamics", json!({"object_id": 1, "mass": 1.5})),
        ("body type", "change_dynamics", json!({"object_id": 1, "mass": 0})),
        ("friction", "change_dynamics", json!({"object_id": 1, "lateral_friction": 0.7})),
        ("restitution", "change_dynamics", json!({"object_id": 1, "restitution": 0.1})),
        ("rolling friction", "change_dynamics", json!({"object_id": 1, "rolling_friction": 0.1})),
        ("spinning friction", "change_dynamics", json!({"object_id": 1, "spinning_friction": 0.1})),
        ("contact stiffness", "change_dynamics", json!({"object_id": 1, "contact_stiffness": 1000})),
        ("contact damping", "change_dynamics", json!({"object_id": 1, "contact_damping": 10})),
        ("linear damping", "change_dynamics", json!({"object_id": 1, "linear_damping": 0.5})),
        ("angular damping", "change_dynamics", json!({"object_id": 1, "angular_damping": 0.5})),
        ("pending force", "apply_force", json!({"object_id": 1, "force": [0, 0, 1]})),
        ("pending torque", "apply_torque", json!({"object_id": 1, "torque": [0, 0, 1]})),
        ("timestep", "set_timestep", json!({"timestep": 0.01})),
        ("time and step count", "step_simulation", json!({"steps": 1})),
        ("objects", "remove_object", json!({"object_id": 1})),
        ("constraints", "create_constraint", json!({"parent_id": 1, "child_id": -1, "joint_type": "fixed"})),
        ("viewer camera", "set_camera", json!({"distance": 4, "yaw": 10, "pitch": -20, "target": [0, 0, 0]})),
        ("viewer contacts", "enable_debug_visualization", json!({"show_contacts": false})),
        ("viewer frames", "enable_debug_visualization", json!({"show_frames": true})),
    ];
    for (item, tool, mut args) in probes {
        let s = base(&c, g.clone(), red.clone()).await;
        assert_eq!(c.hash(&s).await, h0, "identical scenes must hash alike");
        args["sim_id"] = json!(s);
        c.call(tool, args).await;
        assert_ne!(c.hash(&s).await, h0, "changing {item} did not change the state hash");
        c.call("destroy_simulation", json!({"sim_id": s})).await;
    }
    // Items set at creation: gravity, color.
    let s = base(&c, json!([0, 0, -9.8]), red.clone()).await;
    assert_ne!(c.hash(&s).await, h0, "gravity is not hashed");
    let s = base(&c, g.clone(), json!([0, 1, 0, 1])).await;
    assert_ne!(c.hash(&s).await, h0, "color is not hashed");
    // The id counter: add then remove leaves the same objects but a later next id.
    let s = base(&c, g.clone(), red.clone()).await;
    let extra = c.call("add_sphere", json!({"sim_id": s, "radius": 0.1, "position": [3, 3, 3]})).await;
    c.call("remove_object", json!({"sim_id": s, "object_id": extra["object_id"]})).await;
    assert_ne!(c.hash(&s).await, h0, "the object id counter is not hashed");
    // The constraint id counter likewise.
    let s = base(&c, g.clone(), red.clone()).await;
    let k = c.call("create_constraint", json!({"sim_id": s, "parent_id": 1, "child_id": -1, "joint_type": "spherical"})).await;
    c.call("remove_constraint", json!({"sim_id": s, "constraint_id": k["constraint_id"]})).await;
    assert_ne!(c.hash(&s).await, h0, "the constraint id counter is not hashed");
}

#[tokio::test(flavor = "multi_thread")]
async fn stdio_serves_the_same_tools() {
    let dir = tempfile::tempdir().unwrap();
    let (data, ws) = (dir.path().join("data"), dir.path().join("ws"));
    let transport = TokioChildProcess::new(
        tokio::process::Command::new(env!("CARGO_BIN_EXE_physics-mcp")).configure(|cmd| {
            cmd.arg("stdio").arg("--data").arg(&data).arg("--workspace").arg(&ws);
        }),
    )
    .unwrap();
    let client = ().serve(transport).await.expect("stdio initialize");
    let tools = client.list_all_tools().await.unwrap();
    assert!(tools.len() >= 18, "{} tools", tools.len());
    let call = |name: &'static str, args: Value| {
        let client = &client;
        async move {
            let r = client
                .call_tool(CallToolRequestParams::new(name).with_arguments(args.as_object().unwrap().clone()))
                .await
                .unwrap();
            assert_ne!(r.is_error, Some(true), "{name}: {:?}", r.content);
            r.structured_content.unwrap()
        }
    };
    let sim = call("create_simulation", json!({})).await["simulation_id"].as_str().unwrap().to_string();
    call("add_sphere", json!({"sim_id": sim, "radius": 0.5, "position": [0, 0, 10]})).await;
    call("step_simulation", json!({"sim_id": sim, "steps": 240})).await;
    let z = call("get_object_state", json!({"sim_id": sim, "object_id": 0})).await["position"][2].as_f64().unwrap();
    assert!(z < 10.0 - 4.0 && z > 10.0 - 5.5, "fell to {z}");
    client.cancel().await.unwrap();
}

#[tokio::test(flavor = "multi_thread")]
async fn the_data_directory_is_exclusively_locked_and_unsafe_directories_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let _first = Server::start(dir.path(), &[]);
    let data = dir.path().join("data");
    let (ok, err) = Server::start_failure(&[
        "serve", "--bind", "127.0.0.1:0", "--data", data.to_str().unwrap(),
        "--workspace", dir.path().join("w2").to_str().unwrap(),
    ]);
    assert!(!ok && err.contains("another physics-mcp process"), "{err}");
    let (ok, err) = Server::start_failure(&["stdio", "--data", "/", "--workspace", dir.path().to_str().unwrap()]);
    assert!(!ok && err.contains("--data resolves to /"), "{err}");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_token_is_required_when_set() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--token", "s3cret"]);
    let anonymous = ().serve(StreamableHttpClientTransport::from_uri(server.url.clone())).await;
    assert!(anonymous.is_err(), "initialized without the token");
    let cfg = StreamableHttpClientTransportConfig::with_uri(server.url.clone()).auth_header("s3cret");
    let client = ().serve(StreamableHttpClientTransport::from_config(cfg)).await.expect("with token");
    let r = client
        .call_tool(CallToolRequestParams::new("list_simulations").with_arguments(Default::default()))
        .await
        .unwrap();
    assert_ne!(r.is_error, Some(true));
}

/// The Python `mcp` SDK logs `Session termination failed: 202` unless `DELETE /mcp` answers
/// 200 or 204.
#[tokio::test(flavor = "multi_thread")]
async fn ending_a_session_answers_204_no_content() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let http = reqwest::Client::new();
    let session = common::raw_session(&http, &server.url, "2025-11-25").await.expect("initialize");
    let end = |session: Option<String>| {
        let mut request = http.delete(&server.url).header("MCP-Protocol-Version", "2025-11-25");
        if let Some(s) = session {
            request = request.header("mcp-session-id", s);
        }
        async move { request.send().await.expect("DELETE").status().as_u16() }
    };
    assert_eq!(end(Some(session)).await, 204);
    // An error is left as rmcp answers it.
    assert_eq!(end(None).await, 400);
}

#[tokio::test(flavor = "multi_thread")]
async fn a_tampered_log_is_reported_and_skipped_not_served() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let good = c.new_sim(json!({})).await;
    let bad = c.new_sim(json!({})).await;
    for s in [&good, &bad] {
        c.call("add_sphere", json!({"sim_id": s, "radius": 0.1, "position": [0, 0, 1]})).await;
        c.step(s, 10).await;
    }
    let data = server.data.clone();
    server.kill();
    // Rewrite history: the last step now claims a different outcome.
    let conn = rusqlite::Connection::open(data.join(format!("{bad}.sqlite"))).unwrap();
    conn.execute(
        "UPDATE events SET command = replace(command, '\"steps\":10', '\"steps\":11') WHERE tool = 'step_simulation'",
        [],
    )
    .unwrap();
    drop(conn);
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let listed = c.call("list_simulations", json!({})).await;
    let ids: Vec<&str> = listed["simulations"].as_array().unwrap().iter().map(|s| s["simulation_id"].as_str().unwrap()).collect();
    assert_eq!(ids, vec![good.as_str()], "the tampered simulation must not be served");
    let e = c.try_call("get_simulation_info", json!({"sim_id": bad})).await.unwrap_err();
    // named damaged (it used to answer "not found"), with the event that diverged.
    assert!(e.starts_with(&format!("Simulation {bad} is damaged: ")) && e.contains("seq"), "{e}");
    let damaged = &listed["damaged"][0];
    assert_eq!(damaged["simulation_id"], json!(bad));
    assert!(data.join(format!("{bad}.sqlite")).exists(), "the tampered file is left for inspection");
}
