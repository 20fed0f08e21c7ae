//! Gymnasium's MuJoCo models among the fixtures (`tests/fixtures/mjcf`; mesh_robot.xml is ours,
//! not one of them): one list, and one way to read a model and its timestep, for the rest test,
//! the MJCF benchmark and the rapier-only reproduction (which includes this file by path, so it
//! uses only std and roxmltree).

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

/// The model's file (`<stem>.xml`) as bytes (for the root package's tests and benches).
pub fn fixture(model: &str) -> Vec<u8> {
    std::fs::read(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/mjcf").join(format!("{model}.xml"))).unwrap()
}

/// The model's `<option timestep>`, MuJoCo's default 0.002 s when it names none.
pub fn model_timestep(bytes: &[u8]) -> f64 {
    let doc = roxmltree::Document::parse(std::str::from_utf8(bytes).unwrap()).unwrap();
    doc.descendants().find(|n| n.has_tag_name("option")).and_then(|n| n.attribute("timestep")).map_or(0.002, |t| t.trim().parse().unwrap())
}
