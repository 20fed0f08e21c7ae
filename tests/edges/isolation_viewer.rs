//! One client cannot sink the others by looking at the past (docs/guarantees.md "Isolation"):
//! re-simulations for get_trajectory, render_animation and the viewer are priced before they
//! run and refused past `--max-work` saying what fits; they stop when nobody waits for them
//! (an MCP cancel, a browser that went away); an object id that never existed is refused
//! without re-simulating; viewer asks waiting for a busy simulation hold a few threads, not
//! one each; and the viewer's caches forget destroyed simulations.

use std::sync::Arc;
use std::time::Duration;

use crate::common;

use common::Server;
use rmcp::model::{CallToolRequestParams, ClientRequest, Request};
use rmcp::service::PeerRequestOptions;
use serde_json::{json, Value};

/// `n` static boxes in rows (calls for a batch): cheap to step, yet each counts in body-steps.
fn static_boxes(n: usize) -> Vec<Value> {
    (0..n)
        .map(|i| json!({"tool": "add_box", "arguments": {"dimensions": [0.1, 0.1, 0.1], "position": [(i % 100) as f64 * 0.3, (i / 100) as f64 * 0.3, 0.1], "mass": 0}}))
        .collect()
}

/// GET `url`: (status, body).
async fn get(url: &str) -> (u16, String) {
    let r = reqwest::Client::new().get(url).send().await.expect("HTTP GET");
    (r.status().as_u16(), r.text().await.unwrap())
}

/// A simulation of 100 static boxes and two step events of `steps` steps each: (id, the seq
/// after the boxes, the first step's seq, the second's).
async fn two_steps(c: &common::Client, steps: u64) -> (String, u64, u64, u64) {
    let sim = c.new_sim(json!({})).await;
    let added = c.call("batch", json!({"sim_id": sim, "calls": static_boxes(100)})).await;
    let boxes = added["head_seq"].as_u64().expect("batch head_seq");
    let first = c.step(&sim, steps).await["head_seq"].as_u64().unwrap();
    let second = c.step(&sim, steps).await["head_seq"].as_u64().unwrap();
    (sim, boxes, first, second)
}

/// The server's threads now (Linux).
fn threads(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    status.lines().find_map(|l| l.strip_prefix("Threads:")).and_then(|n| n.trim().parse().ok()).unwrap()
}

#[tokio::test(flavor = "multi_thread")]
async fn looking_back_is_priced_before_it_runs_and_refused_saying_what_fits() {
    let dir = tempfile::tempdir().unwrap();
    // Each step event costs 100 boxes × 4,000 steps = 400,000 body-steps; both, 800,000.
    let server = Server::start(dir.path(), &["--max-work", "500000"]);
    let c = server.client().await;
    let (sim, boxes, first, second) = two_steps(&c, 4000).await;
    let before = common::hard::fingerprint(&c, &sim).await;
    for tool in ["get_trajectory", "render_animation"] {
        let why = c.try_call(tool, json!({"sim_id": sim, "from_seq": boxes, "every": 1000})).await.unwrap_err();
        assert!(why.contains("800000 body-steps") && why.contains("(--max-work)") && why.contains(&format!("a to_seq at or before {first}")), "{tool}: {why}");
        // What it said fits, fits.
        c.call(tool, json!({"sim_id": sim, "from_seq": boxes, "to_seq": first, "every": 1000})).await;
    }
    common::hard::assert_unchanged(&c, &sim, &before, "a re-simulation refused over --max-work").await;
    // The viewer: a clip over both steps, the inspector over the whole chain — refused alike,
    // and the same answer when asked again (remembered at this head).
    let base = server.base_url();
    for ask in [format!("clip?from_seq={boxes}&every=1000000"), "object?id=5".to_string()] {
        let (status, why) = get(&format!("{base}/viewer/{sim}/{ask}")).await;
        assert!(status == 400 && why.contains("(--max-work)"), "{ask}: {status} {why}");
        assert_eq!(get(&format!("{base}/viewer/{sim}/{ask}")).await, (status, why), "{ask} asked again");
    }
    // A moment inside a step event is priced only as far as it goes.
    let (status, why) = get(&format!("{base}/viewer/{sim}/poses?seq={second}&step=4000")).await;
    assert_eq!(status, 200, "{why}");
    let (status, _) = get(&format!("{base}/viewer/{sim}/clip?from_seq={first}&every=1000")).await;
    assert_eq!(status, 200);
}

