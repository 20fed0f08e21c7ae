//! The tool adapters, one file per tool family: arguments (`crate::params`) → `Command` or
//! read → `Sim` → MCP result.

pub(crate) mod animation;
pub(crate) mod batch;
pub(crate) mod constraints;
pub(crate) mod dynamics;
pub(crate) mod files;
pub(crate) mod mjcf;
pub(crate) mod models;
pub(crate) mod objects;
pub(crate) mod persistence;
pub(crate) mod robots;
pub(crate) mod sensing;
pub(crate) mod simulations;
pub(crate) mod sweep;
pub(crate) mod timeline;
pub(crate) mod trajectory;
pub(crate) mod viewer;
