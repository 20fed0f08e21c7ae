//! Corrupted files: a flipped state hash, random byte flips, a truncated file, a
//! deleted WAL and a swapped snapshot blob. The server still starts, serves every other
//! simulation unchanged, never serves the damaged one (every call on it answers
//! `Simulation {id} is damaged: {reason}`), and lists it under `damaged` with a reason that
//! names the first bad event where one can be named. Also the MAC key: a key of the wrong
//! length stops the start with one sentence; 32 other bytes make saved files refold.

use crate::common;

use common::hard::{listed, rng, seed};
use common::Server;
use rand::Rng;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// A simulation with a ground, a few boxes and enough changes for several snapshots.
async fn populated(c: &common::Client) -> String {
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    for i in 0..70 {
        let z = 0.5 + f64::from(i % 7) * 0.3;
        c.call("add_box", json!({"sim_id": sim, "dimensions": [0.2, 0.2, 0.2], "position": [f64::from(i % 5), 0, z]})).await;
    }
    c.step(&sim, 20).await;
    sim
}

fn log_path(data: &Path, sim: &str) -> PathBuf {
    data.join(format!("{sim}.sqlite"))
}

/// Replaces every occurrence of `needle` in `path` (if the file exists) by `with`.
fn replace_bytes(path: &Path, needle: &[u8], with: &[u8]) -> usize {
    let Ok(mut bytes) = std::fs::read(path) else { return 0 };
    let mut n = 0;
    let mut i = 0;
    while i + needle.len() <= bytes.len() {
        if &bytes[i..i + needle.len()] == needle {
            bytes[i..i + needle.len()].copy_from_slice(with);
            n += 1;
            i += needle.len();
        } else {
            i += 1;
        }
    }
    std::fs::write(path, bytes).unwrap();
    n
}

fn damaged_reason<'a>(damaged: &'a [(String, String)], sim: &str) -> &'a str {
    &damaged.iter().find(|(id, _)| id == sim).unwrap_or_else(|| panic!("{sim} not listed as damaged: {damaged:?}")).1
}

#[tokio::test(flavor = "multi_thread")]
async fn damaged_logs_are_reported_and_never_served() {
    let seed = seed();
    let mut rng = rng(seed);
    let dir = tempfile::tempdir().unwrap();
    let names = ["hash_flip", "random_flips", "truncated", "snapshot_swap", "wal_deleted", "healthy"];
    let (sims, hashes) = {
        let server = Server::start(dir.path(), &[]);
        let c = server.client().await;
        let mut sims = Vec::new();
        let mut hashes = Vec::new();
        for _ in names {
            let sim = populated(&c).await;
            hashes.push(c.hash(&sim).await);
            sims.push(sim);
        }
        // A clean stop: every log is checkpointed into its main file and closed.
        server.terminate();
        (sims, hashes)
    };
    let data = dir.path().join("data");
    let [flip, random, truncated, swap, wal, healthy] = std::array::from_fn(|i| sims[i].clone());

    // The head's state hash, one hex digit changed everywhere it is stored.
    let head_hash = hashes[0].as_bytes();
    let mut bad = head_hash.to_vec();
    bad[10] = if bad[10] == b'0' { b'1' } else { b'0' };
    assert!(replace_bytes(&log_path(&data, &flip), head_hash, &bad) > 0, "the head hash is in the file");

    // Random byte flips in the second half of the file (past SQLite's header page).
    let path = log_path(&data, &random);
    let mut bytes = std::fs::read(&path).unwrap();
    let len = bytes.len();
    for _ in 0..64 {
        let i = rng.gen_range(len / 2..len);
        bytes[i] ^= 1 << rng.gen_range(0..8);
    }
    std::fs::write(&path, bytes).unwrap();

    // Truncated to half.
    let path = log_path(&data, &truncated);
    let f = std::fs::OpenOptions::new().write(true).open(&path).unwrap();
    f.set_len(std::fs::metadata(&path).unwrap().len() / 2).unwrap();
    drop(f);

    // The newest snapshot replaced by the oldest one (bytes and hash: a valid snapshot of
    // the wrong state).
    {
        let conn = rusqlite::Connection::open(log_path(&data, &swap)).unwrap();
        let (oldest, newest): (i64, i64) =
            conn.query_row("SELECT MIN(seq), MAX(seq) FROM snapshots", [], |r| Ok((r.get(0)?, r.get(1)?))).unwrap();
        assert!(oldest < newest, "several snapshots");
        conn.execute(
            "UPDATE snapshots SET (bytes, hash) = (SELECT bytes, hash FROM snapshots WHERE seq = ?1) WHERE seq = ?2",
            [oldest, newest],
        )
        .unwrap();
    }

    // Changes committed to the WAL only, then kill -9 and the WAL deleted.
    {
        let server = Server::start(dir.path(), &[]);
        let c = server.client().await;
        for _ in 0..5 {
            c.step(&wal, 3).await;
        }
        server.kill();
        let wal_file = data.join(format!("{wal}.sqlite-wal"));
        assert!(wal_file.exists(), "the killed server left its WAL");
        std::fs::remove_file(wal_file).unwrap();
        let _ = std::fs::remove_file(data.join(format!("{wal}.sqlite-shm")));
    }

    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let (live, damaged) = listed(&c.call("list_simulations", json!({})).await);
    eprintln!("damaged: {damaged:#?}");
    // Served only with the exact state it had, or not at all.
    let mut must_be_damaged = vec![flip.clone(), truncated.clone(), swap.clone(), wal.clone()];
    if live.contains(&random) {
        assert_eq!(c.hash(&random).await, hashes[1], "random flips: served, so with its own state");
    } else {
        must_be_damaged.push(random.clone());
    }
    for sim in &must_be_damaged {
        assert!(!live.contains(sim), "{sim} is damaged but listed live");
        let reason = damaged_reason(&damaged, sim);
        for (tool, args) in [
            ("get_simulation_info", json!({"sim_id": sim})),
            ("step_simulation", json!({"sim_id": sim, "steps": 1})),
            ("verify_simulation", json!({"sim_id": sim})),
            ("destroy_simulation", json!({"sim_id": sim})),
        ] {
            let e = c.try_call(tool, args).await.unwrap_err();
            assert_eq!(e, format!("Simulation {sim} is damaged: {reason}"), "{tool}");
        }
    }
    assert!(damaged_reason(&damaged, &flip).contains("seq"), "the hash flip names its event");
    assert!(damaged_reason(&damaged, &swap).contains("seq"), "the swapped snapshot names its event");
    assert!(damaged_reason(&damaged, &wal).contains("write-ahead log"));
    // The healthy one is served with its state and keeps working.
    assert!(live.contains(&healthy));
    assert_eq!(c.hash(&healthy).await, hashes[5]);
    c.step(&healthy, 1).await;
    let v = c.call("verify_simulation", json!({"sim_id": healthy})).await;
    assert_eq!(v["ok"], true);
    // The damaged files are left as they were, for inspection.
    for sim in &must_be_damaged {
        assert!(log_path(&data, sim).exists());
    }
}

