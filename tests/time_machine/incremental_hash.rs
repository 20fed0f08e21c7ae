//! State hash v2 is kept incrementally (a Merkle tree over objects, updated only where a command
//! says it touched): after every event of every recorded log in `replays/`, folded under v2, the
//! kept hash equals the hash recomputed from nothing — and so does the hash of the world a
//! snapshot restores and of a batch's working copy. A command that changes an object without
//! saying so would fail here. (The recorded logs themselves keep state hash v1 and still verify:
//! `replays.rs`, `compat_v1.rs`.)

use std::collections::BTreeMap;

use physics_mcp::command::{BlobSource, Command};
use physics_mcp::limits::Limits;
use physics_mcp::log::fold;
use physics_mcp::log::sqlite::{Kind, Log};
use physics_mcp::world::{HashRules, World};

use crate::common::recorded_logs;

fn check(world: &World, what: &str) {
    assert_eq!(world.hash_rules(), HashRules::V2, "{what}");
    assert_eq!(world.state_hash(), world.state_hash_from_scratch(), "{what}: the kept hash drifted from a full recompute");
}

#[test]
fn after_every_event_of_every_recorded_log_the_kept_v2_hash_equals_a_full_recompute() {
    let limits = Limits::default();
    let mut events_checked = 0;
    for path in recorded_logs() {
        let log = Log::open_read_only(&path).unwrap();
        let blobs: &dyn BlobSource = &log;
        let events = physics_mcp::log::replay::events(&path).unwrap();
        // The world after each state-changing event, so branches and forks fold from their parent.
        let mut after: BTreeMap<u64, World> = BTreeMap::new();
        for e in events.iter().filter(|e| e.kind.is_state_changing() && e.ok) {
            let name = format!("{} seq {} ({})", path.file_name().unwrap().to_string_lossy(), e.seq, e.tool);
            let mut world = match e.parent.and_then(|p| after.get(&p)) {
                Some(parent) => parent.duplicate(),
                None => fold::create_root(e, blobs).unwrap().0.with_hash_rules(HashRules::V2),
            };
            // Ask once before the event, so the kept tree has something to be stale against.
            world.state_hash();
            if e.kind == Kind::Change || e.parent.is_some() {
                fold::fold_event(&mut world, e, blobs, &limits, false).unwrap_or_else(|err| panic!("{name}: {err}"));
            }
            check(&world, &name);
            // A snapshot restores under the same rules to the same hash.
            let restored = World::restore("restored", false, &world.snapshot()).unwrap();
            check(&restored, &format!("{name}, restored"));
            assert_eq!(restored.state_hash(), world.state_hash(), "{name}: restored");
            after.insert(e.seq, world);
            events_checked += 1;
        }
    }
    assert!(events_checked >= 200, "only {events_checked} events checked");
}

#[test]
fn old_chains_keep_v1_and_new_ones_record_v2() {
    // A root recorded before event version 5 folds under v1 (its recorded hashes were v1).
    let path = recorded_logs().into_iter().find(|p| p.ends_with("drop_and_stack.sqlite")).unwrap();
    let events = physics_mcp::log::replay::events(&path).unwrap();
    let log = Log::open_read_only(&path).unwrap();
    let root = events.iter().find(|e| e.kind == Kind::Root).unwrap();
    assert!(root.version < physics_mcp::command::STATE_HASH_V2_SINCE);
    let (old, _) = fold::create_root(root, &log).unwrap();
    assert_eq!(old.hash_rules(), HashRules::V1);
    assert_eq!(old.state_hash(), root.state_hash);
    // Its snapshots keep v1 too; a new world's carry v2.
    assert_eq!(World::restore("x", false, &old.snapshot()).unwrap().hash_rules(), HashRules::V1);
    let create = Command::CreateSimulation { simulation_id: "n".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) };
    let (new, _) = World::create(&create).unwrap();
    assert_eq!(new.hash_rules(), HashRules::V2);
    assert_ne!(new.state_hash(), old.state_hash(), "the same empty world hashes differently under v1 and v2");
    assert_eq!(World::restore("x", false, &new.snapshot()).unwrap().hash_rules(), HashRules::V2);
}
