//! Two servers driven call for call with the same arguments, each reply compared as soon as
//! both are in: the equivalence tests' engine. A side is one server through one session, or
//! several cluster nodes called round-robin (a session on each, or stateless requests).
//! Simulation ids differ between servers (fresh UUIDs), so every UUID in a reply is renamed
//! `sim#N` by its order of first appearance on that side; fields that may legitimately differ
//! are dropped (`VOLATILE`).

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::time::Duration;

use serde_json::{Map, Value};

use crate::common::Client;
use crate::nodes::{attempt, attempt_stateless, Outcome};

/// Reply fields that differ between two correct servers given the same calls, as found by
/// running the script against two embedded servers
/// (`equivalence::two_embedded_servers_agree_on_the_script`): none so far. Simulation ids and
/// directories are renamed; everything else (simulated time included) follows from the calls.
const VOLATILE: &[&str] = &[];

/// The longest any single call of the script may take before the run is judged hung.
const CALL_LIMIT: Duration = Duration::from_secs(300);

/// Renames UUIDs (simulation ids) to `sim#N`, N by first appearance, and the server's own
/// directories (which refusals name) to `<workspace>`/`<data>`.
#[derive(Default)]
pub struct Ids {
    seen: HashMap<String, usize>,
    dirs: Vec<(String, &'static str)>,
}

impl Ids {
    /// Also renames `server`'s workspace and data directories, as given and as resolved (a
    /// node's workspace is a symlink).
    pub fn with_dirs_of(server: &crate::common::Server) -> Ids {
        Ids::with_dirs_of_all(&[server])
    }

    /// Also renames the workspace and data directories of every server of `servers` (the nodes
    /// one side's calls are spread over: each has its own data directory, and a refusal may
    /// name any of them).
    pub fn with_dirs_of_all(servers: &[&crate::common::Server]) -> Ids {
        let mut dirs = Vec::new();
        for server in servers {
            for (dir, name) in [(&server.workspace, "<workspace>"), (&server.data, "<data>")] {
                dirs.push((dir.display().to_string(), name));
                if let Ok(real) = dir.canonicalize() {
                    dirs.push((real.display().to_string(), name));
                }
            }
        }
        // Longest first, so a path is not half-replaced by a prefix of it.
        dirs.sort_by_key(|d| std::cmp::Reverse(d.0.len()));
        dirs.dedup();
        Ids { seen: HashMap::new(), dirs }
    }

    /// The same directory renaming with no ids seen yet (to compare logs, each renamed from its
    /// own first event).
    pub fn fresh(&self) -> Ids {
        Ids { seen: HashMap::new(), dirs: self.dirs.clone() }
    }

    /// `s` with every UUID in it renamed.
    pub fn text(&mut self, s: &str) -> String {
        let mut s = s.to_string();
        for (dir, name) in &self.dirs {
            s = s.replace(dir.as_str(), name);
        }
        let s = s.as_str();
        let mut out = String::with_capacity(s.len());
        let mut i = 0;
        while i < s.len() {
            let at_word_start = !s[..i].ends_with(|c: char| c.is_ascii_hexdigit() || c == '-');
            if let Some(id) = s.get(i..i + 36).filter(|c| is_uuid(c)) {
                let n = self.seen.len();
                let n = *self.seen.entry(id.to_ascii_lowercase()).or_insert(n);
                out.push_str(&format!("sim#{n}"));
                i += 36;
            } else if let Some((n, len)) = self.cut_id(&s[i..]).filter(|_| at_word_start) {
                out.push_str(&format!("sim#{n}"));
                i += len;
            } else {
                let c = s[i..].chars().next().unwrap();
                out.push(c);
                i += c.len_utf8();
            }
        }
        out
    }

