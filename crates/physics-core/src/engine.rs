//! Which engine build computes the worlds: recorded with every root event (docs/log-format.md
//! "Compatibility of logs and files"), so `replay` of a log made by another build can say so,
//! naming the crates that differ, before any hash disagrees.
//!
//! An engine build is a map from crate to version: every crate of physics-core's locked
//! dependency closure whose version can change a fold's result (rapier3d, parry3d, nalgebra,
//! the URDF/MJCF/mesh parsers, serde_json, postcard, blake3, …), with rapier3d's
//! result-affecting features. Recorded builds are compared as maps, never as text.
//!
//! The map is a constant, not read at run time: this crate's build script takes the versions
//! from `Cargo.lock` when the crate is compiled (`lock` holds the rules it applies and the
//! crates it leaves out, each with the reason). Unit tests hold it to `Cargo.lock` and the
//! workspace manifest.

pub mod lock;

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Which arithmetic a world's engine steps with, chosen when the simulation is created and
/// kept for its life: recorded in its root (`Command::CreateSimulation`'s `engine_rule`, absent
/// before rule 2 existed), carried by its snapshots, inherited by its forks and loads (which
/// fold or restore the parent's chain). A new rule may change results in the last bits; every
/// older rule stays in this build, bit for bit, so every recorded log folds as it did
/// (docs/log-format.md "The engine rule"). Recorded as its number.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(try_from = "u32", into = "u32")]
pub enum EngineRule {
    /// rapier3d 0.36.1's own arithmetic, unpatched: every simulation created before rule 2
    /// (roots without `engine_rule`).
    Upstream = 1,
    /// Multibodies' joint-space dynamics over their tree (the vendored rapier's
    /// `MultibodyDynamics::TreeSparse`, crates/rapier3d/PATCHES.md patch 1); everything else as
    /// rule 1. Since event version 6.
    TreeMultibody = 2,
    /// Rule 2 with each multibody's mass matrices factorised once per step instead of once per
    /// substep (the vendored rapier's `MultibodyDynamics::TreeSparsePerStep`, PATCHES.md patch
    /// 3); free accelerations still per substep; everything else as rule 2. Since event version 9.
    TreeMultibodyPerStep = 3,
    /// Rule 3 with the one-step forces the step loop writes (MJCF actuators' joint efforts and
    /// torque-control motors' torques before a step, the clearing of every one-step force after
    /// it; apply_force and apply_torque still mark their body) written to an awake or
    /// non-dynamic body without marking it modified (the vendored rapier's
    /// `RigidBodySet::one_step_forces`, PATCHES.md patch 8). A marked body makes the next step
    /// rebuild the solver's caches (contact graph, body table, joint colouring) instead of
    /// reusing them, and the rebuilt order rounds differently; the forces are the same. Since
    /// event version 10.
    QuietStepForces = 4,
}

/// The rule new simulations are created under.
pub const ENGINE_RULE: EngineRule = EngineRule::QuietStepForces;

impl EngineRule {
    /// The rule of a root that recorded `recorded` (None: recorded before rules were, rule 1).
    pub fn of_root(recorded: Option<EngineRule>) -> EngineRule {
        recorded.unwrap_or(EngineRule::Upstream)
    }

    /// How the engine computes multibodies under this rule.
    pub fn multibody_dynamics(self) -> rapier3d::dynamics::MultibodyDynamics {
        match self {
            EngineRule::Upstream => rapier3d::dynamics::MultibodyDynamics::Dense,
            EngineRule::TreeMultibody => rapier3d::dynamics::MultibodyDynamics::TreeSparse,
            EngineRule::TreeMultibodyPerStep | EngineRule::QuietStepForces => rapier3d::dynamics::MultibodyDynamics::TreeSparsePerStep,
        }
    }

    /// Whether one-step forces on an awake or non-dynamic body leave it unmarked (rule 4).
    pub fn quiet_step_forces(self) -> bool {
        self >= EngineRule::QuietStepForces
    }
}

impl TryFrom<u32> for EngineRule {
    type Error = String;

    /// A recorded rule number; one this build does not know is refused, naming it.
    fn try_from(n: u32) -> Result<EngineRule, String> {
        match n {
            1 => Ok(EngineRule::Upstream),
            2 => Ok(EngineRule::TreeMultibody),
            3 => Ok(EngineRule::TreeMultibodyPerStep),
            4 => Ok(EngineRule::QuietStepForces),
            n => Err(format!("engine_rule {n} is not known to this build (it knows 1, 2, 3 and 4)")),
        }
    }
}

