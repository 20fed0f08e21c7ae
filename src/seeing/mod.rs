//! Seeing a simulation: sensing (rays, contacts, camera), trajectories, animations, the
//! session report, the web viewer and the MCAP export for Foxglove.

pub mod animation;
pub mod fit;
pub mod foxglove;
pub mod framing;
pub mod measure;
pub mod overlay;
pub mod report;
pub mod sensing;
pub mod style;
pub mod trajectory;
pub mod viewer;
