//! Forking a fork at an inherited seq said "log is corrupt: no snapshot on
//! the head's chain" (a fork copied its parent's events but only its own root's snapshot).
//! Any state-changing event of a fork's ancestry — inherited, on an undone branch, several forks
//! deep — forks to exactly the parent's recorded state, after a kill -9 restart too and after
//! save → load on a server with another MAC key, and the fork then goes on bit for bit.

use crate::common;

use common::{Client, Server};
use serde_json::{json, Value};

/// Seq → recorded state hash of every state-changing event in `sim`'s log.
async fn recorded(c: &Client, sim: &str) -> Vec<(u64, String, bool)> {
    let h = c.call("get_history", json!({"sim_id": sim, "limit": 1000, "detail": "full"})).await;
    h["events"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e["kind"] == "root" || e["kind"] == "change")
        .map(|e| (e["seq"].as_u64().unwrap(), e["state_hash"].as_str().unwrap().to_string(), e["inherited"] == true))
        .collect()
}

fn hash_at(events: &[(u64, String, bool)], seq: u64) -> String {
    events.iter().find(|e| e.0 == seq).unwrap_or_else(|| panic!("no event {seq}")).1.clone()
}

/// Forks `sim` at `seq`, checks the fork's hash against `expected`, then adds a sphere and
/// steps 40 times, and returns the fork's id and final hash (what "goes on" must reproduce).
async fn fork_and_go_on(c: &Client, sim: &str, seq: u64, expected: &str) -> (String, String) {
    let f = c.call("fork_simulation", json!({"sim_id": sim, "at_seq": seq})).await;
    assert_eq!(f["state_hash"], expected, "fork of {sim} at {seq}");
    let id = f["simulation_id"].as_str().unwrap().to_string();
    assert_eq!(c.hash(&id).await, expected);
    c.call("add_sphere", json!({"sim_id": id, "radius": 0.05, "position": [0.05, 0, 0.5]})).await;
    c.step(&id, 40).await;
    let v = c.call("verify_simulation", json!({"sim_id": id})).await;
    assert_eq!(v["ok"], true, "{v}");
    let hash = c.hash(&id).await;
    (id, hash)
}

/// Six state-changing calls after create: their seqs, in order.
async fn six_calls(c: &Client, sim: &str) -> Vec<u64> {
    let mut seqs = Vec::new();
    let calls = [
        ("add_box", json!({"sim_id": sim, "dimensions": [5, 5, 0.5], "position": [0, 0, -0.5], "mass": 0})),
        ("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})),
        ("step_simulation", json!({"sim_id": sim, "steps": 100})),
        ("add_sphere", json!({"sim_id": sim, "radius": 0.1, "position": [0.5, 0, 1]})),
        ("apply_force", json!({"sim_id": sim, "object_id": 1, "force": [0, 40, 0]})),
        ("step_simulation", json!({"sim_id": sim, "steps": 100})),
    ];
    for (tool, args) in calls {
        c.call(tool, args).await;
        let h = c.call("get_simulation_info", json!({"sim_id": sim})).await;
        seqs.push(h["head_seq"].as_u64().unwrap());
    }
    seqs
}

#[tokio::test(flavor = "multi_thread")]
async fn forks_of_forks_at_inherited_and_undone_seqs() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let a = c.new_sim(json!({})).await;
    let seqs = six_calls(&c, &a).await;
    // An undone branch: undo the last two, then a different change.
    c.call("undo", json!({"sim_id": a, "count": 2})).await;
    c.call("add_capsule", json!({"sim_id": a, "radius": 0.1, "height": 0.2, "position": [0, 1, 1]})).await;
    let a_events = recorded(&c, &a).await;

    // Fork at the 4th call, then fork that fork at the 2nd (inherited) call.
    let f1 = c.call("fork_simulation", json!({"sim_id": a, "at_seq": seqs[3]})).await;
    let f1 = f1["simulation_id"].as_str().unwrap().to_string();
    c.step(&f1, 20).await;
    let (f2, f2_end) = fork_and_go_on(&c, &f1, seqs[1], &hash_at(&a_events, seqs[1])).await;
    // The same fork made from the original gives the same continuation, bit for bit.
    let (_, direct_end) = fork_and_go_on(&c, &a, seqs[1], &hash_at(&a_events, seqs[1])).await;
    assert_eq!(f2_end, direct_end);
    // At an undone-branch seq of the original (the last step, undone above).
    let (_, undone_end) = fork_and_go_on(&c, &a, seqs[5], &hash_at(&a_events, seqs[5])).await;
    // A fork of a fork of a fork, at the oldest inherited change and at the first step.
    let f3 = c.call("fork_simulation", json!({"sim_id": f2, "at_seq": seqs[0]})).await;
    let f3 = f3["simulation_id"].as_str().unwrap().to_string();
    let (_, f4_end) = fork_and_go_on(&c, &f3, seqs[0], &hash_at(&a_events, seqs[0])).await;
    let (f4b, f4b_end) = fork_and_go_on(&c, &f1, seqs[2], &hash_at(&a_events, seqs[2])).await;

    // After kill -9: the same forks, from the recovered logs.
    drop(c);
    server.kill();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    assert_eq!(fork_and_go_on(&c, &f1, seqs[1], &hash_at(&a_events, seqs[1])).await.1, f2_end);
    assert_eq!(fork_and_go_on(&c, &a, seqs[5], &hash_at(&a_events, seqs[5])).await.1, undone_end);
    assert_eq!(fork_and_go_on(&c, &f3, seqs[0], &hash_at(&a_events, seqs[0])).await.1, f4_end);
    assert_eq!(fork_and_go_on(&c, &f4b, seqs[2], &hash_at(&a_events, seqs[2])).await.1, f4b_end);

    // After save → load on another server (another MAC key): the loaded simulation's
    // inherited chain forks the same way.
    c.call("save_simulation", json!({"sim_id": f4b, "file_path": "f4b.json"})).await;
    let other_dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(other_dir.path().join("workspace")).unwrap();
    std::fs::copy(server.workspace.join("f4b.json"), other_dir.path().join("workspace/f4b.json")).unwrap();
    let other = Server::start(other_dir.path(), &[]);
    let o = other.client().await;
    let loaded = o.call("load_simulation", json!({"file_path": "f4b.json"})).await;
    let l = loaded["simulation_id"].as_str().unwrap().to_string();
    assert_eq!(fork_and_go_on(&o, &l, seqs[1], &hash_at(&a_events, seqs[1])).await.1, f2_end);
    assert_eq!(fork_and_go_on(&o, &l, seqs[2], &hash_at(&a_events, seqs[2])).await.1, f4b_end);
    let (l2, _) = fork_and_go_on(&o, &l, seqs[0], &hash_at(&a_events, seqs[0])).await;
    // …and a fork of that fork, at an event it inherited through the loaded file.
    assert_eq!(fork_and_go_on(&o, &l2, seqs[0], &hash_at(&a_events, seqs[0])).await.1, f4_end);
    let listed: Value = o.call("list_simulations", json!({})).await;
    assert_eq!(listed["simulations"].as_array().unwrap().len(), 5);
}
