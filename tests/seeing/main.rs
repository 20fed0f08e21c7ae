//! Looking back at any moment of a run: trajectories, animations, the viewer's timeline and
//! live progress, the command line's pictures, and the viewer in a real browser (ignored in
//! plain `cargo test`; `.ci/run` runs it).

#[path = "../common/mod.rs"]
mod common;

mod animation;
mod app_in_host;
mod browser_3d;
mod browser_viewer;
mod cli_pictures;
mod host_harness;
mod mcap_export;
mod readable_pictures;
mod report_page;
mod trajectory;
mod viewer;
mod viewer_timeline;