impl From<EngineRule> for u32 {
    fn from(rule: EngineRule) -> u32 {
        rule as u32
    }
}

/// The engine build of this binary, as recorded in `engine` of every new root event: the
/// text [`lock::encode`] makes of [`lock::engine_map`] of the workspace's `Cargo.lock`,
/// written by `build.rs` when this crate is compiled — `name version` entries joined by
/// `"; "`, rapier3d first with its features in parentheses, then the other crates sorted by
/// name (several locked versions of one crate joined by `", "`):
/// `rapier3d 0.36.1 (serde-serialize, enhanced-determinism); RustyXML 0.3.0; ahash 0.8.12; …`.
/// rapier's `parallel` (on since `--threads`) is not named: the same bits come out for any
/// thread count and with or without it — `tests/physics/threads.rs` holds every `replays/` log and
/// three scenes on 1, 2 and 4 threads to hashes the build without it recorded — so naming it
/// would only make `replay` warn about every older log.
pub const ENGINE_BUILD: &str = include_str!(concat!(env!("OUT_DIR"), "/engine_build.txt"));

/// rapier3d features that are enabled but do not change what it computes, so
/// [`ENGINE_BUILD`] leaves them out (see there).
pub const RESULT_NEUTRAL_FEATURES: &[&str] = &["parallel"];

/// The build that wrote every root event recorded before builds were recorded: roots without
/// one read as this. It is also the whole text builds recorded before the crate map (rapier3d
/// alone), so both read as the map [`build_map`] gives it. Fixed forever, whatever
/// `ENGINE_BUILD` becomes.
pub const UNRECORDED_ENGINE_BUILD: &str = "rapier3d 0.36.1 (serde-serialize, enhanced-determinism)";

/// What `Cargo.lock` held for the other recorded crates while builds were recorded as rapier3d
/// alone (frozen from the lock of that time, never to be updated): a recorded text naming
/// rapier3d alone reads as its own entry plus these, so a log written then does not warn on
/// the build that wrote it. Logs older than the MJCF parsers or older locks read the same; their
/// recorded hashes (all of `replays/` replays) show their folds agree.
pub const PRE_MAP_LOCK: &[(&str, &str)] = &[
    ("RustyXML", "0.3.0"),
    ("ahash", "0.8.12"),
    ("approx", "0.5.1"),
    ("arrayvec", "0.7.8"),
    ("blake3", "1.8.7"),
    ("ena", "0.14.4"),
    ("foldhash", "0.2.0"),
    ("glam", "0.30.10, 0.31.1, 0.32.1, 0.33.12"),
    ("glamx", "0.3.1"),
    ("hash32", "0.2.1, 0.3.1"),
    ("hashbrown", "0.16.1, 0.17.1"),
    ("heapless", "0.7.17, 0.8.0"),
    ("indexmap", "2.14.2"),
    ("libm", "0.2.16"),
    ("matrixmultiply", "0.3.11"),
    ("mjcf-rs", "0.36.1"),
    ("nalgebra", "0.35.0"),
    ("num-bigint", "0.4.8"),
    ("num-complex", "0.4.6"),
    ("num-integer", "0.1.47"),
    ("num-rational", "0.4.2"),
    ("num-traits", "0.2.19"),
    ("ordered-float", "5.5.1"),
    ("parry3d", "0.31.1"),
    ("postcard", "1.1.3"),
    ("quick-xml", "0.39.4"),
    ("rapier3d-mjcf", "0.36.1"),
    ("regex", "1.13.1"),
    ("regex-automata", "0.4.18"),
    ("regex-syntax", "0.8.11"),
    ("robust", "1.2.0"),
    ("roxmltree", "0.20.0"),
    ("rstar", "0.13.1"),
    ("safe_arch", "1.2.0"),
    ("serde", "1.0.229"),
    ("serde-xml-rs", "0.6.0"),
    ("serde_arrays", "0.2.0"),
    ("serde_core", "1.0.229"),
    ("serde_derive", "1.0.229"),
    ("serde_json", "1.0.154"),
    ("simba", "0.10.2"),
    ("slab", "0.4.12"),
    ("smallvec", "1.16.5"),
    ("spade", "2.15.1"),
    ("stl_io", "0.11.0"),
    ("tobj", "4.0.5"),
    ("urdf-rs", "0.9.1"),
    ("wide", "1.7.1"),
    ("xml-rs", "0.8.29"),
    ("zmij", "1.0.23"),
];

