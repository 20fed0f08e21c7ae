//! Writing user files, under one policy (docs/guarantees: "an output never replaces a file"):
//!
//! - **Outputs** (ray_test_batch's `.json`, get_camera_image's `.png`/`.npy`, get_trajectory's
//!   `.csv`/`.jsonl`, render_animation's `.gif`) are created new: an existing path is refused
//!   with a sentence, and of two concurrent writers to one new path exactly one wins (the file
//!   is written under a temporary name, then linked into place only if the name is free).
//! - **Files a tool owns** (save_simulation's saves, generate_revolute_joint's URDFs) replace an
//!   existing file only when it is one of theirs (a physics-mcp save; a URDF with the
//!   generator's comment), anything else only with `overwrite: true`.
//! - **The command line's outputs** (`report -o`, `replay --render/--trajectory`) never replace
//!   a file without `--force`.
//! - **A client's own files** (write_file) are created new; an existing regular file is
//!   replaced only with `overwrite: true`; links and special files never are.
//!
//! Every write is atomic (temporary file in the same folder, fsynced, renamed) and gets the
//! usual permissions (0666 less the umask); the data directory and its MAC key are not user
//! files and stay private (`store::data_dir`).

use std::io::{ErrorKind, Write};
use std::path::Path;

use super::Sandbox;
use crate::value::Refusal;

/// The path an output named by parameter `param` goes to: inside the workspace and not
/// existing yet (checked before the work; the write itself checks again, atomically).
pub fn new_output(sandbox: &Sandbox, param: &str, user: &str) -> Result<std::path::PathBuf, Refusal> {
    let target = sandbox.writable(user).map_err(|e| format!("{param}: {}", e.replacen("file_path ", "", 1)))?;
    if target.symlink_metadata().is_ok() {
        return Err(exists(param, user));
    }
    Ok(target)
}

/// Writes a new file under the first of `names` (workspace-relative) that is free, moving on
/// to the next when another writer takes one first; returns the path written.
pub fn create_first_free(sandbox: &Sandbox, names: impl IntoIterator<Item = String>, bytes: &[u8]) -> Result<std::path::PathBuf, Refusal> {
    for name in names {
        let target = sandbox.writable(&name)?;
        if target.symlink_metadata().is_ok() {
            continue;
        }
        match create_new(sandbox, &target, "file_path", &name, bytes) {
            Ok(()) => return Ok(target),
            Err(_) if target.symlink_metadata().is_ok() => continue,
            Err(why) => return Err(why),
        }
    }
    Err("no free file name is left".into())
}

fn exists(param: &str, user: &str) -> Refusal {
    format!("{param} {user} already exists; give a new file name (files are never overwritten)")
}

/// A temporary file beside `target` holding `bytes`, fsynced, with the usual permissions; with
/// a sandbox, the folder it landed in must still be inside it (a folder swapped for a symlink
/// after the path was resolved is caught here, before anything is linked into place).
fn staged(target: &Path, bytes: &[u8], sandbox: Option<&Sandbox>) -> Result<tempfile::NamedTempFile, Refusal> {
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    // A user file's folders are made now that the call was accepted (`Sandbox::writable`
    // checked them inside the workspace; the temporary file's real folder is checked again
    // below). The command line's outputs go to folders that exist.
    if sandbox.is_some() {
        std::fs::create_dir_all(dir).map_err(|e| format!("could not create the folder for {}: {e}", target.display()))?;
    }
    let mut builder = tempfile::Builder::new();
    builder.prefix(".physics-mcp-");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // The kernel takes the umask off, as for any file a program creates.
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder.tempfile_in(dir).map_err(|e| format!("could not write {}: {e}", target.display()))?;
    if let (Some(sandbox), Some(real)) = (sandbox, super::read::opened_path(tmp.as_file())) {
        if !real.parent().is_some_and(|d| sandbox.contains(d)) {
            return Err(sandbox.denied(&target.display().to_string()));
        }
    }
    tmp.write_all(bytes)
        .and_then(|_| tmp.as_file().sync_all())
        .map_err(|e| format!("could not write {}: {e}", target.display()))?;
    Ok(tmp)
}

