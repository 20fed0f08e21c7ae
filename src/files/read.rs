//! Reading user files: regular files only, bounded from the open handle, inside the sandbox.
//!
//! A path is resolved by the sandbox, then opened without following a final symlink and
//! without blocking (a FIFO would otherwise wait for a writer while the caller holds a
//! simulation); the *opened* handle must be a regular file, and on Linux the file it names
//! must still be inside the workspace (a symlink swapped in after the check is caught). At
//! most `limit + 1` bytes are read from the handle, so a file that grows, or a device that
//! never ends, cannot make the server read more than the limit: there is no size-then-read.
//!
//! A [`Reader`] serves one request: each distinct file is read once (a batch of 300
//! load_urdf of one robot reads it once) and the request holds at most
//! [`REQUEST_FILE_BYTES`] of file contents in all.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::Sandbox;
use crate::value::Refusal;

/// The most bytes of file contents one request (a call, a batch, a sweep) reads in all:
/// a robot with its meshes is at most 72 MiB (`urdf_files`' limits), so this holds a few.
pub const REQUEST_FILE_BYTES: u64 = 256 << 20;

/// Opens `path` for reading as a regular file: no final symlink followed, never blocking on
/// a FIFO or device, anything but a regular file refused naming `shown`.
fn open_regular(path: &Path, shown: &str) -> Result<File, Refusal> {
    open(path, shown, false)
}

/// `open_regular`, following a final symlink (for a file about to be replaced, whose link
/// the sandbox has checked).
pub(super) fn open_regular_following(path: &Path, shown: &str) -> Result<File, Refusal> {
    open(path, shown, true)
}

fn open(path: &Path, shown: &str, follow: bool) -> Result<File, Refusal> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        let nofollow = if follow { 0 } else { libc::O_NOFOLLOW };
        options.custom_flags(libc::O_NONBLOCK | nofollow);
    }
    let file = options.open(path).map_err(|e| format!("could not read {shown}: {e}"))?;
    let meta = file.metadata().map_err(|e| format!("could not read {shown}: {e}"))?;
    if !meta.is_file() {
        let what = if meta.is_dir() { "a directory" } else { "not a regular file (a FIFO, socket or device)" };
        return Err(format!("{shown} is {what}; only regular files are read"));
    }
    Ok(file)
}

/// Where the open handle really is (Linux: the kernel's name for it), to check it is still
/// inside the sandbox after the open; None where the system cannot tell.
pub(super) fn opened_path(file: &File) -> Option<PathBuf> {
    #[cfg(target_os = "linux")]
    {
        use std::os::fd::AsRawFd;
        std::fs::read_link(format!("/proc/self/fd/{}", file.as_raw_fd())).ok()
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = file;
        None
    }
}

/// At most `limit` bytes from `file`, refused (naming `shown`) when it holds more. The bound
/// is on what is read, not on what the file says its size is (a file may grow meanwhile); the
/// size is only quoted in the refusal.
fn read_bounded(file: File, shown: &str, limit: u64) -> Result<Vec<u8>, Refusal> {
    let size = file.metadata().map(|m| m.len()).unwrap_or(0);
    let mut bytes = Vec::new();
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| format!("could not read {shown}: {e}"))?;
    if bytes.len() as u64 > limit {
        return Err(too_big(shown, size.max(bytes.len() as u64), limit));
    }
    Ok(bytes)
}

/// The refusal of a file over its limit.
fn too_big(shown: &str, size: u64, limit: u64) -> Refusal {
    format!("{shown} is {size} bytes; the limit is {limit}")
}

/// Reads a file the operator named on the command line (not sandboxed: the operator may
/// name any file), with the same rules: a regular file, at most `limit` bytes.
pub fn read_operator_file(path: &Path, limit: u64) -> Result<Vec<u8>, Refusal> {
    let shown = path.display().to_string();
    read_bounded(open_regular(path, &shown)?, &shown, limit)
}

