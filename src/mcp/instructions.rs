//! The server's `instructions` (sent once, at initialize): the conventions every tool shares,
//! said here once so that no tool description or parameter has to repeat them (each tool's
//! schema is read on every turn of an agent; these are read once).

/// What a model should know before calling any tool.
pub(crate) const INSTRUCTIONS: &str = "\
Deterministic rigid-body physics (rapier3d, f32). Conventions for every tool: SI units (m, kg, s, N, rad; \
angles in camera tools are degrees); world frame z-up; vectors are JSON arrays [x, y, z]; quaternions \
[x, y, z, w] (normalised on input); colors [r, g, b] or [r, g, b, a] in [0, 1]; sim_id is the UUID from \
create_simulation or list_simulations; object and constraint ids are integers from 0 in creation order; \
link_index -1 is the base. mass 0 = static; there is no implicit ground (add a static box or plane.urdf). \
Start: create_simulation, add bodies, step_simulation (1/240 s per step by default), read states. \
Every call is recorded in the simulation's event log (undo, redo, fork_simulation, get_history). \
Errors are one sentence with isError true and change nothing; an unknown parameter is refused. \
Replies are at most --max-reply-bytes (1 MiB): large results (ray_test_batch, get_camera_image, \
get_trajectory, render_animation) take output_path, a new file in the workspace. \
Resources: sim://{sim_id}/info, /history, /image.";
