//! physics-mcp's built-in model library: pybullet_data's robots and props and Gymnasium's
//! MuJoCo models, loadable by name with no file of one's own (`load_urdf("kuka_iiwa/model.urdf")`,
//! `load_mjcf("mujoco/ant.xml")`).
//!
//! The library is data: the committed files under `models/` (and the Gymnasium fixtures,
//! `catalog::ELSEWHERE`) are deflated at build time into one archive embedded here
//! ([`ARCHIVE`]), so a binary carries it wherever it is installed and nothing is read from the
//! source tree at run time. The server's files layer reads it (`physics_mcp::files::library`)
//! and puts a model's bytes into the load event like a workspace file's.
//!
//! Only the `physics-mcp` binary refers to [`ARCHIVE`] (it hands it to the files layer at
//! start), so test binaries that never do link no model bytes; [`archive`] and [`catalog`]
//! are plain code and tables.
//!
//! To add a model: put its file and the meshes its collisions name under `models/` at the
//! name it loads under, add a [`catalog::Model`], and its licence to NOTICE.

pub mod archive;
pub mod catalog;

/// The library: every model file, deflated (`archive` format).
pub static ARCHIVE: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/models.bin"));
