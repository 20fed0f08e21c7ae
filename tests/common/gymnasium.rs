//! Gymnasium's MuJoCo models among the fixtures (`tests/fixtures/mjcf`; mesh_robot.xml is ours,
//! not one of them): one list for the rest test and the MJCF benchmark.

/// The models' file stems.
pub const MODELS: [&str; 11] = [
    "ant",
    "half_cheetah",
    "hopper",
    "humanoid",
    "humanoidstandup",
    "inverted_double_pendulum",
    "inverted_pendulum",
    "pusher",
    "reacher",
    "swimmer",
    "walker2d",
];