    /// `v` with every UUID in its strings (and keys) renamed and `VOLATILE` fields dropped.
    pub fn value(&mut self, v: &Value) -> Value {
        match v {
            Value::String(s) => Value::String(self.text(s)),
            Value::Array(a) => Value::Array(a.iter().map(|x| self.value(x)).collect()),
            Value::Object(o) => Value::Object(
                o.iter().filter(|(k, _)| !VOLATILE.contains(&k.as_str())).map(|(k, x)| (self.text(k), self.value(x))).collect::<Map<_, _>>(),
            ),
            other => other.clone(),
        }
    }
}

impl Ids {
    /// A known id cut short where a summary was cut (`0d6b5595-f163-…`) at the start of `s`:
    /// its number and the length of the cut part.
    fn cut_id(&self, s: &str) -> Option<(usize, usize)> {
        let len = s.find(|c: char| !(c.is_ascii_hexdigit() || c == '-')).unwrap_or(s.len());
        if len < 8 || !s[len..].starts_with('…') {
            return None;
        }
        let part = s[..len].to_ascii_lowercase();
        self.seen.iter().find(|(id, _)| id.starts_with(&part)).map(|(_, &n)| (n, len))
    }
}

/// Whether `s` (36 characters) is a UUID in its textual form.
fn is_uuid(s: &str) -> bool {
    s.len() == 36
        && s.char_indices().all(|(i, c)| if matches!(i, 8 | 13 | 18 | 23) { c == '-' } else { c.is_ascii_hexdigit() })
}

/// How one side's calls reach its server or servers.
enum Via {
    /// One MCP session (2025-11-25): every call on it.
    Session(Client),
    /// One MCP session per node: call i goes to session i mod n, as a balancer spreading
    /// calls over nodes would send them.
    RoundRobin(Vec<Client>),
    /// Stateless 2026-07-28 requests over plain HTTP: call i goes to URL i mod n (one URL for
    /// a single server).
    Stateless { http: reqwest::Client, urls: Vec<String> },
}

/// One of the two servers (or groups of nodes): how it is called, its ids for the script's
/// simulation slots, its renaming.
pub struct Side {
    pub label: &'static str,
    via: Via,
    /// Calls sent so far (picks the next session or URL).
    sent: usize,
    /// Slot i of the script is simulation `sims[i]` on this server.
    pub sims: Vec<String>,
    pub ids: Ids,
}

impl Side {
    /// `server`'s side of the run (its directories renamed in what it says), through `client`.
    pub fn new(label: &'static str, server: &crate::common::Server, client: Client) -> Side {
        Side { label, via: Via::Session(client), sent: 0, sims: Vec::new(), ids: Ids::with_dirs_of(server) }
    }

    /// A side whose calls go round-robin over `clients` (one session on each of `servers`).
    pub fn round_robin(label: &'static str, servers: &[&crate::common::Server], clients: Vec<Client>) -> Side {
        assert!(!clients.is_empty());
        Side { label, via: Via::RoundRobin(clients), sent: 0, sims: Vec::new(), ids: Ids::with_dirs_of_all(servers) }
    }

    /// A side whose calls are stateless 2026-07-28 requests, round-robin over `servers`' URLs.
    pub fn stateless(label: &'static str, servers: &[&crate::common::Server]) -> Side {
        assert!(!servers.is_empty());
        let urls = servers.iter().map(|s| s.url.clone()).collect();
        Side { label, via: Via::Stateless { http: reqwest::Client::new(), urls }, sent: 0, sims: Vec::new(), ids: Ids::with_dirs_of_all(servers) }
    }

    /// The script's arguments with each `"$sim:N"` string replaced by this server's id of slot N.
    fn bind(&self, template: &Value) -> Value {
        match template {
            Value::String(s) => match s.strip_prefix("$sim:") {
                Some(n) => Value::String(self.sims[n.parse::<usize>().unwrap()].clone()),
                None => template.clone(),
            },
            Value::Array(a) => Value::Array(a.iter().map(|x| self.bind(x)).collect()),
            Value::Object(o) => Value::Object(o.iter().map(|(k, x)| (k.clone(), self.bind(x))).collect()),
            other => other.clone(),
        }
    }

    /// Makes the call (on the next session or URL of a round-robin side); a lost call fails
    /// the test (every server must stay up).
    async fn call(&mut self, tool: &str, template: &Value) -> Outcome {
        let n = self.sent;
        self.sent += 1;
        let args = self.bind(template);
        let (outcome, to) = match &self.via {
            Via::Session(c) => (attempt(c, tool, args, CALL_LIMIT).await, String::new()),
            Via::RoundRobin(cs) => (attempt(&cs[n % cs.len()], tool, args, CALL_LIMIT).await, format!(" (session {})", n % cs.len())),
            Via::Stateless { http, urls } => {
                let url = &urls[n % urls.len()];
                (attempt_stateless(http, url, n as u64 + 1, tool, args, CALL_LIMIT).await, format!(" (to {url})"))
            }
        };
        if let Outcome::Lost(e) = &outcome {
            panic!("{}: {tool} {template}{to} got no answer: {e}", self.label);
        }
        outcome
    }

