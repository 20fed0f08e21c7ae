//! Where a model's own files are found and read — the model, the meshes its collisions name,
//! an MJCF file's includes and meshes: in the workspace, or, for a built-in model, in the
//! library (`library`), each relative name resolved against the model's folder either way. A
//! workspace file wins over a built-in of the same name; a built-in's meshes and includes come
//! from the library only, so a built-in loads the same whatever the workspace holds.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::library::{self, Format};
use super::Reader;
use crate::value::Refusal;

/// The files of one model: the workspace's (through the request's reader) or the library's
/// (through the request's reader when there is a request, so each is read once within its
/// budget; directly when the server lists its models).
pub enum ModelFiles<'r> {
    /// A workspace model: canonical paths, sandboxed.
    Workspace(&'r mut Reader),
    /// A built-in model: library names as relative paths.
    Builtin(Option<&'r mut Reader>),
}

impl<'r> ModelFiles<'r> {
    /// Where the model `user` names is — the workspace file if there is one, else the built-in
    /// of that name — and its files. Refused, naming the nearest built-ins, when it is neither;
    /// a built-in of the other format names the tool that loads it.
    pub fn locate(reader: &'r mut Reader, user: &str, format: Format) -> Result<(ModelFiles<'r>, PathBuf), Refusal> {
        if let Some(path) = reader.sandbox().probe(user)? {
            return Ok((ModelFiles::Workspace(reader), path));
        }
        match library::model(user) {
            Some(f) if f == format => Ok((ModelFiles::Builtin(Some(reader)), PathBuf::from(user))),
            Some(other) => Err(library::wrong_tool(user, other)),
            None => Err(library::not_found(user, &reader.sandbox().missing(user))),
        }
    }

    /// The folder relative names start from: the workspace, or the library's top.
    pub fn root(&self) -> PathBuf {
        match self {
            ModelFiles::Workspace(reader) => reader.sandbox().workspace.clone(),
            ModelFiles::Builtin(_) => PathBuf::new(),
        }
    }

    /// The folder of the model file at `at`, which its relative names resolve against.
    pub fn folder(&self, at: &Path) -> PathBuf {
        at.parent().map(Path::to_path_buf).unwrap_or_else(|| self.root())
    }

    /// Where `candidate` is: Some(place to read) when a file is there, None when nothing is
    /// (a candidate to try the next of), refused when it is outside the workspace.
    pub fn probe(&self, candidate: &Path) -> Result<Option<PathBuf>, Refusal> {
        match self {
            ModelFiles::Workspace(reader) => reader.sandbox().probe(&candidate.display().to_string()),
            ModelFiles::Builtin(_) => Ok(library::name_of(candidate).filter(|n| library::contains(n)).map(PathBuf::from)),
        }
    }

    /// `probe` of a file that must be there: refused, saying so, when nothing is.
    pub fn existing(&self, candidate: &Path) -> Result<PathBuf, Refusal> {
        self.probe(candidate)?.ok_or_else(|| match self {
            ModelFiles::Workspace(reader) => reader.sandbox().missing(&candidate.display().to_string()),
            ModelFiles::Builtin(_) => format!("{} is not in the built-in library", candidate.display()),
        })
    }

    /// The bytes of a file `probe` found, at most `limit`; `shown` names it in refusals.
    pub fn read(&mut self, at: PathBuf, shown: &str, limit: u64) -> Result<Arc<Vec<u8>>, Refusal> {
        match self {
            ModelFiles::Workspace(reader) => reader.read_resolved(at, shown, limit).map(|(_, bytes)| bytes),
            ModelFiles::Builtin(reader) => {
                let name = library::name_of(&at).ok_or_else(|| format!("{shown} is not in the built-in library"))?;
                match reader {
                    Some(reader) => reader.read_builtin(&name, shown, limit),
                    None => {
                        let bytes = library::read(&name).ok_or_else(|| format!("{shown} is not in the built-in library"))?;
                        if bytes.len() as u64 > limit {
                            return Err(format!("{shown} is {} bytes; the limit is {limit}", bytes.len()));
                        }
                        Ok(Arc::new(bytes))
                    }
                }
            }
        }
    }
}
