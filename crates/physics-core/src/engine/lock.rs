//! The engine build as `Cargo.lock` fixes it: which locked crates are recorded, and how.
//!
//! Shared, as text functions, by this crate's build script (`build.rs` reads `Cargo.lock` and
//! writes [`crate::engine::ENGINE_BUILD`] with [`engine_map`] and [`encode`]) and by the unit
//! tests that hold the recorded build to the lock. Nothing here reads a file: the caller hands
//! in the lock's text, so the library stays a pure fold.

use std::collections::{BTreeMap, BTreeSet};

/// rapier3d's enabled features that can change what it computes, recorded after its version
/// in this order (the order is part of the recorded text, so keep it). `parallel` is enabled
/// but result-neutral ([`crate::engine::RESULT_NEUTRAL_FEATURES`]). A unit test holds this
/// list to the workspace manifest.
pub const RECORDED_RAPIER_FEATURES: &[&str] = &["serde-serialize", "enhanced-determinism"];

/// Crates of physics-core's locked dependency closure whose version cannot change a fold's
/// result, each with the reason; every other crate of the closure is recorded, so a crate new
/// to the lock counts as affecting results until it is listed here. When unsure, leave a
/// crate out of this list: a needless entry in the map only costs a warning on `replay`, a
/// missing one lets results change silently.
pub const RESULT_NEUTRAL_CRATES: &[(&str, &str)] = &[
    // Compile time only.
    ("proc-macro2", "proc-macro plumbing: passes derives' tokens through at compile time"),
    ("quote", "proc-macro plumbing: passes derives' tokens through at compile time"),
    ("syn", "proc-macro plumbing: parses derive input at compile time"),
    ("unicode-ident", "proc-macro plumbing: identifier characters for syn"),
    ("nalgebra-macros", "matrix!/vector! literals: the elements as written"),
    ("num-derive", "derives plain casts between parry3d's enums and integers"),
    ("rustversion", "compile-time conditions on the rustc version"),
    ("cfg-if", "compile-time conditions"),
    ("static_assertions", "compile-time assertions"),
    ("typenum", "type-level numbers for nalgebra's dimensions, resolved at compile time"),
    ("autocfg", "build-script probe of the compiler"),
    ("version_check", "build-script probe of the compiler"),
    ("rustc_version", "build-script probe of the compiler"),
    ("semver", "rustc_version's version parsing, in build scripts"),
    ("cc", "compiles blake3's C/assembly kernels, whose output BLAKE3 fixes (blake3 is recorded)"),
    ("find-msvc-tools", "cc's search for the MSVC toolchain"),
    ("shlex", "cc's command-line quoting"),
    // Scheduling and synchronisation: no values.
    ("rayon", "thread pool: the same bits for any thread count (tests/physics/threads.rs)"),
    ("rayon-core", "thread pool: the same bits for any thread count (tests/physics/threads.rs)"),
    ("crossbeam-deque", "rayon's work stealing: scheduling only"),
    ("crossbeam-epoch", "rayon's memory reclamation: scheduling only"),
    ("crossbeam-utils", "rayon's synchronisation primitives: scheduling only"),
    ("lock_api", "locks: synchronisation only"),
    ("scopeguard", "run-on-drop guards for lock_api"),
    ("spin", "spin locks for heapless: synchronisation only"),
    ("critical-section", "critical sections for atomic-polyfill: synchronisation only"),
    ("atomic-polyfill", "atomics for heapless on targets without them"),
    ("once_cell", "lazy statics: initialisation only"),
    ("futures-channel", "async plumbing (js-sys's): the fold is synchronous"),
    ("futures-core", "async plumbing (js-sys's): the fold is synchronous"),
    ("futures-io", "async plumbing (js-sys's): the fold is synchronous"),
    ("futures-macro", "async plumbing (js-sys's): the fold is synchronous"),
    ("futures-sink", "async plumbing (js-sys's): the fold is synchronous"),
    ("futures-task", "async plumbing (js-sys's): the fold is synchronous"),
    ("futures-util", "async plumbing (js-sys's): the fold is synchronous"),
    ("pin-project-lite", "async plumbing (js-sys's): the fold is synchronous"),
    // The platform: the fold reads no clock, randomness or OS state (clippy.toml).
    ("libc", "operating-system bindings"),
    ("android_system_properties", "operating-system bindings"),
    ("core-foundation-sys", "operating-system bindings"),
    ("r-efi", "operating-system bindings"),
    ("wasip2", "operating-system bindings"),
    ("wit-bindgen", "operating-system bindings"),
    ("windows-core", "operating-system bindings"),
    ("windows-implement", "operating-system bindings"),
    ("windows-interface", "operating-system bindings"),
    ("windows-link", "operating-system bindings"),
    ("windows-result", "operating-system bindings"),
    ("windows-strings", "operating-system bindings"),
    ("wasm-bindgen", "WebAssembly/JavaScript bindings"),
    ("wasm-bindgen-macro", "WebAssembly/JavaScript bindings"),
    ("wasm-bindgen-macro-support", "WebAssembly/JavaScript bindings"),
    ("wasm-bindgen-shared", "WebAssembly/JavaScript bindings"),
    ("js-sys", "WebAssembly/JavaScript bindings"),
    ("bumpalo", "arena allocator of wasm-bindgen's macros"),
    ("chrono", "dates for schemars' chrono schemas: the fold has no clock"),
    ("iana-time-zone", "time zones for chrono: the fold has no clock"),
    ("iana-time-zone-haiku", "time zones for chrono: the fold has no clock"),
    ("getrandom", "randomness: no result may depend on it at all, whatever its version"),
    ("cpufeatures", "CPU detection for blake3, which picks among kernels giving BLAKE3's bits"),
    // Descriptions and reports, not values.
    ("schemars", "JSON schemas of the tools: descriptions, not values"),
    ("schemars_derive", "JSON schemas of the tools: descriptions, not values"),
    ("serde_derive_internals", "schemars_derive's reading of serde attributes: schemas only"),
    ("dyn-clone", "schemars' cloning of boxed schema parts"),
    ("ref-cast", "schemars' reference casts"),
    ("ref-cast-impl", "schemars' reference casts"),
    ("log", "logging: messages, not values"),
    ("profiling", "profiler scopes in rapier: no-ops without a profiler feature"),
    ("profiling-procmacros", "profiler scopes in rapier: no-ops without a profiler feature"),
    ("anyhow", "error plumbing: carries the parsers' own messages (the parsers are recorded)"),
    ("thiserror", "error plumbing: Display from the crates' own message strings"),
    ("thiserror-impl", "error plumbing: Display from the crates' own message strings"),
    // Exact operations: every correct version gives the same answer.
    ("memchr", "exact byte search"),
    ("aho-corasick", "exact substring search for regex (regex is recorded)"),
    ("itoa", "exact decimal digits of integers"),
    ("byteorder", "exact byte-order conversions of integers"),
    ("bytemuck", "bit-for-bit casts between plain types"),
    ("zerocopy", "bit-for-bit casts between plain types"),
    ("zerocopy-derive", "bit-for-bit casts between plain types"),
    ("rawpointer", "pointer offsets for matrixmultiply's kernels (matrixmultiply is recorded)"),
    ("constant_time_eq", "blake3's constant-time comparison: a yes or no, no hash"),
    ("either", "a two-variant enum"),
    ("bitflags", "flag sets: exact bit operations"),
    ("downcast-rs", "type downcasts of parry3d's shapes"),
    ("equivalent", "a trait for hash-map key lookups"),
    ("allocator-api2", "the allocator trait of hashbrown"),
    ("stable_deref_trait", "a marker trait"),
    ("cobs", "postcard's COBS framing, which this crate does not use"),
    ("embedded-io", "postcard's embedded I/O traits, which this crate does not use"),
];

