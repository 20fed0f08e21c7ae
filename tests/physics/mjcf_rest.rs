//! No speed bought with bad physics: every Gymnasium model in tests/fixtures/mjcf,
//! loaded as load_mjcf loads it (its free base free, where it has one) in a world with gravity
//! −9.81 m/s² along z, is stepped for 10 s of simulated time at its own `<option timestep>`
//! (MuJoCo's 0.002 s when it names none) with nothing driving it. It comes to rest on its floor
//! (or hangs from its rail) and:
//!
//! - resting, it stays out of its floor: from its first second on (by then every model has
//!   landed), at every step, the deepest active contact point of a pair with a fixed collider
//!   (the floor, a rail; −distance of the point, rapier reporting a penetration as a negative
//!   distance) stays under 5 mm. The first second is left out because two models do not start
//!   resting: humanoidstandup's file pose has its arms 36 mm inside the floor (MuJoCo 4.0's own
//!   contacts at qpos0 say the same), and ant falls onto its legs, a 14 mm transient at its
//!   0.01 s step. The whole run's deepest floor contact and the deepest contact between two of
//!   the model's own bodies are printed beside (humanoid 6.4 mm, humanoidstandup 13.5 mm, whose
//!   limbs overlap in the file as in MuJoCo: 15 and 13 mm there);
//! - it gains no energy: its mechanical energy at the end is at most its energy at the start
//!   plus a tolerance. The energy is Σ over every dynamic body of ½·m·|v_com|² + ½·ωᵀ·I·ω
//!   (the body's inertia about its centre of mass, in world axes) + m·g·z_com, plus Σ over
//!   every multibody coordinate of ½·armature·q̇² (MJCF `armature` is a rotor inertia in joint
//!   space, added to the mass matrix's diagonal: part of the kinetic energy, not of any body's).
//!   Joint springs (`stiffness`) are not simulated (load_mjcf lists them in `ignored`), so they
//!   hold no energy here. The tolerance is the energy of raising the whole model by 1 mm
//!   (M·g·0.001): far below any physical gain that matters, above f32 round-off of a model at
//!   rest; the start is at rest, so any motion at the end must have been paid for by a fall.
//!
//! The world is driven through `World::apply` as the server does (load_mjcf, set_timestep,
//! step_simulation); an observer reads the narrow phase after every step. No clock is read.

use physics_mcp::command::Command;
use physics_mcp::world::World;

use crate::common::gymnasium::{fixture, model_timestep, MODELS};

const G: f32 = 9.81;
const SIMULATED_S: f64 = 10.0;
const MAX_PENETRATION_M: f32 = 0.005;
/// When the model is resting: after its first second (module doc).
const SETTLE_S: f64 = 1.0;

/// load_mjcf of `model` as the server records it today.
fn load_command(model: &str, bytes: &[u8], use_model_options: bool) -> Command {
    crate::common::mjcf_command::load_mjcf(&format!("{model}.xml"), bytes, use_model_options)
}

/// A fresh simulation (gravity −G along z) for `model`.
fn root(model: &str) -> Command {
    Command::CreateSimulation { simulation_id: model.into(), gravity: [0.0, 0.0, -G], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) }
}

fn loaded(model: &str, bytes: &[u8], dt: f64) -> World {
    let (mut w, _) = World::create(&root(model)).unwrap();
    let out = w.apply(&load_command(model, bytes, false), &mut |_| true);
    assert!(matches!(out, physics_mcp::outputs::Outcome::MjcfLoaded(_)), "{model} loads: {:?}", out.to_value());
    w.apply(&Command::SetTimestep { timestep: dt as f32, timestep_given: Some(dt) }, &mut |_| true);
    w
}

/// Mechanical energy (module doc), in f64 from the engine's f32 state.
fn energy(w: &World) -> f64 {
    let p = w.physics();
    let mut e = 0.0f64;
    for (_, b) in p.bodies.iter().filter(|(_, b)| b.is_dynamic()) {
        let m = b.mass() as f64;
        if m == 0.0 {
            continue; // the crate's massless spacers between a body's joints
        }
        let v = b.linvel();
        let com = b.center_of_mass();
        let local_w = b.rotation().inverse() * b.angvel();
        let inertia = b.mass_properties().local_mprops.reconstruct_inertia_matrix();
        let iw = inertia * local_w;
        e += 0.5 * m * v.length_squared() as f64 + 0.5 * local_w.dot(iw) as f64 + m * G as f64 * com.z as f64;
    }
    for mb in p.multibody_joints.multibodies() {
        let (qd, a) = (mb.generalized_velocity(), mb.armature());
        e += qd.iter().zip(a.iter()).map(|(v, a)| 0.5 * *a as f64 * (*v as f64).powi(2)).sum::<f64>();
    }
    e
}

/// The whole model's mass (kg).
fn total_mass(w: &World) -> f64 {
    w.physics().bodies.iter().filter(|(_, b)| b.is_dynamic()).map(|(_, b)| b.mass() as f64).sum()
}

