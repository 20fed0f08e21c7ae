//! What a model is, read off the robot the engine builds from it: joints (as PyBullet counts
//! them, or one per MJCF hinge/slide), degrees of freedom, moving mass and whether its base
//! stands fixed. For the built-in model list (`list_models`): the figures are the server's own
//! reading of the file — what a load of it gives — not a second parser's.

use crate::command::Command;
use crate::limits::Limits;
use crate::value::Refusal;

use super::World;

/// A model's figures as the engine builds it (loaded at the origin, its base as the file says).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelFacts {
    /// Joints: fixed ones included for a URDF (PyBullet's count), one per hinge/slide for MJCF.
    pub joints: usize,
    /// Joints that move (one degree of freedom each).
    pub dofs: usize,
    /// Mass of every body that moves (kg): a fixed base, and an MJCF model's worldbody
    /// (its floor), do not count.
    pub mass: f64,
    /// Whether the base stands fixed when loaded as is (`use_fixed_base` false): a URDF base of
    /// mass 0, an MJCF model whose top body has no free joint.
    pub fixed_base: bool,
}

/// The figures of the model `load` (a load_urdf or load_mjcf command, files read) describes:
/// built in a world of its own, which is then dropped.
pub fn model_facts(load: &Command) -> Result<ModelFacts, Refusal> {
    if !matches!(load, Command::LoadUrdf { .. } | Command::LoadMjcf { .. }) {
        return Err("model facts are read from a load_urdf or load_mjcf command".into());
    }
    let root = Command::CreateSimulation { simulation_id: "model-facts".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(crate::engine::ENGINE_RULE) };
    let (mut world, _) = World::create(&root).ok_or("Internal error: no world for the model")?;
    let load = load.clone().ready()?;
    load.validate(&world, &Limits::unbounded())?;
    world.apply(&load, &mut |_| true);
    let (_, object) = world.objects().next().ok_or("Internal error: the model was not built")?;
    let robot = object.kind.robot().ok_or("Internal error: the model is not a robot")?;
    let bodies = &world.physics().bodies;
    let moving = std::iter::once(object.body).chain(robot.links.iter().map(|l| l.body));
    // A fold from +0, not `sum` (which starts at −0.0 and would report a static model's −0).
    let mass = moving.filter_map(|h| bodies.get(h)).filter(|b| b.is_dynamic()).fold(0.0, |m, b| m + f64::from(b.mass()));
    Ok(ModelFacts {
        joints: robot.links.len(),
        dofs: robot.movable().len(),
        mass,
        fixed_base: bodies.get(object.body).is_some_and(|b| b.is_fixed()),
    })
}
