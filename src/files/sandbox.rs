//! The path sandbox: every user-supplied file path resolves inside the workspace directory
//! and never inside the data directory. Paths are resolved relative to the workspace, then
//! canonicalised (symlinks followed); anything that ends up outside is refused with one
//! sentence. This module only resolves paths; `read` and `write` open them.

use std::path::{Component, Path, PathBuf};

use crate::value::Refusal;

/// `path` with `.` and `..` resolved textually (for paths that do not exist yet).
fn lexical(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}

/// The workspace and the data directory it must stay clear of (both canonical).
#[derive(Clone, Debug)]
pub struct Sandbox {
    /// Canonical workspace directory.
    pub workspace: PathBuf,
    /// Canonical data directory (refused even if it lies inside the workspace).
    pub data_dir: PathBuf,
}

impl Sandbox {
    pub(crate) fn denied(&self, shown: &str) -> Refusal {
        format!("Access denied: {shown} is outside the workspace {}", self.workspace.display())
    }

    /// Whether a canonical path is one a user file may be: inside the workspace, not in the
    /// data directory.
    pub(super) fn contains(&self, canon: &Path) -> bool {
        canon.starts_with(&self.workspace) && !canon.starts_with(&self.data_dir)
    }

    fn check_inside(&self, canon: &Path, shown: &str) -> Result<(), Refusal> {
        if self.contains(canon) {
            Ok(())
        } else {
            Err(self.denied(shown))
        }
    }

    /// The canonical path of an existing entry to read (whether it is a regular file is
    /// checked on the opened handle, by `read`).
    pub fn existing(&self, user: &str) -> Result<PathBuf, Refusal> {
        self.probe(user)?.ok_or_else(|| self.missing(user))
    }

    /// The sentence for a path inside the workspace with nothing there.
    pub fn missing(&self, user: &str) -> Refusal {
        format!("file_path {user} does not exist in the workspace {}", self.workspace.display())
    }

    /// Where `user` resolves: Some(canonical path) when it exists inside the workspace, None
    /// when nothing is there (a candidate to try the next of), refused when it is outside.
    pub fn probe(&self, user: &str) -> Result<Option<PathBuf>, Refusal> {
        let joined = self.workspace.join(user);
        match joined.canonicalize() {
            Ok(canon) => self.check_inside(&canon, user).map(|()| Some(canon)),
            Err(_) => self.check_inside(&lexical(&joined), user).map(|()| None),
        }
    }

    /// The path to write `user` at, checked to be inside the workspace (an existing symlink at
    /// the target must itself point inside it). Nothing is created here: the folders are made
    /// by the write itself (`write.rs`), once the call is accepted, so a refused call leaves no
    /// trace on disk.
    pub fn writable(&self, user: &str) -> Result<PathBuf, Refusal> {
        if user.is_empty() {
            return Err("file_path must be a non-empty path".into());
        }
        let joined = self.workspace.join(user);
        let name = joined
            .file_name()
            .filter(|_| !matches!(joined.components().next_back(), Some(Component::ParentDir)))
            .ok_or_else(|| format!("file_path {user} must name a file"))?
            .to_owned();
        let parent = joined.parent().ok_or_else(|| self.denied(user))?;
        // Resolve the deepest existing ancestor, then check before creating anything.
        let mut existing = parent.to_path_buf();
        let mut missing = Vec::new();
        while !existing.exists() {
            match (existing.file_name(), existing.parent()) {
                (Some(n), Some(p)) => {
                    missing.push(n.to_owned());
                    existing = p.to_path_buf();
                }
                _ => return Err(self.denied(user)),
            }
        }
        let mut canon_parent = existing.canonicalize().map_err(|_| self.denied(user))?;
        for part in missing.iter().rev() {
            if part == ".." {
                return Err(self.denied(user));
            }
            canon_parent.push(part);
        }
        self.check_inside(&canon_parent, user)?;
        let target = canon_parent.join(&name);
        if target.is_symlink() {
            let resolved = target.canonicalize().map_err(|_| self.denied(user))?;
            self.check_inside(&resolved, user)?;
        }
        Ok(target)
    }

    /// `path` as the user would name it: relative to the workspace when inside it.
    pub fn shown(&self, path: &Path) -> String {
        path.strip_prefix(&self.workspace).unwrap_or(path).display().to_string()
    }
}
