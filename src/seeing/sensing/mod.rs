//! The agent's senses: rays, contacts, camera matrices and images. All of it reads a world
//! and changes nothing, so it lives outside `world/` and may use threads.
//!
//! Rays and images are computed from the bodies' *current* poses (a `set_object_pose` is seen
//! at once, as PyBullet's rayTest sees a reset pose), not from rapier's broad phase, which is
//! only brought up to date by a step: `World::scene` (world/scene.rs) indexes them, once per
//! state. Contacts are the narrow phase's result of the last step.

pub mod camera;
pub mod contacts;
pub mod rays;
pub mod capture;
pub mod render;
pub mod shading;
