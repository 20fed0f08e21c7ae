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
