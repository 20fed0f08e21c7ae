//! Rules of the source tree that keep its promises checkable, read from the source itself: only
//! the files layer (`src/files/`) opens a user's path and only the log's storage
//! (`src/log/`) touches the data directory — no other server code calls the file system —
//! and the MJCF parser is reached only through the one function that refuses file-naming
//! elements first.

use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`.
fn sources(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(sources(&p));
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
    out.sort();
    out
}

/// The file's code without its unit tests and comments (what ships).
fn shipped(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    let code = text.split("#[cfg(test)]\nmod tests").next().unwrap_or("");
    code.lines().filter(|l| !l.trim_start().starts_with("//")).collect::<Vec<_>>().join("\n")
}

/// Calls that reach the file system.
const FILE_SYSTEM: &[&str] = &[
    "std::fs",
    "fs::",
    "File::open",
    "File::create",
    "File::options",
    "OpenOptions",
    "tempfile::",
    ".exists()",
    ".is_file()",
    ".is_dir()",
    ".canonicalize()",
    "read_link",
    "symlink_metadata",
    "metadata(",
    "Connection::open",
];

#[test]
fn only_the_files_layer_and_the_log_touch_the_file_system() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let allowed = [root.join("src/files"), root.join("src/log")];
    let mut found = Vec::new();
    for path in sources(&root.join("src")) {
        if allowed.iter().any(|a| path.starts_with(a)) {
            continue;
        }
        let code = shipped(&path);
        for (n, line) in code.lines().enumerate() {
            if let Some(call) = FILE_SYSTEM.iter().find(|c| line.contains(*c)) {
                found.push(format!("{}:{}: {call}: {}", path.strip_prefix(root).unwrap().display(), n + 1, line.trim()));
            }
        }
    }
    assert!(found.is_empty(), "file-system calls outside src/files and src/log:\n{}", found.join("\n"));
}

#[test]
fn the_deterministic_core_touches_no_file() {
    // Its build script reads Cargo.lock (the engine build); its library reads nothing.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut found = Vec::new();
    for path in sources(&root.join("crates/physics-core/src")) {
        for (n, line) in shipped(&path).lines().enumerate() {
            if let Some(call) = FILE_SYSTEM.iter().find(|c| line.contains(*c)) {
                found.push(format!("{}:{}: {call}", path.strip_prefix(root).unwrap().display(), n + 1));
            }
        }
    }
    assert!(found.is_empty(), "file-system calls in physics-core:\n{}", found.join("\n"));
    // rapier3d-mjcf reads mesh files itself through rapier3d-meshloader: it must stay out.
    let lock = std::fs::read_to_string(root.join("Cargo.lock")).unwrap();
    assert!(!lock.contains("name = \"rapier3d-meshloader\""), "rapier3d-meshloader is built: MJCF meshes would be read from disk");
}

#[test]
fn the_mjcf_parser_is_reached_only_through_parse_model() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut found = Vec::new();
    for path in sources(&root.join("src")).into_iter().chain(sources(&root.join("crates/physics-core/src"))) {
        for (n, line) in shipped(&path).lines().enumerate() {
            if ["Model::from_str", "Model::from_file", "MjcfRobot::from_file", "MjcfRobot::from_str", "load_from_path"].iter().any(|c| line.contains(c)) {
                found.push(format!("{}:{}", path.strip_prefix(root).unwrap().display(), n + 1));
            }
        }
    }
    assert_eq!(found.len(), 1, "the parser is called in more than one place: {found:?}");
    assert!(found[0].starts_with("crates/physics-core/src/world/mjcf.rs"), "{found:?}");
}