#[tokio::test(flavor = "multi_thread")]
async fn an_object_that_never_existed_is_refused_without_re_simulating() {
    let dir = tempfile::tempdir().unwrap();
    // Any re-simulation at all would be refused over --max-work 1: the sentence shows none ran.
    let server = Server::start(dir.path(), &["--max-work", "1"]);
    let c = server.client().await;
    let (sim, ..) = two_steps(&c, 10).await;
    let url = format!("{}/viewer/{sim}/object?id=99999", server.base_url());
    let (status, why) = get(&url).await;
    assert!(status == 400 && why.contains(&format!("simulation {sim} never had an object 99999")) && !why.contains("--max-work"), "{status} {why}");
    assert_eq!(get(&url).await, (status, why));
}

/// A simulation whose re-simulation from its root (the first seq returned) to its step (the
/// second) steps 1,000 static boxes `steps` times: long enough to be stopped in the middle.
/// Steps of the long histories the cancellation tests re-simulate: long enough (seconds, even
/// on a quiet machine: static boxes step in microseconds) that the re-simulation is still
/// running when the client gives up after 0.3 s, and within the default `--max-work`.
const LONG: u64 = 150_000;

async fn long_history(c: &common::Client, steps: u64) -> (String, u64, u64) {
    let sim = c.new_sim(json!({})).await;
    let root = c.call("get_history", json!({"sim_id": sim}))
        .await["events"][0]["seq"].as_u64().unwrap();
    c.call("batch", json!({"sim_id": sim, "calls": static_boxes(1000)})).await;
    let head = c.step(&sim, steps).await["head_seq"].as_u64().unwrap();
    (sim, root, head)
}

