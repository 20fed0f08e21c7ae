//! Records `replays/scripts/*.txt` into logs with the project's own server and MCP client:
//! `replays/record.sh` runs the ignored `record_replays` test, which rewrites `replays/*.sqlite`.
//! Every test run also records scripts into a temporary directory and replays what it wrote
//! with the CLI, so the recorder cannot rot unnoticed.
//!
//! A script line is `TOOL {json}`, optionally followed by ` -> name=field`, which saves that
//! field of the result for later lines to use as `$name`. A leading `!` marks a call that must
//! be refused (the scripts record refusals on purpose). Blank lines and `#` comments are
//! skipped. Any other refusal, or a `!` call that succeeds, fails the recording.

// A test harness reads scripts, environment and files; the clock and file bans are for the world.
#![allow(clippy::disallowed_methods)]

use crate::common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use common::{Client, Server};
use serde_json::Value;

/// Runs one script on `client`; `Err` names the first line that did not go as written.
async fn run_script(client: &Client, script: &str) -> Result<(), String> {
    let mut saved: BTreeMap<String, Value> = BTreeMap::new();
    for (n, raw) in script.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (refusal, line) = match line.strip_prefix('!') {
            Some(rest) => (true, rest.trim_start()),
            None => (false, line),
        };
        let (call, save) = match line.rsplit_once(" -> ") {
            Some((call, save)) => (call, Some(save)),
            None => (line, None),
        };
        let mut call = call.to_string();
        for (name, v) in &saved {
            let text = v.as_str().map(str::to_string).unwrap_or_else(|| v.to_string());
            call = call.replace(&format!("${name}"), &text);
        }
        let (tool, json) = call.split_once(' ').unwrap_or((&call, "{}"));
        let args: Value = serde_json::from_str(json).map_err(|e| format!("line {}: bad JSON {json}: {e}", n + 1))?;
        let got = client.try_call(tool, args).await;
        let result = match (got, refusal) {
            (Ok(v), false) => v,
            (Err(_), true) => continue,
            (Err(why), false) => return Err(format!("line {}: {tool} was refused: {why}", n + 1)),
            (Ok(v), true) => return Err(format!("line {}: {tool} is marked `!` but was accepted: {v}", n + 1)),
        };
        if let Some(save) = save {
            let (name, field) = save.split_once('=').ok_or_else(|| format!("line {}: expected -> name=field", n + 1))?;
            let v = result.get(field.trim()).cloned().ok_or_else(|| format!("line {}: no field {field} in {result}", n + 1))?;
            saved.insert(name.trim().to_string(), v);
        }
    }
    Ok(())
}

/// Runs `script` against a fresh server and writes every simulation it created into `out` as
/// `<name>.sqlite` (the one with no inherited events first) and `<name>-<n>.sqlite`, compacted
/// (4 KB pages, no WAL). Returns the files written.
async fn record(script: &Path, out: &Path) -> Result<Vec<PathBuf>, String> {
    let name = script.file_stem().unwrap().to_str().unwrap();
    let text = std::fs::read_to_string(script).map_err(|e| format!("{}: {e}", script.display()))?;
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    // The fixtures (URDFs, MJCF models) are in the workspace for scripts that load them.
    server.copy_fixtures();
    let client = server.client().await;
    let ran = run_script(&client, &text).await;
    drop(client);
    let data = server.data.clone();
    // SIGTERM commits the read and refused events still buffered.
    server.terminate();
    ran.map_err(|e| format!("{}: {e}", script.display()))?;
    let mut logs: Vec<(i64, PathBuf)> = std::fs::read_dir(&data)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "sqlite"))
        .map(|p| {
            let conn = rusqlite::Connection::open(&p).unwrap();
            let inherited: i64 = conn.query_row("SELECT COUNT(*) FROM events WHERE inherited = 1", [], |r| r.get(0)).unwrap();
            (inherited, p)
        })
        .collect();
    logs.sort();
    let mut written = Vec::new();
    for (i, (_, path)) in logs.iter().enumerate() {
        let conn = rusqlite::Connection::open(path).unwrap();
        conn.execute_batch("PRAGMA journal_mode=DELETE; PRAGMA page_size=4096; VACUUM;").unwrap();
        drop(conn);
        let dest = out.join(if i == 0 { format!("{name}.sqlite") } else { format!("{name}-{i}.sqlite") });
        std::fs::copy(path, &dest).unwrap();
        written.push(dest);
    }
    if written.is_empty() {
        return Err(format!("{}: the script created no simulation", script.display()));
    }
    Ok(written)
}

