//! The data directory: the server's own files, not the user's — the simulations' logs, the
//! exclusive lock and the saved-file MAC key. Private to the server: created 0700, the key
//! 0600. (User files go through `crate::files`.)

use std::io::Write;
use std::path::{Path, PathBuf};

/// Creates `dir` (the data directory privately, `private`) and refuses `/` or the home
/// directory (MCP clients often start stdio servers with the working directory at `/`).
pub fn prepare_dir(flag: &str, dir: &Path, private: bool) -> anyhow::Result<PathBuf> {
    let mut builder = std::fs::DirBuilder::new();
    builder.recursive(true);
    #[cfg(unix)]
    if private {
        use std::os::unix::fs::DirBuilderExt;
        builder.mode(0o700);
    }
    builder.create(dir).map_err(|e| anyhow::anyhow!("cannot create {flag} {}: {e}", dir.display()))?;
    let canon = dir.canonicalize()?;
    let home = std::env::var_os("HOME").map(PathBuf::from).and_then(|h| h.canonicalize().ok());
    if canon == Path::new("/") || Some(&canon) == home.as_ref() {
        anyhow::bail!(
            "{flag} resolves to {}, which is / or the home directory; pass an absolute {flag} \
             for physics-mcp's own files (MCP clients often start servers with the working \
             directory at /)",
            canon.display()
        );
    }
    Ok(canon)
}

/// Takes the data directory's exclusive OS lock (released when the process dies, even by
/// kill -9), refusing to start beside another live process on the same directory.
pub fn lock(data_dir: &Path) -> anyhow::Result<std::fs::File> {
    let lock_path = data_dir.join(".lock");
    let lock = std::fs::File::options().create(true).truncate(false).write(true).open(&lock_path)?;
    // A lock just released can still be held for a moment: by a process that is exiting, or
    // (in one process) by a child being spawned between its fork and its exec. Two seconds of
    // retries tell those from another live server.
    let mut tries = 0;
    while lock.try_lock().is_err() && tries < 40 {
        tries += 1;
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    if tries == 40 && lock.try_lock().is_err() {
        let holder = std::fs::read_to_string(&lock_path).ok().and_then(|s| s.trim().parse::<u32>().ok());
        anyhow::bail!(
            "another physics-mcp process{} is using the data directory {} (it holds {}), and a \
             data directory serves one process at a time: stop that one, or give this one its own \
             directories with --data DIR --workspace DIR (in an MCP client's config: \
             \"args\": [\"physics-mcp\", \"stdio\", \"--data\", \"DIR\", \"--workspace\", \"DIR\"]), \
             or connect both clients to one `physics-mcp serve` over HTTP",
            holder.map(|pid| format!(" (pid {pid})")).unwrap_or_default(),
            data_dir.display(),
            lock_path.display()
        );
    }
    // Who holds it, for the message above in the next process that tries.
    let _ = lock.set_len(0).and_then(|()| (&lock).write_all(format!("{}\n", std::process::id()).as_bytes()));
    Ok(lock)
}

/// Whether a running server holds the data directory the log `log` lives in (the report says
/// its last reads may not be flushed yet): the server keeps an exclusive OS lock on
/// `<data>/.lock` while it runs (`lock`), released when it exits however it exits. Asked
/// without waiting, with a shared lock dropped at once; a log outside a data directory is
/// never held.
pub fn held_by_server(log: &Path) -> bool {
    let Some(lock) = log.parent().map(|d| d.join(".lock")) else { return false };
    match std::fs::File::open(lock) {
        Ok(f) => f.try_lock_shared().is_err(),
        Err(_) => false,
    }
}

/// The simulation logs in the data directory, in name order.
pub fn logs(data_dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(data_dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "sqlite"))
        .collect();
    paths.sort();
    Ok(paths)
}

/// Deletes the partial logs a kill during create, fork or load left behind (start-up: no
/// request is running, so none is being written).
pub fn remove_partial_logs(data_dir: &Path) {
    let Ok(entries) = std::fs::read_dir(data_dir) else { return };
    for e in entries.flatten() {
        if e.file_name().to_str().is_some_and(super::sqlite::is_partial) {
            tracing::info!("removing the partial log {}", e.path().display());
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// Deletes a log and its WAL/shared-memory companions.
pub fn remove_log_files(path: &Path) {
    for suffix in std::iter::once("").chain(super::sqlite::COMPANIONS) {
        let mut p = path.to_path_buf().into_os_string();
        p.push(suffix);
        let _ = std::fs::remove_file(PathBuf::from(p));
    }
}

/// Reads the data directory's MAC key, creating it (0600) on first start. Saved files carry a
/// MAC of their snapshot under this key, so only files this server wrote load from a snapshot.
pub fn mac_key(data_dir: &Path) -> anyhow::Result<[u8; 32]> {
    let path = data_dir.join("mac.key");
    if let Ok(bytes) = std::fs::read(&path) {
        if let Ok(key) = <[u8; 32]>::try_from(bytes.as_slice()) {
            private(&path);
            return Ok(key);
        }
        anyhow::bail!("{} is not a 32-byte key; remove it to make a new one", path.display());
    }
    // A secret key straight from the operating system's generator (not derived from ids
    // made for uniqueness, whose randomness is not a promise about secrecy).
    let mut key = [0u8; 32];
    getrandom::fill(&mut key)
        .map_err(|e| anyhow::anyhow!("cannot make {}: no system randomness ({e})", path.display()))?;
    let mut options = std::fs::File::options();
    options.write(true).create_new(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.mode(0o600);
    }
    use std::io::Write;
    options.open(&path).and_then(|mut f| f.write_all(&key).and_then(|()| f.sync_all()))?;
    Ok(key)
}

/// Makes a key written by an earlier release (with the umask's 0644) private again, saying so.
fn private(path: &Path) {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        if let Ok(meta) = std::fs::metadata(path) {
            if meta.permissions().mode() & 0o077 != 0 {
                match std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o600)) {
                    Ok(()) => tracing::warn!("{} was readable by others; it is 0600 now", path.display()),
                    Err(e) => tracing::warn!("{} is readable by others and could not be made private: {e}", path.display()),
                }
            }
        }
    }
}

/// The file that marks a data directory as a cluster node's cache (`serve --cluster`).
const CLUSTER_CACHE_MARK: &str = ".cluster-cache";

/// Checks that `data_dir` may serve this mode, and marks it: a cluster node empties its
/// directory at start (a cache), so it refuses a directory holding an embedded server's logs
/// (they would be deleted); an embedded server refuses a node's cache (its files are copies,
/// not simulations of its own).
pub fn claim_for(data_dir: &Path, cluster: bool) -> anyhow::Result<()> {
    let mark = data_dir.join(CLUSTER_CACHE_MARK);
    let has_logs = !logs(data_dir)?.is_empty();
    match (cluster, mark.exists()) {
        (true, false) if has_logs => anyhow::bail!(
            "--data {} holds an embedded server's simulation logs, which a cluster node would delete \
             (its --data is a cache); import them with `physics-mcp import` or pass another --data",
            data_dir.display()
        ),
        (true, false) => std::fs::write(&mark, b"physics-mcp cluster cache\n")?,
        (false, true) => anyhow::bail!(
            "--data {} is a cluster node's cache (it holds {CLUSTER_CACHE_MARK}); pass another --data, \
             or --cluster to serve it as that node",
            data_dir.display()
        ),
        _ => {}
    }
    Ok(())
}