#[tokio::test(flavor = "multi_thread")]
async fn a_cancelled_trajectory_stops_re_simulating_and_is_recorded_as_refused() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start_with_env(dir.path(), &[], &[("RUST_LOG", "physics_mcp=info")]);
    let c = server.client().await;
    let (sim, root, head) = long_history(&c, LONG).await;
    let req = ClientRequest::CallToolRequest(Request::new(
        CallToolRequestParams::new("get_trajectory").with_arguments(json!({"sim_id": sim, "from_seq": root, "every": 100000}).as_object().unwrap().clone()),
    ));
    let mut opts = PeerRequestOptions::no_options();
    opts.timeout = Some(Duration::from_millis(300));
    let handle = c.service.send_cancellable_request(req, opts).await.unwrap();
    let r = handle.await_response().await;
    assert!(r.is_err(), "the call should have been cancelled: {r:?}");
    // The server says it stopped, and the log records the call as refused, saying why.
    let stderr = server.stderr.clone();
    common::until("the re-simulation to stop", || stderr.lock().unwrap().iter().any(|l| l.contains("re-simulation stopped") && l.contains(&sim))).await;
    let mut refused = None;
    for _ in 0..200 {
        let h = c.call("get_history", json!({"sim_id": sim, "since_seq": head})).await;
        refused = h["events"].as_array().unwrap().iter().find(|e| e["tool"] == "get_trajectory").cloned();
        if refused.is_some() {
            break;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let refused = refused.expect("the cancelled get_trajectory is in the history");
    assert!(refused.to_string().contains("cancelled"), "{refused}");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_viewer_ask_the_browser_gave_up_stops_re_simulating() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start_with_env(dir.path(), &[], &[("RUST_LOG", "physics_mcp=info")]);
    let c = server.client().await;
    let (sim, root, _) = long_history(&c, LONG).await;
    // The browser asks for a clip of the whole chain and goes away after 0.3 s.
    let url = format!("{}/viewer/{sim}/clip?from_seq={root}&every=1000000", server.base_url());
    let http = reqwest::Client::builder().timeout(Duration::from_millis(300)).build().unwrap();
    assert!(http.get(&url).send().await.is_err(), "the ask should have timed out");
    let stderr = server.stderr.clone();
    common::until("the dropped ask's re-simulation to stop", || stderr.lock().unwrap().iter().any(|l| l.contains("re-simulation stopped") && l.contains(&sim))).await;
}

#[tokio::test(flavor = "multi_thread")]
async fn viewer_asks_waiting_for_a_busy_simulation_hold_a_few_threads() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = Arc::new(server.client().await);
    let sim = c.new_sim(json!({})).await;
    c.call("batch", json!({"sim_id": sim, "calls": static_boxes(100)})).await;
    // An arm never sleeps (a falling box does, and then a million steps take moments on a
    // quiet machine), so the step below holds the simulation for a minute or more.
    c.call("load_urdf", json!({"sim_id": sim, "file_path": "kuka_iiwa/model.urdf", "position": [0, 2, 0]})).await;
    let stepping = {
        let (c, sim) = (c.clone(), sim.clone());
        tokio::spawn(async move { c.try_call("step_simulation", json!({"sim_id": sim, "steps": 1_000_000})).await })
    };
    // Until the step holds the simulation, a past moment answers at once.
    let url = format!("{}/viewer/{sim}/poses?seq=1", server.base_url());
    loop {
        tokio::time::sleep(Duration::from_millis(200)).await;
        assert!(!stepping.is_finished(), "the step ended before the viewer saw it busy: the test proves nothing");
        if get(&url).await.0 == 202 {
            break;
        }
    }
    let idle = threads(server.pid());
    let asks: Vec<_> = (0..60)
        .map(|_| {
            let url = url.clone();
            tokio::spawn(async move { get(&url).await })
        })
        .collect();
    tokio::time::sleep(Duration::from_millis(1500)).await;
    let waiting = threads(server.pid());
    assert!(!stepping.is_finished(), "the step ended before the asks were counted: the test proves nothing");
    assert!(waiting < idle + 20, "60 asks waiting for a busy simulation took {} threads (from {idle} to {waiting})", waiting - idle.min(waiting));
    for a in asks {
        assert_eq!(a.await.unwrap().0, 202, "an ask of a busy simulation is told to ask again");
    }
}

/// A registry in this process with simulations `ids`, each a sphere stepped 3 × 10 steps (so
/// a timeline, past moments and clips have something to show).
fn registry_with_spheres(dir: &std::path::Path, ids: &[&str]) -> physics_mcp::sim::Registry {
    use physics_mcp::command::{Command, Shape};
    use physics_mcp::limits::Limits;
    use physics_mcp::sim::{lock_sim, Registry};
    use physics_mcp::value::Args;

    let reg = Registry::open(common::config(dir)).unwrap();
    let (a, l) = (Args::new(), Limits::default());
    for &id in ids {
        let root = Command::CreateSimulation { simulation_id: id.into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) };
        reg.create(root, &a).unwrap();
        let shared = reg.get(id).unwrap();
        let mut sim = lock_sim(&shared);
        let add = Command::AddBody { shape: Shape::Sphere { radius: 0.1 }, position: [0.0, 0.0, 1.0], orientation: [0.0, 0.0, 0.0, 1.0], mass: 1.0, color: None, collides: true };
        sim.change("add_sphere", &a, Ok(add), &l, &mut |_| true).unwrap();
        for _ in 0..3 {
            sim.change("step_simulation", &a, Ok(Command::step(10)), &l, &mut |_| true).unwrap();
        }
    }
    reg
}