/// Whether `name` is listed in [`RESULT_NEUTRAL_CRATES`].
pub fn is_result_neutral(name: &str) -> bool {
    RESULT_NEUTRAL_CRATES.iter().any(|(neutral, _)| *neutral == name)
}

/// One `[[package]]` block of `Cargo.lock`: all this scan needs of it.
#[derive(Default)]
struct Package<'a> {
    name: &'a str,
    version: &'a str,
    /// Entries of its `dependencies = [...]`: `"name"`, or `"name version"` (with a source
    /// after it) when the lock holds several versions of that crate.
    dependencies: Vec<&'a str>,
}

/// The `[[package]]` blocks of a lock file. Cargo writes them one key a line and each
/// dependency on a line of its own, which is all this scan reads; any other table ends a block.
fn packages(lock: &str) -> Vec<Package<'_>> {
    let (mut packages, mut in_package, mut in_dependencies) = (Vec::<Package>::new(), false, false);
    for line in lock.lines().map(str::trim) {
        if in_dependencies {
            in_dependencies = line != "]";
            if let (true, Some(package)) = (in_dependencies, packages.last_mut()) {
                package.dependencies.push(line.trim_end_matches(',').trim_matches('"'));
            }
        } else if line == "[[package]]" {
            packages.push(Package::default());
            in_package = true;
        } else if line.starts_with('[') {
            in_package = false;
        } else if let (true, Some(package), Some((key, value))) = (in_package, packages.last_mut(), line.split_once(" = ")) {
            match key {
                "name" => package.name = value.trim_matches('"'),
                "version" => package.version = value.trim_matches('"'),
                "dependencies" => in_dependencies = value == "[",
                _ => {}
            }
        }
    }
    packages
}

