//! Seeing a simulation: sensing (rays, contacts, camera), trajectories, animations, the
//! session report and the web viewer.

pub mod animation;
pub mod framing;
pub mod overlay;
pub mod report;
pub mod sensing;
pub mod style;
pub mod trajectory;
pub mod viewer;