/// Writes a new output file at `target` (from `new_output`): refused, naming `param` and
/// `user`, if anything exists there by the time it is linked into place.
pub fn create_new(sandbox: &Sandbox, target: &Path, param: &str, user: &str, bytes: &[u8]) -> Result<(), Refusal> {
    let tmp = staged(target, bytes, Some(sandbox))?;
    crate::crash_point!("save_write");
    match tmp.persist_noclobber(target) {
        Ok(_) => Ok(()),
        Err(e) if e.error.kind() == ErrorKind::AlreadyExists => Err(exists(param, user)),
        Err(e) => Err(format!("could not write {}: {}", target.display(), e.error)),
    }
}

/// Writes several new output files that belong together (a camera image's PNG and arrays),
/// in order, all or none: should one be refused (its path taken meanwhile), those already
/// written by this call are removed again.
pub fn create_new_all(sandbox: &Sandbox, param: &str, files: &[(&Path, &[u8])]) -> Result<(), Refusal> {
    for (i, (target, bytes)) in files.iter().enumerate() {
        let user = sandbox.shown(target);
        if let Err(why) = create_new(sandbox, target, param, &user, bytes) {
            for (written, _) in &files[..i] {
                let _ = std::fs::remove_file(written);
            }
            return Err(why);
        }
    }
    Ok(())
}

/// What a tool that owns its files writes: how to recognise one of them from its first
/// bytes, and what to call it in a refusal.
pub struct Owned {
    /// Whether the first (up to [`OWNED_PREFIX`]) bytes of an existing file are one of ours.
    pub ours: fn(&[u8]) -> bool,
    /// "a physics-mcp save", "a URDF written by generate_revolute_joint".
    pub what: &'static str,
}

/// How many leading bytes of an existing file `Owned::ours` is shown.
pub const OWNED_PREFIX: u64 = 4096;

/// The identity of whatever is at `path` now (device and inode), if anything is.
fn identity(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    path.symlink_metadata().ok().map(|m| (m.dev(), m.ino()))
}

/// Writes `bytes` at `target` (from `Sandbox::writable`) for a tool that owns its files: a
/// new file is created; an existing one is replaced only if it is one of `owned`'s, or with
/// `overwrite`. The file looked at is the file replaced: if another takes its place before
/// the rename (checked by device and inode), it is looked at again. Refusals name `user`.
pub fn write_owned(sandbox: &Sandbox, target: &Path, user: &str, bytes: &[u8], owned: &Owned, overwrite: bool) -> Result<(), Refusal> {
    for _ in 0..3 {
        let seen = identity(target);
        if seen.is_some() && !overwrite {
            let head = prefix(target, user)?;
            if !(owned.ours)(&head) {
                return Err(format!(
                    "file_path {user} already exists and is not {}; give overwrite: true to replace it, or a new file name",
                    owned.what
                ));
            }
        }
        let tmp = staged(target, bytes, Some(sandbox))?;
        crate::crash_point!("save_write");
        if identity(target) != seen {
            continue;
        }
        let done = if seen.is_some() { tmp.persist(target).map_err(|e| e.error) } else { tmp.persist_noclobber(target).map_err(|e| e.error) };
        match done {
            Ok(_) => return Ok(()),
            Err(e) if e.kind() == ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(format!("could not write {}: {e}", target.display())),
        }
    }
    Err(format!("file_path {user} kept changing while it was written; try again"))
}

/// The first bytes of an existing file (a symlink's target's; anything but a regular file
/// is refused).
fn prefix(path: &Path, user: &str) -> Result<Vec<u8>, Refusal> {
    use std::io::Read;
    let shown = format!("file_path {user}");
    let file = super::read::open_regular_following(path, &shown)?;
    let mut head = Vec::new();
    file.take(OWNED_PREFIX).read_to_end(&mut head).map_err(|e| format!("could not read {shown}: {e}"))?;
    Ok(head)
}

/// Writes a file the operator named on the command line: never over an existing file unless
/// `force` (`--force`).
pub fn write_operator_file(path: &Path, bytes: &[u8], force: bool) -> Result<(), Refusal> {
    let shown = path.display().to_string();
    let tmp = staged(path, bytes, None)?;
    let done = if force { tmp.persist(path).map_err(|e| e.error) } else { tmp.persist_noclobber(path).map_err(|e| e.error) };
    match done {
        Ok(_) => Ok(()),
        Err(e) if e.kind() == ErrorKind::AlreadyExists => Err(format!("{shown} already exists; pass --force to replace it")),
        Err(e) => Err(format!("could not write {shown}: {e}")),
    }
}