/// The build a root event was made by: its recorded one, or [`UNRECORDED_ENGINE_BUILD`] for a
/// root written before builds were recorded.
pub fn engine_build_of(recorded: Option<&str>) -> &str {
    recorded.unwrap_or(UNRECORDED_ENGINE_BUILD)
}

/// A recorded engine build read as the map it stands for (crate → version, rapier3d's with
/// its features), so builds are compared as maps: entry order and how the text was written
/// do not matter. A text naming rapier3d alone was recorded before the map and reads as that
/// entry plus [`PRE_MAP_LOCK`].
pub fn build_map(recorded: &str) -> BTreeMap<String, String> {
    let entry = |e: &str| {
        let (name, value) = e.split_once(' ').unwrap_or((e, ""));
        (name.to_owned(), value.to_owned())
    };
    let mut map: BTreeMap<String, String> = recorded.split("; ").filter(|e| !e.is_empty()).map(entry).collect();
    if map.len() == 1 && map.contains_key("rapier3d") {
        map.extend(PRE_MAP_LOCK.iter().map(|(name, version)| (name.to_string(), version.to_string())));
    }
    map
}

/// One crate whose version differs between a recorded engine build and this binary's, for
/// `replay`'s warning and its `--json` output.
#[derive(Serialize, Debug, Clone, PartialEq, Eq)]
pub struct CrateDifference {
    /// The crate.
    #[serde(rename = "crate")]
    pub name: String,
    /// Its version in the recorded build (rapier3d's with its features); `None`: not in it.
    pub recorded: Option<String>,
    /// Its version in this binary's build; `None`: not in it.
    pub this: Option<String>,
}

impl std::fmt::Display for CrateDifference {
    /// `crate: recorded → this binary`, a side without the crate shown as `absent`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let side = |v: &Option<String>| v.clone().unwrap_or_else(|| "absent".into());
        write!(f, "{}: {} → {}", self.name, side(&self.recorded), side(&self.this))
    }
}

/// Whether this build's rapier3d (`version (features)` as recorded) computes everything a build
/// recording `recorded` computed, bit for bit: the same release and features, and a patch
/// level at least as high. The vendored rapier is versioned `<release>+pmcp.<N>`
/// (crates/rapier3d/PATCHES.md): patch level N of that release; the release itself is level 0.
/// Every patch keeps the arithmetic of the levels before it as an engine rule
/// ([`EngineRule`]), so a log recorded by an older level folds here exactly as it did there —
/// the rule beside the map (docs/log-format.md "The engine build").
pub fn rapier_covers(recorded: &str, this: &str) -> bool {
    // "0.36.1+pmcp.2 (serde-serialize, …)" → ("0.36.1", 2, "(serde-serialize, …)").
    let parse = |v: &str| -> Option<(String, u32, String)> {
        let (version, features) = v.split_once(' ').unwrap_or((v, ""));
        let (release, level) = match version.split_once("+pmcp.") {
            Some((release, level)) => (release, level.parse().ok()?),
            None if !version.contains('+') => (version, 0),
            None => return None,
        };
        Some((release.to_owned(), level, features.to_owned()))
    };
    match (parse(recorded), parse(this)) {
        (Some((r_release, r_level, r_features)), Some((t_release, t_level, t_features))) => {
            r_release == t_release && r_features == t_features && r_level <= t_level
        }
        _ => recorded == this,
    }
}

