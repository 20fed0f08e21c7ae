//! What a client was told, checked against what the log holds: the crash tests stream
//! add_box and step_simulation calls, note each acknowledged one by what it made (the new
//! object's id, the time the step reached: unique along one chain without undo), and count the
//! calls whose fate they never learned. Afterwards the exported log's changes must contain
//! every acknowledged call, in order, and at most one extra change per unknown call.

use serde_json::{json, Value};

use crate::nodes::{event_result, owned_elsewhere, Outcome};
use physics_mcp::log::sqlite::{Event, Kind};

/// The calls a stream makes, with arguments tagged so that every add_box is distinct.
pub struct Stream {
    pub sim: String,
    n: u64,
}

impl Stream {
    pub fn new(sim: &str) -> Stream {
        Stream { sim: sim.to_string(), n: 0 }
    }

    /// The next call: add_box on a 20×20 grid (then stacked higher) and a 2-step
    /// step_simulation, alternately.
    pub fn next_call(&mut self) -> (&'static str, Value) {
        let n = self.n;
        self.n += 1;
        if n % 2 == 1 {
            return ("step_simulation", json!({"sim_id": self.sim, "steps": 2}));
        }
        let k = n / 2;
        let (x, y, z) = ((k % 20) as f64 * 0.3 - 3.0, ((k / 20) % 20) as f64 * 0.3 - 3.0, 0.1 + (k / 400) as f64 * 0.25);
        ("add_box", json!({"sim_id": self.sim, "dimensions": [0.05, 0.05, 0.05], "position": [x, y, z]}))
    }
}

/// Adds the static ground slab the stream's boxes land on, noted in `ledger` like any
/// acknowledged add_box (it is one of the log's add_box changes).
pub async fn ground(c: &crate::common::Client, sim: &str, ledger: &mut Ledger) {
    let id = c.ground(sim).await;
    ledger.record("add_box", &Outcome::Ok(json!({"object_id": id})));
}

/// What identifies an accepted add_box or step along one chain: what it made.
fn identity(tool: &str, result: &Value) -> Value {
    match tool {
        "add_box" => result["object_id"].clone(),
        "step_simulation" => result["current_time"].clone(),
        other => panic!("the ledger only follows add_box and step_simulation, not {other}"),
    }
}

/// The acknowledged calls in order, and how many calls ended without the client learning
/// whether they were applied.
#[derive(Default)]
pub struct Ledger {
    acked: Vec<(String, Value)>,
    unknown: usize,
}

impl Ledger {
    /// Notes a call's outcome. A refusal or a lost reply is unknown: the owner a forwarded
    /// call reached may have died with it ("stopped answering"), a node may have lost the
    /// cluster's acknowledgement; the stream's calls are valid, so no refusal here is the
    /// ordinary kind that changes nothing. (The "owned by another node" refusal, which did
    /// change nothing, is no longer answered: such a call is forwarded to the owner.)
    pub fn record(&mut self, tool: &str, outcome: &Outcome) {
        match outcome {
            Outcome::Ok(v) => self.acked.push((tool.to_string(), identity(tool, v))),
            Outcome::Refused(e) => {
                assert!(!owned_elsewhere(e), "{tool} was refused as owned by another node, which routing forwards: {e}");
                self.unknown += 1;
            }
            Outcome::Lost(_) => self.unknown += 1,
        }
    }

    pub fn acked(&self) -> usize {
        self.acked.len()
    }

    pub fn unknown(&self) -> usize {
        self.unknown
    }

    /// Panics unless the log's own accepted add_box/step changes contain every acknowledged
    /// call, in order, with at most `unknown` more.
    pub fn assert_in_log(&self, events: &[Event]) {
        let changes: Vec<(String, Value)> = events
            .iter()
            .filter(|e| e.kind == Kind::Change && e.ok && !e.inherited && matches!(e.tool.as_str(), "add_box" | "step_simulation"))
            .map(|e| (e.tool.clone(), identity(&e.tool, &event_result(e))))
            .collect();
        let mut next = 0;
        for (i, acked) in self.acked.iter().enumerate() {
            match changes[next..].iter().position(|c| c == acked) {
                Some(p) => next += p + 1,
                None => panic!(
                    "acknowledged call #{i} ({} {}) is not in the log after its change #{next}; \
                     the log has {} add_box/step changes, {} calls were acknowledged",
                    acked.0,
                    acked.1,
                    changes.len(),
                    self.acked.len()
                ),
            }
        }
        let extra = changes.len() - self.acked.len();
        assert!(
            extra <= self.unknown,
            "the log holds {extra} add_box/step changes no client was told of, but only {} calls ended unknown",
            self.unknown
        );
    }
}

/// The checker's own control, on an embedded server (no NATS): a stream killed mid-call with
/// -9, the server restarted on its data, the stream resumed; the ledger must find every
/// acknowledged call in the log, or the crash tests' verdicts would mean nothing.
#[tokio::test(flavor = "multi_thread")]
#[ignore = "the control of the cluster crash tests: cargo test --test cluster -- --ignored"]
async fn the_ledger_finds_every_acknowledged_call_in_an_embedded_log() {
    crate::nodes::assert_no_ambient_cluster();
    use crate::common::Server;
    use crate::nodes::{attempt, events, signal};
    use std::time::Duration;

    let dir = tempfile::tempdir().unwrap();
    let mut server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let (mut stream, mut ledger) = (Stream::new(&sim), Ledger::default());
    ground(&c, &sim, &mut ledger).await;
    for round in 0..3 {
        let c = server.client().await;
        let pid = server.pid();
        let timer = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(150 + 100 * round));
            signal(pid, "KILL");
        });
        loop {
            let (tool, args) = stream.next_call();
            let outcome = attempt(&c, tool, args, Duration::from_secs(10)).await;
            ledger.record(tool, &outcome);
            if matches!(outcome, Outcome::Lost(_)) {
                break;
            }
        }
        timer.join().unwrap();
        server.kill();
        server = Server::start(dir.path(), &[]);
    }
    server.terminate();
    let log = events(&dir.path().join("data").join(format!("{sim}.sqlite")));
    ledger.assert_in_log(&log);
    assert!(ledger.acked() > 10, "{} calls acknowledged", ledger.acked());
    eprintln!("{} acknowledged, {} unknown, all in the log", ledger.acked(), ledger.unknown());
}
