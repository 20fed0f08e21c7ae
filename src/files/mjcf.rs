//! The adapter side of MJCF models: reading the main file and its `<include>`s from the
//! workspace (the world never reads files). Includes are spliced at XML level — each
//! `<include file=…/>` element is replaced by the children of the included file's `<mujoco>`
//! root, as MuJoCo does — so the event carries one self-contained MJCF text. Include paths
//! resolve relative to the main file's folder (MuJoCo's rule) and go through the sandbox.
//! The meshes the model's geoms use are read too (relative to the main file's folder and its
//! `<compiler meshdir/assetdir>`, sandboxed, within the URDF mesh limit) and travel in the
//! event as blobs, keyed by their `<mesh file>`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::command::{Blob, Command};
use crate::files::library::Format;
use crate::files::model_files::ModelFiles;
use crate::files::Reader;
use crate::params;
use crate::files::urdf::{MAX_MESH_BYTES, MAX_URDF_BYTES};
use crate::value::{self, Refusal};

/// Most nested include levels followed (a cycle is refused before this).
const MAX_INCLUDE_DEPTH: usize = 16;

/// The text of an MJCF file (or include), within what is left of the model's byte budget.
fn read_text(files: &mut ModelFiles, path: PathBuf, shown: &str, budget: &mut u64) -> Result<String, Refusal> {
    // The limit is the model's with its includes: what is left of it.
    let bytes = files.read(path, shown, *budget)?;
    *budget -= bytes.len() as u64;
    String::from_utf8(bytes.to_vec()).map_err(|_| format!("{shown} is not an MJCF model: it is not UTF-8 text"))
}

/// Refuses what the server cannot resolve into the event: a sub-model in another file
/// (`<asset><model file>`, which the parser would read itself), named by its element. The
/// elements that name files are the core's (`world::mjcf::file_reference`), which every fold
/// checks too.
fn refuse_unresolvable(text: &str, shown: &str) -> Result<(), Refusal> {
    match crate::world::mjcf::file_references(text).into_iter().find(|r| r.tag != "include") {
        Some(r) => Err(format!(
            "{shown} uses <asset><model file=\"{}\">: sub-models in other files are not supported; paste the sub-model's bodies into the model (or <include> them)",
            r.file
        )),
        None => Ok(()),
    }
}

/// The text with every `<include>` replaced by the included file's content, recursively.
fn splice(files: &mut ModelFiles, text: &str, shown: &str, dir: &Path, chain: &mut Vec<PathBuf>, budget: &mut u64) -> Result<String, Refusal> {
    crate::world::xml_guard::check(text, shown)?;
    let doc = roxmltree::Document::parse(text).map_err(|e| format!("{shown} is not well-formed XML: {e}"))?;
    refuse_unresolvable(text, shown)?;
    let mut includes: Vec<(std::ops::Range<usize>, String)> = Vec::new();
    for n in doc.descendants().filter(|n| n.is_element() && n.tag_name().name() == "include") {
        if n.children().any(|c| c.is_element()) {
            return Err(format!("{shown} has an <include> with elements inside it; an <include> must be empty"));
        }
        includes.push((n.range(), n.attribute("file").unwrap_or("").to_string()));
    }
    if includes.is_empty() {
        return Ok(text.to_string());
    }
    if chain.len() > MAX_INCLUDE_DEPTH {
        return Err(format!("{shown}: includes nest deeper than {MAX_INCLUDE_DEPTH} levels"));
    }
    let mut out = String::with_capacity(text.len());
    let mut at = 0;
    for (range, file) in includes {
        if file.is_empty() {
            return Err(format!("{shown} has an <include> without a file attribute"));
        }
        let candidate = dir.join(&file);
        let path = files
            .existing(&candidate)
            .map_err(|why| format!("include {file} of {shown} cannot be read: {why}"))?;
        if chain.contains(&path) {
            return Err(format!("include {file} of {shown} includes itself (a cycle)"));
        }
        let inner_shown = format!("include {file}");
        let inner_text = read_text(files, path.clone(), &inner_shown, budget)?;
        chain.push(path);
        let inner = splice(files, &inner_text, &inner_shown, dir, chain, budget)?;
        chain.pop();
        let inner_doc = roxmltree::Document::parse(&inner).map_err(|e| format!("include {file} is not well-formed XML: {e}"))?;
        let root = inner_doc.root_element();
        if root.tag_name().name() != "mujoco" {
            return Err(format!("include {file} is not an MJCF file: its root element is <{}>, not <mujoco>", root.tag_name().name()));
        }
        let children: Vec<roxmltree::Node> = root.children().collect();
        let body = match (children.first(), children.last()) {
            (Some(a), Some(b)) => &inner[a.range().start..b.range().end],
            _ => "",
        };
        out.push_str(&text[at..range.start]);
        out.push_str(body);
        at = range.end;
    }
    out.push_str(&text[at..]);
    Ok(out)
}