/// Destroying a simulation drops every answer the viewer cached of it at once — its timeline,
/// the last present shown, past moments, clips, inspections and refusals — and nothing of
/// another simulation. Counted in the caches themselves: each is bounded in bytes, so a
/// forgotten `forget` never shows in the process's memory (measuring it could not fail, and
/// failed on allocator noise).
#[test]
fn the_viewer_forgets_destroyed_simulations() {
    use physics_mcp::seeing::viewer::ask;

    let dir = tempfile::tempdir().unwrap();
    let ids = ["forgotten_doomed", "forgotten_kept"];
    let reg = registry_with_spheres(dir.path(), &ids);
    let stop = tokio_util::sync::CancellationToken::new();
    // One ask of each kind that is kept: a timeline, the present, a past moment, a clip, an
    // inspection, and a refusal (an object the simulation never had).
    let asks = [("timeline", ""), ("poses", ""), ("poses", "seq=3"), ("clip", "from_seq=2"), ("object", "id=0"), ("object", "id=99")];
    for id in ids {
        for (kind, query) in asks {
            let answered = ask::answer_text(&reg, id, kind, query, &stop);
            assert_eq!(answered.is_ok(), query != "id=99", "{kind}?{query} of {id}: {answered:?}");
        }
    }
    let kept = ask::kept_of(ids[1]);
    for (cache, n) in ask::kept_of(ids[0]).into_iter().chain(kept.clone()) {
        assert!(n > 0, "the viewer's {cache} cache kept nothing of the asks");
    }
    reg.destroy(ids[0]).unwrap();
    for (cache, n) in ask::kept_of(ids[0]) {
        assert_eq!(n, 0, "the viewer's {cache} cache still keeps answers of a destroyed simulation");
    }
    assert_eq!(ask::kept_of(ids[1]), kept, "destroying one simulation dropped another's answers");
}

/// An ask re-simulates without the simulation's lock, so it can finish after `destroy` emptied
/// the viewer's caches: what it caches then is dropped too. The asker is held at the spot where
/// it caches its clip (a debug build's hold point) while the simulation is destroyed.
#[cfg(debug_assertions)]
#[test]
fn an_ask_finishing_after_destroy_leaves_nothing_cached() {
    use physics_mcp::seeing::viewer::ask;
    use std::sync::{mpsc, Mutex};

    let dir = tempfile::tempdir().unwrap();
    let id = "refilled_doomed";
    let reg = registry_with_spheres(dir.path(), &[id]);
    let stop = tokio_util::sync::CancellationToken::new();
    let (arrived, at_hold) = mpsc::channel::<()>();
    let (release, go) = mpsc::channel::<()>();
    // Only the asker below is held, once: other tests' asks pass the point.
    let hold = Mutex::new(Some((arrived, go)));
    fail::cfg_callback("viewer_clip_put", move || {
        if std::thread::current().name() != Some("refill asker") {
            return;
        }
        if let Some((arrived, go)) = hold.lock().unwrap().take() {
            let _ = arrived.send(());
            // Bounded: if the test fails while the asker is held, it fails instead of hanging.
            let _ = go.recv_timeout(Duration::from_secs(120));
        }
    })
    .unwrap();
    std::thread::scope(|s| {
        let asker = std::thread::Builder::new()
            .name("refill asker".into())
            .spawn_scoped(s, || ask::answer_text(&reg, id, "clip", "from_seq=2", &stop))
            .unwrap();
        at_hold.recv_timeout(Duration::from_secs(120)).expect("the ask reached the point where it caches its clip");
        reg.destroy(id).unwrap();
        release.send(()).unwrap();
        let answered = asker.join().unwrap();
        assert!(answered.is_ok(), "the clip was answered: {answered:?}");
    });
    fail::remove("viewer_clip_put");
    for (cache, n) in ask::kept_of(id) {
        assert_eq!(n, 0, "the viewer's {cache} cache keeps an answer made after its simulation was destroyed");
    }
}