/// write_file: `bytes` as the workspace file `user` (at `target`, from `Sandbox::writable`),
/// a regular file only. A new file is created (of two writers to one new path exactly one
/// wins); an existing regular file is replaced only with `overwrite`; a symbolic link, folder,
/// FIFO, socket or device at the path is refused either way, so nothing is written through a
/// link or into a special file. Every refusal leaves the path as it was.
pub fn write_client_file(sandbox: &Sandbox, target: &Path, user: &str, bytes: &[u8], overwrite: bool) -> Result<(), Refusal> {
    let refuse_kind = |meta: &std::fs::Metadata| -> Result<(), Refusal> {
        let kind = meta.file_type();
        let what = if kind.is_symlink() {
            "a symbolic link"
        } else if kind.is_dir() {
            "a folder"
        } else if !kind.is_file() {
            "not a regular file (a FIFO, socket or device)"
        } else {
            return Ok(());
        };
        Err(format!("path {user} is {what}; write_file writes regular files only"))
    };
    match target.symlink_metadata() {
        Ok(meta) => {
            refuse_kind(&meta)?;
            if !overwrite {
                return Err(format!("path {user} already exists; give overwrite: true to replace it, or a new path"));
            }
            let tmp = staged(target, bytes, Some(sandbox))?;
            // Still the regular file looked at (not swapped for a link or a FIFO meanwhile)?
            // A rename replaces the directory entry itself, never what a link points to.
            if let Ok(now) = target.symlink_metadata() {
                refuse_kind(&now)?;
            }
            tmp.persist(target).map(|_| ()).map_err(|e| format!("could not write {user}: {}", e.error))
        }
        Err(_) => {
            let tmp = staged(target, bytes, Some(sandbox))?;
            match tmp.persist_noclobber(target) {
                Ok(_) => Ok(()),
                Err(e) if e.error.kind() == ErrorKind::AlreadyExists => {
                    Err(format!("path {user} was created by someone else meanwhile; give overwrite: true to replace it, or a new path"))
                }
                Err(e) => Err(format!("could not write {user}: {}", e.error)),
            }
        }
    }
}

/// write_file's whole work: the content (text, or base64 for bytes) checked against
/// `max_bytes` before anything is decoded or written, the path resolved inside the workspace
/// (its folders created), then written under `write_client_file`'s rules.
pub fn write_file(sandbox: &Sandbox, p: &crate::params::WriteFile, max_bytes: usize) -> Result<crate::outputs::FileWritten, Refusal> {
    use base64::Engine as _;
    let user = &p.path.0;
    let over = |size: usize| format!("the file would be {size} bytes; write_file writes at most {max_bytes} (--max-write-bytes)");
    let bytes = match (&p.content, &p.content_base64) {
        (Some(_), Some(_)) => return Err("give content or content_base64, not both".into()),
        (None, None) => return Err("content or content_base64 is required: the file as text, or as base64 for bytes".into()),
        (Some(text), None) => {
            if text.0.len() > max_bytes {
                return Err(over(text.0.len()));
            }
            text.0.clone().into_bytes()
        }
        (None, Some(b64)) => {
            let packed: Vec<u8> = b64.0.bytes().filter(|b| !b.is_ascii_whitespace()).collect();
            // Three bytes for every four characters: refused before decoding when surely over.
            if packed.len() / 4 * 3 > max_bytes.saturating_add(2) {
                return Err(over(packed.len() / 4 * 3));
            }
            let bytes = base64::engine::general_purpose::STANDARD
                .decode(&packed)
                .map_err(|e| format!("content_base64 is not valid base64: {e}"))?;
            if bytes.len() > max_bytes {
                return Err(over(bytes.len()));
            }
            bytes
        }
    };
    let target = sandbox.writable(user).map_err(|why| why.replacen("file_path ", "path ", 1))?;
    write_client_file(sandbox, &target, user, &bytes, p.overwrite.as_ref().is_some_and(|b| b.0))?;
    Ok(crate::outputs::FileWritten { path: sandbox.shown(&target), bytes: bytes.len() as u64 })
}
