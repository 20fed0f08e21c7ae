//! Snapshots per chain stay ≤ 100 + ⌈log2 events⌉ over a long history, and the history still
//! verifies, recovers and undoes exactly after thinning.

use physics_mcp::command::{Command, Shape};
use physics_mcp::limits::Limits;
use physics_mcp::sim::{lock_sim, Registry, SNAPSHOT_EVERY_CHANGES};
use physics_mcp::value::Args;

#[test]
fn a_long_history_keeps_a_logarithmic_number_of_snapshots() {
    let dir = tempfile::tempdir().unwrap();
    let config = crate::common::config(dir.path());
    let reg = Registry::open(config.clone()).unwrap();
    let root = Command::CreateSimulation { simulation_id: "long".into(), gravity: [0.0, 0.0, 0.0], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) };
    reg.create(root, &Args::new()).unwrap();
    let shared = reg.get("long").unwrap();
    let mut sim = lock_sim(&shared);
    let (a, l) = (Args::new(), Limits::default());
    let add = Command::AddBody {
        shape: Shape::Sphere { radius: 0.1 },
        position: [0.0, 0.0, 0.0],
        orientation: [0.0, 0.0, 0.0, 1.0],
        mass: 1.0,
        color: None,
        collides: true,
    };
    sim.change("add_sphere", &a, Ok(add), &l, &mut |_| true).unwrap();
    let n = (SNAPSHOT_EVERY_CHANGES as u64) * 140;
    let mut hashes = Vec::new();
    for i in 0..n {
        let v = Command::SetObjectVelocity { object_id: 0, linear_velocity: Some([i as f32, 0.0, 0.0]), angular_velocity: None };
        sim.change("set_object_velocity", &a, Ok(v), &l, &mut |_| true).unwrap();
        hashes.push(sim.state_hash().to_string());
    }
    let head = sim.log().head_seq();
    let snaps = sim.log().chain_snapshot_seqs(head).unwrap();
    let bound = 100 + ((head as f64).log2().ceil() as usize);
    assert!(snaps.len() > 100, "thinning test needs more than 100 snapshots taken");
    assert!(snaps.len() <= bound, "{} snapshots on the chain, bound {bound}", snaps.len());
    // Any point is still reachable exactly: undo far back, then forward again.
    let back = 5000;
    let u = sim.undo(&a, back).unwrap();
    assert_eq!(u.state_hash, hashes[hashes.len() - 1 - back as usize]);
    sim.redo(&a, back).unwrap();
    assert_eq!(sim.state_hash(), hashes.last().unwrap());
    assert!(sim.verify().unwrap().ok);
    drop(sim);
    drop(shared);
    drop(reg);
    let reg = Registry::open(config).unwrap();
    assert_eq!(lock_sim(&reg.get("long").unwrap()).state_hash(), hashes.last().unwrap());
}
