//! The built-in models: files a load finds by name when the workspace has no such file, so an
//! agent loads `kuka_iiwa/model.urdf` or `mujoco/ant.xml` with no file of its own.
//!
//! Two sources. The basic assets (`plane.urdf`, `cube.urdf`, `sphere.urdf`, in `assets/`) are
//! compiled into this crate and always there. The model library (the `physics-models` crate:
//! pybullet_data's robots and props, Gymnasium's MuJoCo models) is an archive the binary hands
//! over at start ([`install`]), so test binaries that never install it link none of its bytes.
//!
//! A built-in is read like a workspace file (`Reader::read_builtin`: once per request, within
//! its byte budget) and its bytes go into the load event, so replay, undo and load never depend
//! on the library's version. Only the catalog's models load by name; the other files of the
//! library (meshes) are reached only from the model that names them, relative to its folder.

use std::collections::BTreeMap;
use std::path::{Component, Path, PathBuf};
use std::sync::OnceLock;

use physics_models::archive::{self, Packed};
use physics_models::catalog;

use crate::outputs::ModelListing;
use crate::value::Refusal;

/// The two model formats, by the tool that loads them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// `.urdf`: load_urdf.
    Urdf,
    /// `.xml`: load_mjcf.
    Mjcf,
}

impl Format {
    /// The format of a model file by its name.
    pub fn of(name: &str) -> Format {
        if name.ends_with(".xml") {
            Format::Mjcf
        } else {
            Format::Urdf
        }
    }

    /// "urdf" or "mjcf", as list_models says.
    pub fn name(self) -> &'static str {
        match self {
            Format::Urdf => "urdf",
            Format::Mjcf => "mjcf",
        }
    }

    /// The tool that loads it.
    pub fn tool(self) -> &'static str {
        match self {
            Format::Urdf => "load_urdf",
            Format::Mjcf => "load_mjcf",
        }
    }
}

/// The basic assets, built into this crate: name, text, description.
const BASIC: [(&str, &str, &str); 3] = [
    ("plane.urdf", include_str!("../../assets/plane.urdf"), "Static ground plane, 60 x 60 m, top at z = 0"),
    ("cube.urdf", include_str!("../../assets/cube.urdf"), "1 m cube, 1 kg"),
    ("sphere.urdf", include_str!("../../assets/sphere.urdf"), "Ball, radius 0.5 m, 1 kg"),
];

/// The basic assets' licence: they are this project's own.
const BASIC_LICENSE: &str = "MIT (physics-mcp)";

/// The installed library's files, still deflated, by name.
static LIBRARY: OnceLock<BTreeMap<&'static str, Packed<'static>>> = OnceLock::new();

/// Makes the model library `archive` (`physics_models::ARCHIVE`) the built-ins' second
/// source, for the rest of the process; refused if it is not an archive or one is installed.
pub fn install(archive: &'static [u8]) -> Result<(), String> {
    let files = archive::entries(archive)?;
    LIBRARY.set(files).map_err(|_| "a model library is already installed".to_string())
}

fn library() -> Option<&'static BTreeMap<&'static str, Packed<'static>>> {
    LIBRARY.get()
}

/// One model of the catalog: name, description, licence.
struct Entry {
    name: &'static str,
    description: &'static str,
    license: &'static str,
}

/// Every built-in model there is: the basic assets, then the installed library's catalog.
fn entries() -> Vec<Entry> {
    let basic = BASIC.iter().map(|(name, _, description)| Entry { name, description, license: BASIC_LICENSE });
    let installed = library().into_iter().flat_map(|files| {
        catalog::MODELS
            .iter()
            .filter(|m| files.contains_key(m.name))
            .map(|m| Entry { name: m.name, description: m.description, license: m.license })
    });
    basic.chain(installed).collect()
}

/// The format of built-in model `name`, if there is one of that name.
pub fn model(name: &str) -> Option<Format> {
    entries().iter().any(|e| e.name == name).then(|| Format::of(name))
}

/// The bytes of built-in file `name` (a model or a file a model names), if there is one.
pub fn read(name: &str) -> Option<Vec<u8>> {
    if let Some((_, text, _)) = BASIC.iter().find(|(n, _, _)| *n == name) {
        return Some(text.as_bytes().to_vec());
    }
    library()?.get(name)?.inflate()
}

/// Whether built-in file `name` exists (without inflating it).
pub fn contains(name: &str) -> bool {
    BASIC.iter().any(|(n, _, _)| *n == name) || library().is_some_and(|files| files.contains_key(name))
}

/// The library name a relative path stands for (`a/./b/../c.stl` → `a/c.stl`), or None if
/// it is absolute or climbs out of the library.
pub fn name_of(path: &Path) -> Option<String> {
    let mut parts: Vec<String> = Vec::new();
    for c in path.components() {
        match c {
            Component::Normal(p) => parts.push(p.to_str()?.to_string()),
            Component::CurDir => {}
            Component::ParentDir => {
                parts.pop()?;
            }
            Component::RootDir | Component::Prefix(_) => return None,
        }
    }
    (!parts.is_empty()).then(|| parts.join("/"))
}