/// The crates whose versions differ between two recorded builds, read as maps
/// ([`build_map`]), sorted by name; empty when they are the same build. rapier3d counts as
/// the same when `this` covers `recorded` ([`rapier_covers`]).
pub fn differences(recorded: &str, this: &str) -> Vec<CrateDifference> {
    let (mut recorded, mut this) = (build_map(recorded), build_map(this));
    let mut names: Vec<String> = recorded.keys().chain(this.keys()).cloned().collect();
    names.sort();
    names.dedup();
    names
        .into_iter()
        .filter_map(|name| {
            let (r, t) = (recorded.remove(&name), this.remove(&name));
            let same = match (&r, &t) {
                (Some(r), Some(t)) if name == "rapier3d" => rapier_covers(r, t),
                _ => r == t,
            };
            (!same).then_some(CrateDifference { name, recorded: r, this: t })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    const LOCK: &str = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../../Cargo.lock"));

    /// The version in `ENGINE_BUILD` is the one `Cargo.lock` resolves rapier3d to, and the
    /// text starts readable: rapier3d, its version and features.
    #[test]
    fn engine_build_names_the_locked_rapier_version() {
        let versions = &lock::closure(LOCK, "physics-core")["rapier3d"];
        assert_eq!(versions.len(), 1, "one rapier3d in the lock");
        let version = versions.first().unwrap();
        let features = lock::RECORDED_RAPIER_FEATURES.join(", ");
        assert!(
            ENGINE_BUILD.starts_with(&format!("rapier3d {version} ({features}); ")),
            "ENGINE_BUILD {ENGINE_BUILD:?} does not start with the locked rapier3d {version}"
        );
    }

    /// The rapier3d features recorded are exactly those the workspace manifest enables, but
    /// those that compute the same bits.
    #[test]
    fn engine_build_names_the_enabled_rapier_features() {
        let manifest = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../../Cargo.toml"));
        let line = manifest
            .lines()
            .find(|l| l.starts_with("rapier3d = "))
            .expect("the workspace manifest names rapier3d");
        let features = line.split("features = [").nth(1).and_then(|f| f.split(']').next()).unwrap_or("");
        let named = |f: &&str| !f.is_empty() && !RESULT_NEUTRAL_FEATURES.contains(f);
        let enabled: BTreeSet<&str> = features.split(',').map(|f| f.trim().trim_matches('"')).filter(named).collect();
        let recorded: BTreeSet<&str> = lock::RECORDED_RAPIER_FEATURES.iter().copied().collect();
        assert_eq!(enabled, recorded, "rapier3d's enabled features against RECORDED_RAPIER_FEATURES");
    }

    /// Completeness: every crate of physics-core's locked dependency closure is either in this
    /// binary's recorded build, at its locked version(s), or listed result-neutral with a
    /// reason — never both, and the neutral list names no crate the lock no longer has.
    #[test]
    fn every_crate_of_the_closure_is_recorded_or_listed_neutral() {
        let closure = lock::closure(LOCK, "physics-core");
        assert!(closure.len() > 50 && closure.contains_key("parry3d"), "{closure:?}");
        let recorded = build_map(ENGINE_BUILD);
        let neutral: BTreeSet<&str> = lock::RESULT_NEUTRAL_CRATES.iter().map(|(name, _)| *name).collect();
        assert_eq!(neutral.len(), lock::RESULT_NEUTRAL_CRATES.len(), "a crate listed neutral twice");
        for (name, versions) in &closure {
            let locked = versions.iter().cloned().collect::<Vec<_>>().join(", ");
            match (recorded.get(name), neutral.contains(name.as_str())) {
                (Some(_), true) => panic!("{name} is both recorded and listed result-neutral"),
                (None, false) => panic!("{name} {locked} is in Cargo.lock but neither recorded nor listed result-neutral"),
                (Some(version), false) => assert!(
                    version == &locked || (name == "rapier3d" && version.starts_with(&format!("{locked} ("))),
                    "{name} is recorded as {version}, locked as {locked}"
                ),
                (None, true) => {}
            }
        }
        let stale: Vec<&&str> = neutral.iter().filter(|n| !closure.contains_key(**n)).collect();
        assert!(stale.is_empty(), "listed result-neutral but no longer in the lock: {stale:?}");
        let foreign: Vec<&String> = recorded.keys().filter(|n| !closure.contains_key(*n)).collect();
        assert!(foreign.is_empty(), "recorded but not in the lock: {foreign:?}");
    }

    /// A crate the lock gains counts as affecting results (it is recorded) until it is listed
    /// result-neutral; a neutral one is left out; several locked versions are all recorded.
    #[test]
    fn a_new_crate_is_recorded_until_listed_neutral() {
        let lock = r#"
version = 4

[[package]]
name = "physics-core"
version = "0.1.0"
dependencies = [
 "brand-new",
 "log",
 "rapier3d",
 "twice 1.0.0",
 "twice 2.0.0 (registry+https://github.com/rust-lang/crates.io-index)",
]

[[package]]
name = "rapier3d"
version = "9.0.0"
source = "registry+https://github.com/rust-lang/crates.io-index"
dependencies = [
 "deep",
]

[[package]]
name = "deep"
version = "0.1.0"

[[package]]
name = "brand-new"
version = "0.2.0"

[[package]]
name = "log"
version = "0.4.0"

[[package]]
name = "twice"
version = "1.0.0"

[[package]]
name = "twice"
version = "2.0.0"

[[package]]
name = "unrelated"
version = "1.0.0"

[[patch.unused]]
name = "ignored"
version = "1.0.0"
"#;
        let map = lock::engine_map(lock).unwrap();
        let features = lock::RECORDED_RAPIER_FEATURES.join(", ");
        assert_eq!(
            lock::encode(&map),
            format!("rapier3d 9.0.0 ({features}); brand-new 0.2.0; deep 0.1.0; twice 1.0.0, 2.0.0")
        );
        assert!(lock::engine_map("").is_err(), "a lock without physics-core or rapier3d is refused");
    }

    /// The recorded text is canonical: encoding the map it reads as gives it back.
    #[test]
    fn engine_build_is_the_canonical_text_of_its_map() {
        assert_eq!(lock::encode(&build_map(ENGINE_BUILD)), ENGINE_BUILD);
    }

    /// Roots written before builds were recorded, and roots that recorded rapier3d alone, read
    /// as the build of their time: rapier3d 0.36.1 with the frozen lock. That is this build
    /// as long as `Cargo.lock` changes no recorded crate: if a bump makes this fail, old logs
    /// now warn on `replay` (as they should), and docs/log-format.md wants a newly recorded log in
    /// `replays/`; then assert the differences here instead.
    #[test]
    fn unrecorded_roots_read_as_the_build_of_their_time() {
        assert_eq!(engine_build_of(None), UNRECORDED_ENGINE_BUILD);
        assert_eq!(engine_build_of(Some("x")), "x");
        assert_eq!(build_map(UNRECORDED_ENGINE_BUILD).len(), PRE_MAP_LOCK.len() + 1);
        assert_eq!(differences(UNRECORDED_ENGINE_BUILD, ENGINE_BUILD), vec![]);
    }

    /// A patched rapier (`<release>+pmcp.<N>`) reads builds of the release and of lower patch
    /// levels as its own — it keeps their arithmetic as engine rules — but not the reverse,
    /// nor another release or other features.
    #[test]
    fn a_patched_rapier_covers_the_release_and_lower_levels() {
        let f = "(serde-serialize, enhanced-determinism)";
        let v = |v: &str| format!("{v} {f}");
        assert!(rapier_covers(&v("0.36.1"), &v("0.36.1+pmcp.1")));
        assert!(rapier_covers(&v("0.36.1+pmcp.1"), &v("0.36.1+pmcp.2")));
        assert!(rapier_covers(&v("0.36.1+pmcp.1"), &v("0.36.1+pmcp.1")));
        assert!(!rapier_covers(&v("0.36.1+pmcp.1"), &v("0.36.1")));
        assert!(!rapier_covers(&v("0.36.1+pmcp.2"), &v("0.36.1+pmcp.1")));
        assert!(!rapier_covers(&v("0.35.0"), &v("0.36.1+pmcp.1")));
        assert!(!rapier_covers("0.36.1 (serde-serialize)", &v("0.36.1+pmcp.1")));
        assert!(!rapier_covers(&v("0.36.1+other.1"), &v("0.36.1+pmcp.1")));
        // In the map: no difference from a log of the release, one for a newer patch level.
        let this = format!("rapier3d {}; a 1.0.0", v("0.36.1+pmcp.1"));
        assert_eq!(differences(&format!("rapier3d {}; a 1.0.0", v("0.36.1")), &this), vec![]);
        let newer = differences(&format!("rapier3d {}; a 1.0.0", v("0.36.1+pmcp.2")), &this);
        assert_eq!(newer.len(), 1, "{newer:?}");
    }

    /// Builds are compared as maps: a difference names the crate with both versions, a crate
    /// only one side has is `absent` on the other, and the order of entries does not matter.
    #[test]
    fn differences_name_the_crates_that_differ() {
        let this = "rapier3d 1.0.0 (f); a 1.0.0; b 2.0.0";
        assert_eq!(differences("rapier3d 1.0.0 (f); b 2.0.0; a 1.0.0", this), vec![]);
        let found = differences("rapier3d 1.0.0 (f); a 0.9.0; c 3.0.0", this);
        let shown: Vec<String> = found.iter().map(ToString::to_string).collect();
        assert_eq!(shown, ["a: 0.9.0 → 1.0.0", "b: absent → 2.0.0", "c: 3.0.0 → absent"]);
        // A text naming rapier3d alone reads as the frozen lock: only rapier3d differs here.
        let old = differences("rapier3d 0.35.0 (serde-serialize, enhanced-determinism)", ENGINE_BUILD);
        assert_eq!(old.len(), 1, "{old:?}");
        assert_eq!(old[0].name, "rapier3d");
    }
}
