//! Packs the library: every file under `models/` (the committed source files) and the models
//! `catalog::ELSEWHERE` names, deflated into `OUT_DIR/models.bin` (`archive` format), which
//! the crate embeds. Fails the build if a model of the catalog has no file.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[path = "src/archive.rs"]
#[allow(dead_code)]
mod archive;
#[path = "src/catalog.rs"]
#[allow(dead_code)]
mod catalog;

/// Every file under `dir`, by its path below `root` with `/` separators.
fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<String, PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .map(|e| e.expect("a directory entry").path())
        .collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            walk(root, &path, out);
        } else {
            let rel = path.strip_prefix(root).expect("below the root");
            let name = rel.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect::<Vec<_>>().join("/");
            out.insert(name, path);
        }
    }
}

fn main() {
    let here = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let models = here.join("models");
    println!("cargo::rerun-if-changed={}", models.display());
    println!("cargo::rerun-if-changed=src/catalog.rs");
    let mut files = BTreeMap::new();
    walk(&models, &models, &mut files);
    for (folder, elsewhere) in catalog::ELSEWHERE {
        let dir = here.join(elsewhere);
        for model in catalog::MODELS.iter().filter_map(|m| m.name.strip_prefix(folder)) {
            let path = dir.join(model);
            println!("cargo::rerun-if-changed={}", path.display());
            files.insert(format!("{folder}{model}"), path);
        }
    }
    for m in catalog::MODELS {
        assert!(files.contains_key(m.name), "the catalog names {}, which is not in the library", m.name);
    }
    let bytes: BTreeMap<String, Vec<u8>> = files
        .into_iter()
        .map(|(name, path)| {
            let b = std::fs::read(&path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
            (name, b)
        })
        .collect();
    let packed = archive::write(&bytes, 10).unwrap_or_else(|e| panic!("cannot pack the library: {e}"));
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR")).join("models.bin");
    std::fs::write(&out, packed).unwrap_or_else(|e| panic!("cannot write {}: {e}", out.display()));
}