fn scripts_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("replays/scripts")
}

fn replay_cli(log: &Path) -> (bool, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_physics-mcp")).arg("replay").arg(log).output().unwrap();
    (out.status.success(), format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr)))
}

#[tokio::test(flavor = "multi_thread")]
async fn recorded_scripts_replay_through_the_cli() {
    let out = tempfile::tempdir().unwrap();
    // Refusals marked `!`, a fork (two files) and an undo.
    for script in ["shapes_and_refusals.txt", "fork.txt"] {
        let files = record(&scripts_dir().join(script), out.path()).await.unwrap_or_else(|e| panic!("{e}"));
        for f in &files {
            let (ok, text) = replay_cli(f);
            assert!(ok, "{}: {text}", f.display());
        }
    }
    assert!(out.path().join("fork-1.sqlite").exists(), "the fork's log was not written");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_script_that_does_not_go_as_written_fails_loudly() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let ok = "create_simulation {} -> sim=simulation_id\nstep_simulation {\"sim_id\": \"$sim\", \"steps\": 1}\n";
    assert_eq!(run_script(&c, ok).await, Ok(()));
    let unexpected = "create_simulation {} -> sim=simulation_id\nadd_sphere {\"sim_id\": \"$sim\", \"radius\": -1}\n";
    let e = run_script(&c, unexpected).await.unwrap_err();
    assert!(e.starts_with("line 2: add_sphere was refused"), "{e}");
    let wrongly_marked = "create_simulation {} -> sim=simulation_id\n! step_simulation {\"sim_id\": \"$sim\", \"steps\": 1}\n";
    let e = run_script(&c, wrongly_marked).await.unwrap_err();
    assert!(e.starts_with("line 2: step_simulation is marked `!` but was accepted"), "{e}");
}

/// Rewrites `replays/*.sqlite` from the scripts (`RECORD_SCRIPTS`: space-separated paths, all
/// scripts by default). Run on purpose only, through `replays/record.sh`.
#[tokio::test(flavor = "multi_thread")]
#[ignore = "rewrites replays/*.sqlite; run through replays/record.sh"]
async fn record_replays() {
    let scripts: Vec<PathBuf> = match std::env::var("RECORD_SCRIPTS") {
        Ok(list) if !list.trim().is_empty() => list.split_whitespace().map(PathBuf::from).collect(),
        _ => {
            let mut all: Vec<PathBuf> = std::fs::read_dir(scripts_dir()).unwrap().map(|e| e.unwrap().path()).filter(|p| p.extension().is_some_and(|x| x == "txt")).collect();
            all.sort();
            all
        }
    };
    let out = std::env::var("RECORD_OUT").map(PathBuf::from).unwrap_or_else(|_| Path::new(env!("CARGO_MANIFEST_DIR")).join("replays"));
    for script in scripts {
        let name = script.file_stem().unwrap().to_str().unwrap().to_string();
        // Record into a scratch directory first: a failing script leaves the old logs alone.
        let scratch = tempfile::tempdir().unwrap();
        let files = record(&script, scratch.path()).await.unwrap_or_else(|e| panic!("{e}"));
        for old in std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().path()) {
            let file = old.file_name().unwrap().to_str().unwrap();
            let numbered = file.strip_prefix(&format!("{name}-")).and_then(|r| r.strip_suffix(".sqlite")).is_some_and(|n| n.parse::<u32>().is_ok());
            if file == format!("{name}.sqlite") || numbered {
                std::fs::remove_file(&old).unwrap();
            }
        }
        for f in files {
            let dest = out.join(f.file_name().unwrap());
            std::fs::copy(&f, &dest).unwrap();
            let (ok, text) = replay_cli(&dest);
            assert!(ok, "{} does not replay: {text}", dest.display());
            println!("{} {} bytes", dest.display(), std::fs::metadata(&dest).unwrap().len());
        }
    }
}