/// The deepest active contact point now (m; 0 when nothing penetrates), with a floor: of a
/// pair with a fixed (the floor's) collider; else of two of the model's own bodies.
fn penetration(w: &World) -> (f32, f32) {
    let p = w.physics();
    let fixed = |c| p.colliders.get(c).and_then(|c| c.parent()).and_then(|b| p.bodies.get(b)).is_some_and(|b| b.is_fixed());
    let (mut floor, mut own) = (0.0f32, 0.0f32);
    for pair in p.narrow_phase.contact_pairs().filter(|p| p.has_any_active_contact()) {
        let deepest = pair.manifolds().iter().flat_map(|m| m.points.iter()).map(|pt| -pt.dist).fold(0.0f32, f32::max);
        if fixed(pair.collider1) || fixed(pair.collider2) {
            floor = floor.max(deepest);
        } else {
            own = own.max(deepest);
        }
    }
    (floor, own)
}

#[test]
fn every_gymnasium_model_rests_on_its_floor_without_penetrating_or_gaining_energy() {
    let mut failures = Vec::new();
    let mut report = Vec::new();
    for model in MODELS {
        let bytes = fixture(model);
        let dt = model_timestep(&bytes);
        let mut w = loaded(model, &bytes, dt);
        let steps = (SIMULATED_S / dt).round() as u64;
        let (e0, mass) = (energy(&w), total_mass(&w));
        let tolerance = mass * G as f64 * 0.001;
        let settled_from = (SETTLE_S / dt).round() as u64;
        let (mut deepest, mut deepest_at, mut resting, mut own) = (0.0f32, 0u64, 0.0f32, 0.0f32);
        let mut step = 0u64;
        w.apply_observed(&Command::step(steps), &mut |_| true, &mut |w| {
            step += 1;
            let (d, o) = penetration(w);
            if d > deepest {
                (deepest, deepest_at) = (d, step);
            }
            if step >= settled_from {
                resting = resting.max(d);
            }
            own = own.max(o);
        });
        assert_eq!(w.steps(), steps, "{model}: every step taken");
        let e1 = energy(&w);
        report.push(format!(
            "{model}: dt {dt}, {steps} steps, floor contact at rest {:.2} mm (deepest {:.2} mm at step {deepest_at}), self-contact {:.2} mm, energy {e0:.4} J -> {e1:.4} J (tolerance {tolerance:.4} J)",
            resting * 1e3,
            deepest * 1e3,
            own * 1e3
        ));
        if resting >= MAX_PENETRATION_M {
            failures.push(format!("{model} rests {:.2} mm deep in its floor", resting * 1e3));
        }
        if e1 > e0 + tolerance {
            failures.push(format!("{model} gains energy: {e0:.4} J -> {e1:.4} J"));
        }
    }
    println!("{}", report.join("\n"));
    assert!(failures.is_empty(), "{}\n{}", failures.join("\n"), report.join("\n"));
}


/// load_mjcf's `use_model_options`: pusher's `<option timestep="0.01" gravity="0 0 0">` becomes
/// the simulation's, as set_timestep would set it, and `ignored` says it is applied; without it
/// (and in events recorded before either flag existed, which decode with both false and
/// re-encode byte for byte) the simulation keeps its own.
#[test]
fn use_model_options_imposes_the_models_timestep_and_gravity_and_old_events_fold_as_before() {
    let bytes = fixture("pusher");
    let load = |use_model_options: bool| load_command("pusher", &bytes, use_model_options);
    let root = root("o");
    let ignored = |out: &physics_mcp::outputs::Outcome| out.to_value()["ignored"][0].as_str().unwrap().to_string();

    let (mut w, _) = World::create(&root).unwrap();
    let out = w.apply(&load(true), &mut |_| true);
    assert_eq!((w.timestep(), w.timestep_given(), w.gravity()), (0.01, 0.01, [0.0, 0.0, 0.0]));
    assert!(ignored(&out).ends_with("applied to the simulation (use_model_options)"), "{}", ignored(&out));
    w.apply(&Command::step(100), &mut |_| true);
    assert!((w.current_time() - 1.0).abs() < 1e-12, "100 steps of 0.01 s: {}", w.current_time());

    let (mut plain, _) = World::create(&root).unwrap();
    let out = plain.apply(&load(false), &mut |_| true);
    assert_eq!((plain.timestep(), plain.gravity()), (1.0 / 240.0, [0.0, 0.0, -G]));
    assert!(ignored(&out).ends_with("the simulation's own timestep and gravity apply"), "{}", ignored(&out));

    // An event as recorded before the flags: both decode as false and are left out again.
    let mut old = serde_json::to_value(load(false)).unwrap();
    old.as_object_mut().unwrap().remove("parent_filter");
    let decoded: Command = serde_json::from_value(old.clone()).unwrap();
    assert!(matches!(decoded, Command::LoadMjcf { parent_filter: false, use_model_options: false, .. }), "{old}");
    assert_eq!(serde_json::to_value(&decoded).unwrap(), old, "re-encodes byte for byte");
}