/// Whether `path` names a regular file (for inputs another library opens, such as a SQLite
/// log given to `replay`: a FIFO there would block it).
pub fn is_regular_file(path: &Path) -> bool {
    open_regular(path, "").is_ok()
}

/// One request's reads of user files: each distinct file once, all of them within
/// [`REQUEST_FILE_BYTES`].
pub struct Reader {
    sandbox: Sandbox,
    read: BTreeMap<PathBuf, Arc<Vec<u8>>>,
    left: u64,
}

impl Reader {
    /// A reader for one request over `sandbox`.
    pub fn new(sandbox: &Sandbox) -> Reader {
        Self::with_budget(sandbox, REQUEST_FILE_BYTES)
    }

    /// A reader for a request that reads one large file of its own kind besides the usual
    /// (load_simulation: a saved file of up to `save_format::MAX_SAVE_BYTES`, then the robots
    /// an old server's file names), within `budget` bytes in all.
    pub fn with_budget(sandbox: &Sandbox, budget: u64) -> Reader {
        Reader { sandbox: sandbox.clone(), read: BTreeMap::new(), left: budget }
    }

    /// The sandbox the reader resolves paths in.
    pub fn sandbox(&self) -> &Sandbox {
        &self.sandbox
    }

    /// The bytes of the workspace file `user` (resolved by the sandbox), at most `limit`,
    /// with its canonical path; `shown` names it in refusals ("file_path robot.urdf",
    /// "mesh arm.stl of robot.urdf").
    pub fn read(&mut self, user: &str, shown: &str, limit: u64) -> Result<(PathBuf, Arc<Vec<u8>>), Refusal> {
        let path = self.sandbox.existing(user)?;
        self.read_resolved(path, shown, limit)
    }

    /// The bytes of built-in file `name` (`library`), at most `limit`, read like a workspace
    /// file: once per request, counted in its budget. Kept under the relative path `name`,
    /// which no canonical workspace path equals.
    pub fn read_builtin(&mut self, name: &str, shown: &str, limit: u64) -> Result<Arc<Vec<u8>>, Refusal> {
        let key = PathBuf::from(name);
        if let Some(bytes) = self.read.get(&key) {
            if bytes.len() as u64 > limit {
                return Err(too_big(shown, bytes.len() as u64, limit));
            }
            return Ok(bytes.clone());
        }
        let bytes = super::library::read(name).ok_or_else(|| format!("{shown} is not in the built-in library"))?;
        let size = bytes.len() as u64;
        if size > limit {
            return Err(too_big(shown, size, limit));
        }
        if size > self.left {
            return Err(format!("{shown} does not fit what one request may read ({REQUEST_FILE_BYTES} bytes of files in all); split the request"));
        }
        self.left -= size;
        let bytes = Arc::new(bytes);
        self.read.insert(key, bytes.clone());
        Ok(bytes)
    }

    /// `read` of a path the sandbox already resolved (`Sandbox::existing`).
    pub fn read_resolved(&mut self, path: PathBuf, shown: &str, limit: u64) -> Result<(PathBuf, Arc<Vec<u8>>), Refusal> {
        if let Some(bytes) = self.read.get(&path) {
            if bytes.len() as u64 > limit {
                return Err(too_big(shown, bytes.len() as u64, limit));
            }
            return Ok((path, bytes.clone()));
        }
        let file = open_regular(&path, shown)?;
        if let Some(real) = opened_path(&file) {
            if !self.sandbox.contains(&real) {
                return Err(self.sandbox.denied(shown));
            }
        }
        let bound = limit.min(self.left);
        let bytes = read_bounded(file, shown, bound).map_err(|why| {
            if bound < limit {
                format!(
                    "{shown} does not fit what one request may read ({REQUEST_FILE_BYTES} bytes of files in all); split the request"
                )
            } else {
                why
            }
        })?;
        self.left -= bytes.len() as u64;
        tracing::debug!(target: "physics_mcp::files", path = %path.display(), bytes = bytes.len(), "read a user file");
        let bytes = Arc::new(bytes);
        self.read.insert(path.clone(), bytes.clone());
        Ok((path, bytes))
    }
}