/// The refusal of a model file that is neither in the workspace nor built in: the nearest
/// built-ins, and how to add a file of one's own. `missing` is the sandbox's sentence.
pub fn not_found(user: &str, missing: &str) -> Refusal {
    let near = nearest(user);
    let hint = match near.as_slice() {
        [] => String::new(),
        [one] => format!("; did you mean {one} (built in)?"),
        more => format!("; did you mean {} (built in)?", more.join(" or ")),
    };
    format!(
        "{missing} and is not a built-in model{hint} list_models lists the built-ins; write_file puts a file of your own in the workspace",
        hint = if hint.is_empty() { ";".to_string() } else { hint }
    )
}

/// The refusal of a built-in model given to the other format's tool.
pub fn wrong_tool(user: &str, format: Format) -> Refusal {
    format!("file_path {user} is a built-in {} model: load it with {}", format.name().to_uppercase(), format.tool())
}

/// Up to three built-in models nearest `user`: same file name first (`ant.xml` →
/// `mujoco/ant.xml`), then names containing its stem (`kuka.urdf` → `kuka_iiwa/model.urdf`),
/// then names within a small edit distance — only the best of these kinds that has any, so a
/// clear match is not diluted by look-alikes (`kuka.urdf` names no `cube.urdf`).
fn nearest(user: &str) -> Vec<String> {
    let user = user.to_lowercase();
    let base = user.rsplit('/').next().unwrap_or(&user).to_string();
    let stem = base.split('.').next().unwrap_or("").to_string();
    let mut scored: Vec<(u8, usize, &'static str)> = entries()
        .iter()
        .filter_map(|e| {
            let name = e.name.to_lowercase();
            let distance = crate::params::edit_distance(&user, &name);
            let rank = if name.rsplit('/').next() == Some(base.as_str()) {
                0
            } else if stem.len() >= 3 && name.contains(&stem) {
                1
            } else if distance <= (name.len() / 4).max(3) {
                2
            } else {
                return None;
            };
            Some((rank, distance, e.name))
        })
        .collect();
    scored.sort();
    let best = scored.first().map(|(rank, _, _)| *rank);
    scored.into_iter().filter(|(rank, _, _)| Some(*rank) == best).take(3).map(|(_, _, name)| name.to_string()).collect()
}

/// What a listing needs from the files layer: the load command of a built-in model, files
/// read from the library (`urdf::builtin_command`, `mjcf::builtin_command`).
type CommandOf = fn(&str) -> Result<crate::command::Command, Refusal>;

/// Every built-in model with what a load of it builds, in the library's order. Worked out once
/// per process (each model built in a world of its own), then served from memory.
pub fn listing() -> Result<&'static [ModelListing], Refusal> {
    static LISTING: OnceLock<Result<Vec<ModelListing>, Refusal>> = OnceLock::new();
    let listed = LISTING.get_or_init(|| {
        entries()
            .iter()
            .map(|e| {
                let format = Format::of(e.name);
                let command_of: CommandOf = match format {
                    Format::Urdf => super::urdf::builtin_command,
                    Format::Mjcf => super::mjcf::builtin_command,
                };
                let facts = command_of(e.name)
                    .and_then(|command| crate::world::facts::model_facts(&command))
                    .map_err(|why| format!("Internal error: built-in model {} does not load: {why}", e.name))?;
                Ok(ModelListing {
                    name: e.name.to_string(),
                    format: format.name().to_string(),
                    joints: facts.joints,
                    dofs: facts.dofs,
                    mass: crate::value::r32(facts.mass as f32),
                    fixed_base: facts.fixed_base,
                    description: e.description.to_string(),
                    license: e.license.to_string(),
                })
            })
            .collect()
    });
    listed.as_deref().map_err(Clone::clone)
}

/// The listing's models that match `filter` (any case, in name, format, description or
/// licence); all of them without one.
pub fn matching(filter: Option<&str>) -> Result<Vec<ModelListing>, Refusal> {
    let filter = filter.map(str::to_lowercase).unwrap_or_default();
    Ok(listing()?
        .iter()
        .filter(|m| [&m.name, &m.format, &m.description, &m.license].iter().any(|f| f.to_lowercase().contains(&filter)))
        .cloned()
        .collect())
}

/// The folder of the library a built-in model's own files are looked up in.
pub fn folder_of(name: &str) -> PathBuf {
    Path::new(name).parent().map(Path::to_path_buf).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn library_names_are_relative_paths_that_stay_inside() {
        assert_eq!(name_of(Path::new("kuka_iiwa/./meshes/../meshes/link_0.stl")).as_deref(), Some("kuka_iiwa/meshes/link_0.stl"));
        assert_eq!(name_of(Path::new("../x.stl")), None);
        assert_eq!(name_of(Path::new("/etc/passwd")), None);
        assert_eq!(name_of(Path::new("")), None);
    }

    #[test]
    fn a_missing_file_names_the_nearest_basic_assets() {
        let why = not_found("plane100.urdf", "file_path plane100.urdf does not exist in the workspace /w");
        assert!(why.contains("did you mean plane.urdf (built in)?"), "{why}");
        assert!(why.contains("write_file"), "{why}");
        let none = not_found("zzzzzzzzzzzzzz.urdf", "file_path zzzzzzzzzzzzzz.urdf does not exist in the workspace /w");
        assert!(!none.contains("did you mean"), "{none}");
    }
}
