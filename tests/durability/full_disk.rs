//! Full disk: the server runs under a file-size limit (RLIMIT_FSIZE, lowered from
//! outside with prlimit(2) as `prlimit --pid` would) until its log cannot grow. A
//! state-changing call that cannot be written is refused with a clear sentence and leaves
//! memory and log agreeing (the next read shows the previous state); reads keep working; the
//! process survives (it ignores SIGXFSZ); when the limit is lifted calls succeed again, and a
//! kill -9 restart comes back at the last acknowledged state.

use crate::common;

use common::Server;
use serde_json::json;

/// Sets the soft RLIMIT_FSIZE of process `pid` (the hard limit stays, so it can be raised
/// again without privileges).
fn set_file_size_limit(pid: u32, bytes: Option<u64>) {
    let mut old = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
    // SAFETY: reads the limit into `old`; no other memory is touched.
    let got = unsafe { libc::prlimit(pid as libc::pid_t, libc::RLIMIT_FSIZE, std::ptr::null(), &mut old) };
    assert_eq!(got, 0, "prlimit get: {}", std::io::Error::last_os_error());
    let new = libc::rlimit { rlim_cur: bytes.unwrap_or(old.rlim_max), rlim_max: old.rlim_max };
    // SAFETY: sets the limit from `new`; no other memory is touched.
    let set = unsafe { libc::prlimit(pid as libc::pid_t, libc::RLIMIT_FSIZE, &new, std::ptr::null_mut()) };
    assert_eq!(set, 0, "prlimit set: {}", std::io::Error::last_os_error());
}

/// The largest file in the data directory (the log or its WAL).
fn largest_data_file(server: &Server) -> u64 {
    std::fs::read_dir(&server.data).unwrap().filter_map(|e| e.ok()?.metadata().ok()).map(|m| m.len()).max().unwrap_or(0)
}

#[tokio::test(flavor = "multi_thread")]
async fn a_full_disk_refuses_changes_keeps_reads_and_recovers() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    c.call("add_box", json!({"sim_id": sim, "position": [0, 0, 1], "dimensions": [0.1, 0.1, 0.1]})).await;
    c.step(&sim, 10).await;

    set_file_size_limit(server.pid(), Some(largest_data_file(&server) + 256 * 1024));
    let (mut acked_hash, mut acked_head) = (c.hash(&sim).await, 0u64);
    let mut refusal = None;
    for i in 0..20_000 {
        let r = c.try_call("add_box", json!({"sim_id": sim, "position": [0, (i % 50) as f64 * 0.3, 2], "dimensions": [0.1, 0.1, 0.1]})).await;
        match r {
            Ok(_) => {
                let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
                acked_hash = info["state_hash"].as_str().unwrap().to_string();
                acked_head = info["head_seq"].as_u64().unwrap();
            }
            Err(why) => {
                refusal = Some(why);
                break;
            }
        }
    }
    let why = refusal.expect("a call was refused once the log could not grow");
    eprintln!("refused after head {acked_head}: {why}");
    assert!(why.contains("could not be recorded"), "a clear sentence: {why}");
    assert!(!why.contains('\n') && why.len() < 400, "one sentence: {why}");

    // Memory and log agree with the last acknowledged call; reads keep working.
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    assert_eq!(info["state_hash"], acked_hash.as_str(), "the refused call changed nothing");
    assert_eq!(info["head_seq"], acked_head);
    c.call("get_object_state", json!({"sim_id": sim, "object_id": 1})).await;
    let refused_again = c.try_call("step_simulation", json!({"sim_id": sim, "steps": 5})).await;
    assert!(refused_again.is_err(), "still full: {refused_again:?}");
    assert_eq!(c.hash(&sim).await, acked_hash);

    // Space returns: calls succeed again, and the log is whole.
    set_file_size_limit(server.pid(), None);
    c.step(&sim, 5).await;
    let after = c.hash(&sim).await;
    assert_ne!(after, acked_hash);
    let v = c.call("verify_simulation", json!({"sim_id": sim})).await;
    assert_eq!(v["ok"], true, "{v}");

    // kill -9 and restart: the last acknowledged state, verified.
    let (data_dir, base) = (server.data.clone(), dir.path().to_path_buf());
    drop(c);
    server.kill();
    assert!(data_dir.exists());
    let again = Server::start(&base, &[]);
    let c = again.client().await;
    assert_eq!(c.hash(&sim).await, after, "nothing acknowledged was lost");
}