    /// The outcome as compared: ok/refused, with ids renamed and volatile fields dropped;
    /// list_simulations' entries sorted by renamed id (servers may order them by raw id).
    fn normalise(&mut self, tool: &str, outcome: &Outcome) -> Value {
        match outcome {
            Outcome::Ok(v) => {
                let mut v = self.ids.value(v);
                if tool == "list_simulations" {
                    if let Some(list) = v.get_mut("simulations").and_then(Value::as_array_mut) {
                        list.sort_by_key(|s| s["simulation_id"].as_str().map(sort_key).unwrap_or_default());
                    }
                }
                serde_json::json!({"ok": v})
            }
            Outcome::Refused(e) => serde_json::json!({"refused": self.ids.text(e)}),
            Outcome::Lost(e) => serde_json::json!({"lost": e}),
        }
    }

    /// Registers the simulations a successful call made, in the order its reply names them.
    fn register(&mut self, tool: &str, outcome: &Outcome) {
        let Outcome::Ok(v) = outcome else { return };
        match tool {
            "create_simulation" | "fork_simulation" | "load_simulation" => {
                self.sims.push(v["simulation_id"].as_str().expect("simulation_id").to_string())
            }
            "run_sweep" => self.sims.extend(
                v["variants"].as_array().into_iter().flatten().filter_map(|x| x["simulation_id"].as_str()).map(str::to_string),
            ),
            _ => {}
        }
    }
}

/// `sim#12` sorts after `sim#3`.
fn sort_key(renamed: &str) -> (usize, String) {
    (renamed.strip_prefix("sim#").and_then(|n| n.parse().ok()).unwrap_or(usize::MAX), renamed.to_string())
}

/// Calls a difference report lists before the one that differed.
const RECENT: usize = 16;

/// The two servers, the calls made so far, and per tool how many were accepted and refused.
pub struct Lockstep {
    pub a: Side,
    pub b: Side,
    pub calls: usize,
    pub tally: BTreeMap<String, (usize, usize)>,
    /// The last `RECENT` calls (their templates, and server a's answer renamed), for a
    /// difference report.
    recent: VecDeque<String>,
}

impl Lockstep {
    pub fn new(a: Side, b: Side) -> Lockstep {
        Lockstep { a, b, calls: 0, tally: BTreeMap::new(), recent: VecDeque::new() }
    }

    /// Makes one call on both servers (slot placeholders bound per server), panics at the first
    /// reply that differs, and returns server a's outcome.
    pub async fn call(&mut self, tool: &str, template: Value) -> Outcome {
        let (oa, ob) = tokio::join!(self.a.call(tool, &template), self.b.call(tool, &template));
        let (na, nb) = (self.a.normalise(tool, &oa), self.b.normalise(tool, &ob));
        // The template names simulations by slot (`$sim:N`, the script's numbering).
        let args = &template;
        assert!(
            na == nb,
            "call #{} {tool} {args} differs:\n  {}: {}\n  {}: {}\nthe calls before it:\n{}",
            self.calls,
            self.a.label,
            na,
            self.b.label,
            nb,
            self.recent.iter().map(|c| format!("  {c}")).collect::<Vec<_>>().join("\n")
        );
        let mut said = na.to_string();
        if said.len() > 240 {
            said.truncate(said.char_indices().nth(240).map_or(said.len(), |(i, _)| i));
            said.push('…');
        }
        self.recent.push_back(format!("#{} {tool} {args} → {said}", self.calls));
        if self.recent.len() > RECENT {
            self.recent.pop_front();
        }
        self.a.register(tool, &oa);
        self.b.register(tool, &ob);
        assert_eq!(self.a.sims.len(), self.b.sims.len());
        self.calls += 1;
        let t = self.tally.entry(tool.to_string()).or_default();
        if matches!(oa, Outcome::Ok(_)) {
            t.0 += 1;
        } else {
            t.1 += 1;
        }
        oa
    }
}
