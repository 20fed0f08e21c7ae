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

/// Lines of shipped code under `src/` (outside `skip`) that contain any of `needles`.
fn found_in_src(skip: &[&str], needles: &[&str]) -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let skip: Vec<PathBuf> = skip.iter().map(|s| root.join(s)).collect();
    let mut found = Vec::new();
    for path in sources(&root.join("src")) {
        if skip.iter().any(|s| path.starts_with(s)) {
            continue;
        }
        for (n, line) in shipped(&path).lines().enumerate() {
            if needles.iter().any(|c| line.contains(c)) {
                found.push(format!("{}:{}: {}", path.strip_prefix(root).unwrap().display(), n + 1, line.trim()));
            }
        }
    }
    found
}

#[test]
fn nothing_below_the_mcp_layer_imports_it() {
    // lib.rs declares the module; main.rs runs the transports.
    let found = found_in_src(&["src/mcp", "src/main.rs", "src/lib.rs"], &["crate::mcp", "physics_mcp::mcp", "super::mcp"]);
    assert!(found.is_empty(), "code below src/mcp imports it:\n{}", found.join("\n"));
}

#[test]
fn one_path_applies_commands_to_a_live_world_and_one_folds_logged_events() {
    // World::apply is reached through `fold::apply` alone (where a change's result is
    // computed, measures included), which the live path and the fold of logged events share.
    let found = found_in_src(&[], &[".apply(", ".apply_observed("]);
    let mut places: Vec<&str> = found.iter().map(|f| f.split(':').next().unwrap()).collect();
    places.dedup();
    assert_eq!(places, ["src/log/fold.rs"], "World::apply is called from:\n{}", found.join("\n"));
    let found = found_in_src(&["src/log"], &["fold::apply("]);
    let places: Vec<&str> = found.iter().map(|f| f.split(':').next().unwrap()).collect();
    assert_eq!(places, ["src/sim/apply.rs"], "fold::apply is called from:\n{}", found.join("\n"));
}

#[test]
fn the_log_is_used_through_its_trait() {
    // Outside src/log, only the code that creates, opens, publishes and deletes a
    // simulation's log names its SQLite backend.
    let found: Vec<String> = found_in_src(&["src/log", "src/sim/mod.rs", "src/sim/timeline.rs"], &["Log"])
        .into_iter()
        .filter(|line| names_word(line.split_once(": ").map_or("", |(_, code)| code), "Log"))
        .collect();
    assert!(found.is_empty(), "the SQLite backend used directly:\n{}", found.join("\n"));
    let lifecycle = found_in_src(&["src/log"], &["Log::open", "Log::create"]);
    assert!(lifecycle.len() <= 5, "{}", lifecycle.join("\n"));
}

/// Whether `code` holds `word` as a whole identifier.
fn names_word(code: &str, word: &str) -> bool {
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    code.match_indices(word).any(|(i, _)| {
        let before = code[..i].chars().next_back();
        let after = code[i + word.len()..].chars().next();
        !before.is_some_and(ident) && !after.is_some_and(ident)
    })
}