/// Saves a simulation (as `s.json`) and returns the file with an early event's command
/// tampered: the snapshot's MAC covers the events, so no key trusts it, and a refold finds it.
async fn tampered_save(server: &Server, c: &common::Client) -> Value {
    let sim = populated(c).await;
    c.call("save_simulation", json!({"sim_id": sim, "file_path": "s.json"})).await;
    let mut file: Value = serde_json::from_slice(&std::fs::read(server.workspace.join("s.json")).unwrap()).unwrap();
    let events = file["history"]["events"].as_array_mut().unwrap();
    let e = events
        .iter_mut()
        .find(|e| e["tool"] == "add_box" && e["command"].as_str().unwrap().contains("\"mass\":1.0"))
        .unwrap();
    let cmd = e["command"].as_str().unwrap().replace("\"mass\":1.0", "\"mass\":1.5");
    assert_ne!(cmd, e["command"].as_str().unwrap(), "the command holds the mass");
    e["command"] = json!(cmd);
    file
}

#[tokio::test(flavor = "multi_thread")]
async fn mac_key_of_wrong_length_stops_the_start_and_another_key_makes_loads_refold() {
    let dir = tempfile::tempdir().unwrap();
    let key = dir.path().join("data/mac.key");
    let file = {
        let server = Server::start(dir.path(), &[]);
        let c = server.client().await;
        let file = tampered_save(&server, &c).await;
        std::fs::write(server.workspace.join("t.json"), file.to_string()).unwrap();
        // Our own key: the untouched file loads; the tampered one is not trusted (the MAC
        // covers the events, not the snapshot alone, as it once did) and its refold finds it.
        c.call("load_simulation", json!({"file_path": "s.json"})).await;
        let e = c.try_call("load_simulation", json!({"file_path": "t.json"})).await.unwrap_err();
        assert!(e.contains("seq"), "the refold names the diverging event: {e}");
        server.terminate();
        file
    };
    std::fs::write(&key, [7u8; 31]).unwrap();
    let data = dir.path().join("data");
    let data = data.to_str().unwrap();
    let ws = dir.path().join("workspace");
    let (ok, stderr) = Server::start_failure(&["serve", "--bind", "127.0.0.1:0", "--data", data, "--workspace", ws.to_str().unwrap()]);
    assert!(!ok);
    assert!(stderr.contains("is not a 32-byte key; remove it to make a new one"), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "one sentence: {stderr}");
    // 32 other bytes: the file's MAC no longer proves it is ours, so the load refolds every
    // event: the untouched file still loads, and the tampered one is found.
    std::fs::write(&key, [7u8; 32]).unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    c.call("load_simulation", json!({"file_path": "s.json"})).await;
    std::fs::write(server.workspace.join("t.json"), file.to_string()).unwrap();
    let e = c.try_call("load_simulation", json!({"file_path": "t.json"})).await.unwrap_err();
    assert!(e.contains("seq"), "the refold names the diverging event: {e}");
}
