//! Which physics engine build computes the worlds: recorded with every root event (SPEC
//! "Compatibility of logs and files"), so `replay` of a log made by another build can say so
//! before any hash disagrees.
//!
//! It is a constant, not read at run time: the rapier version and its features are fixed when
//! this crate is compiled. A unit test holds it to `Cargo.lock` and the workspace manifest, so
//! a dependency bump that forgets it fails the tests.

/// The engine build of this binary: the rapier3d crate, its version and the features that can
/// change what it computes. rapier's `parallel` (on since `--threads`) is not named: the same
/// bits come out for any thread count and with or without it — `tests/threads.rs` holds every
/// `replays/` log and three scenes on 1, 2 and 4 threads to hashes the build without it
/// recorded — so naming it would only make `replay` warn about every older log.
pub const ENGINE_BUILD: &str = "rapier3d 0.36.1 (serde-serialize, enhanced-determinism)";

/// rapier3d features that are enabled but do not change what it computes, so
/// [`ENGINE_BUILD`] leaves them out (see there).
pub const RESULT_NEUTRAL_FEATURES: &[&str] = &["parallel"];

/// The build that wrote every root event recorded before builds were recorded: roots without
/// one read as this. Fixed forever, whatever `ENGINE_BUILD` becomes.
pub const UNRECORDED_ENGINE_BUILD: &str = "rapier3d 0.36.1 (serde-serialize, enhanced-determinism)";

/// The build a root event was made by: its recorded one, or [`UNRECORDED_ENGINE_BUILD`] for a
/// root written before builds were recorded.
pub fn engine_build_of(recorded: Option<&str>) -> &str {
    recorded.unwrap_or(UNRECORDED_ENGINE_BUILD)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The version in `ENGINE_BUILD` is the one `Cargo.lock` resolves rapier3d to.
    #[test]
    fn engine_build_names_the_locked_rapier_version() {
        let lock = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../../Cargo.lock"));
        let block = lock
            .split("[[package]]")
            .find(|b| b.contains("\nname = \"rapier3d\"\n"))
            .expect("rapier3d is in Cargo.lock");
        let version = block
            .lines()
            .find_map(|l| l.strip_prefix("version = \""))
            .and_then(|v| v.strip_suffix('"'))
            .expect("rapier3d has a version in Cargo.lock");
        assert!(
            ENGINE_BUILD.starts_with(&format!("rapier3d {version} (")),
            "ENGINE_BUILD {ENGINE_BUILD:?} does not name the locked rapier3d {version}"
        );
    }

    /// Every rapier3d feature the workspace manifest enables is named in `ENGINE_BUILD`, but
    /// those that compute the same bits.
    #[test]
    fn engine_build_names_the_enabled_rapier_features() {
        let manifest = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../../Cargo.toml"));
        let line = manifest
            .lines()
            .find(|l| l.starts_with("rapier3d = "))
            .expect("the workspace manifest names rapier3d");
        let features = line.split("features = [").nth(1).and_then(|f| f.split(']').next()).unwrap_or("");
        let named = |f: &&str| !f.is_empty() && !RESULT_NEUTRAL_FEATURES.contains(f);
        for feature in features.split(',').map(|f| f.trim().trim_matches('"')).filter(named) {
            assert!(ENGINE_BUILD.contains(feature), "ENGINE_BUILD {ENGINE_BUILD:?} does not name rapier3d's {feature:?}");
        }
    }

    /// Roots written before builds were recorded read as the build that wrote them, which is
    /// this one as long as rapier is not bumped.
    #[test]
    fn unrecorded_roots_read_as_the_build_of_their_time() {
        assert_eq!(engine_build_of(None), UNRECORDED_ENGINE_BUILD);
        assert_eq!(engine_build_of(Some("x")), "x");
        assert_eq!(ENGINE_BUILD, UNRECORDED_ENGINE_BUILD);
    }
}