/// Builds load_mjcf's command from its arguments (as a loaded file's object entry gives them).
pub fn decide_load_mjcf(reader: &mut Reader, a: &value::Args) -> Result<Command, Refusal> {
    load_mjcf_command(reader, &params::parse("load_mjcf", a)?)
}

/// Builds load_mjcf's command: the MJCF text, its includes spliced in, and its meshes travel
/// in it; every file is read through `reader` (once per request). The model is the
/// workspace's file of that name, else the built-in model of that name (`library`).
pub fn load_mjcf_command(reader: &mut Reader, p: &params::LoadMjcf) -> Result<Command, Refusal> {
    let user = p.file_path.0.clone();
    let (files, at) = ModelFiles::locate(reader, &user, Format::Mjcf)?;
    let mut command = mjcf_command(files, at, &user)?;
    if let Command::LoadMjcf { position, orientation, fixed_base, keyframe, use_model_options, .. } = &mut command {
        *position = p.position.as_ref().map_or([0.0; 3], |v| v.0);
        *orientation = p.orientation.as_ref().map_or([0.0, 0.0, 0.0, 1.0], |q| q.0);
        *fixed_base = p.use_fixed_base.as_ref().is_some_and(|b| b.0);
        *keyframe = p.keyframe.as_ref().map(|k| k.0.clone());
        *use_model_options = p.use_model_options.as_ref().is_some_and(|b| b.0);
    }
    Ok(command)
}

/// load_mjcf's command for built-in model `name` at the origin, its base as the file says
/// (what list_models describes), read from the library alone.
pub fn builtin_command(name: &str) -> Result<Command, Refusal> {
    mjcf_command(ModelFiles::Builtin(None), PathBuf::from(name), name)
}

/// The command loading the MJCF model at `at` among `files` (at the origin, no keyframe, the
/// simulation's own options), its includes and meshes read from the same files.
fn mjcf_command(mut files: ModelFiles, at: PathBuf, user: &str) -> Result<Command, Refusal> {
    let dir = files.folder(&at);
    let mut budget = MAX_URDF_BYTES;
    let shown = format!("file_path {user}");
    let text = read_text(&mut files, at.clone(), &shown, &mut budget)?;
    let mut chain = vec![at];
    let spliced = splice(&mut files, &text, &shown, &dir, &mut chain, &mut budget)?;
    let meshes = read_meshes(&mut files, &spliced, &dir, user)?;
    Ok(Command::LoadMjcf {
        file_path: user.to_string(),
        mjcf: Blob::new(spliced.into_bytes()),
        meshes,
        position: [0.0; 3],
        orientation: [0.0, 0.0, 0.0, 1.0],
        fixed_base: false,
        keyframe: None,
        parent_filter: true,
        use_model_options: false,
        actuators: true,
        constraints: true,
        ball_joints_and_pairs: true,
        parsed: Default::default(),
    })
}

/// Every mesh file the model's geoms use, read through the sandbox within the URDF mesh limit
/// (their total), by the `<mesh file>` written in the model.
fn read_meshes(files: &mut ModelFiles, xml: &str, dir: &Path, user: &str) -> Result<BTreeMap<String, Blob>, Refusal> {
    let mut meshes = BTreeMap::new();
    let mut total = 0u64;
    for (file, path) in crate::world::mjcf_mesh::mesh_files(xml, dir) {
        let shown = format!("mesh {file} of {user}");
        let path = files
            .existing(&path)
            .map_err(|why| format!("{shown} cannot be read: {why}"))?;
        let bytes = files.read(path, &shown, MAX_MESH_BYTES.saturating_sub(total))?;
        total += bytes.len() as u64;
        meshes.insert(file, Blob::from_shared(bytes));
    }
    Ok(meshes)
}