/// The locked dependency closure of the workspace package `root`: every crate reached from its
/// `dependencies` (build and platform-specific ones included, as the lock lists them), with
/// each version of it the lock holds. Empty when the lock has no package `root`.
pub fn closure(lock: &str, root: &str) -> BTreeMap<String, BTreeSet<String>> {
    let packages = packages(lock);
    // A dependency entry is "name", or "name version (source)" when several versions are locked.
    let resolve = |entry: &str| -> Vec<&Package> {
        let mut words = entry.split(' ');
        let (name, version) = (words.next().unwrap_or_default(), words.next());
        packages.iter().filter(|p| p.name == name && version.is_none_or(|v| p.version == v)).collect()
    };
    let mut todo: Vec<&str> = packages.iter().filter(|p| p.name == root).flat_map(|p| p.dependencies.iter().copied()).collect();
    let mut seen = BTreeSet::new();
    while let Some(entry) = todo.pop() {
        for package in resolve(entry) {
            if seen.insert((package.name, package.version)) {
                todo.extend(package.dependencies.iter().copied());
            }
        }
    }
    let mut crates: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (name, version) in seen {
        crates.entry(name.to_owned()).or_default().insert(version.to_owned());
    }
    crates
}

/// The engine build a lock file fixes: every crate of physics-core's closure but the
/// [`RESULT_NEUTRAL_CRATES`], mapped to its locked version (several, sorted and joined by
/// `", "`, when the lock holds several), rapier3d's followed by its
/// [`RECORDED_RAPIER_FEATURES`] in parentheses. Fails when the lock has no physics-core or
/// its closure no rapier3d.
pub fn engine_map(lock: &str) -> Result<BTreeMap<String, String>, String> {
    let mut map: BTreeMap<String, String> = closure(lock, "physics-core")
        .into_iter()
        .filter(|(name, _)| !is_result_neutral(name))
        .map(|(name, versions)| (name, versions.into_iter().collect::<Vec<_>>().join(", ")))
        .collect();
    let rapier = map.get_mut("rapier3d").ok_or("Cargo.lock has no rapier3d among physics-core's dependencies")?;
    *rapier = format!("{rapier} ({})", RECORDED_RAPIER_FEATURES.join(", "));
    Ok(map)
}

/// The recorded text of an engine-build map: `name value` entries joined by `"; "`, rapier3d's
/// first and the rest sorted by name, e.g. `rapier3d 0.36.1 (serde-serialize,
/// enhanced-determinism); ahash 0.8.12; approx 0.5.1; …`. rapier3d first keeps the text
/// readable and makes the text recorded before the map (rapier3d alone) its prefix; sorting
/// makes it canonical, so one map has one text.
pub fn encode(map: &BTreeMap<String, String>) -> String {
    let rapier = map.get_key_value("rapier3d");
    let rest = map.iter().filter(|(name, _)| *name != "rapier3d");
    rapier.into_iter().chain(rest).map(|(name, value)| format!("{name} {value}")).collect::<Vec<_>>().join("; ")
}
