//! list_files: what the workspace holds under a path, depth first in name order, without
//! following symbolic links (a link is listed as one, so the listing never leaves the
//! workspace) and without the data directory. Bounded: at most [`MAX_LISTED`] entries are
//! returned and at most [`MAX_WALKED`] looked at, so a huge tree costs a bounded reply and
//! bounded work.

use std::path::Path;

use super::Sandbox;
use crate::outputs::{FileEntry, Files};
use crate::value::Refusal;

/// Entries one list_files reply holds (a few tens of KB); `truncated` says when there are more.
pub const MAX_LISTED: usize = 256;
/// Entries one list_files call looks at in all (the `total` it reports stops counting here).
pub const MAX_WALKED: u64 = 100_000;

/// The prefix of write staging files (`write::staged`): a write in flight, not listed.
const STAGING_PREFIX: &str = ".physics-mcp-";

/// list_files of workspace path `user` (None: the whole workspace).
pub fn list(sandbox: &Sandbox, user: Option<&str>) -> Result<Files, Refusal> {
    let shown = user.unwrap_or(".");
    let start = sandbox
        .probe(shown)
        .map_err(|why| why.replacen(shown, &format!("path {shown}"), 1))?
        .ok_or_else(|| format!("path {shown} does not exist in the workspace {}", sandbox.workspace.display()))?;
    let mut listing = Listing { sandbox, entries: Vec::new(), seen: 0 };
    let meta = start.metadata().map_err(|e| format!("could not list path {shown}: {e}"))?;
    if meta.is_dir() {
        listing.walk(&start)?;
    } else {
        listing.add(&start, &meta);
    }
    let total = listing.seen;
    let truncated = total > listing.entries.len() as u64;
    Ok(Files { entries: listing.entries, truncated, total: truncated.then_some(total) })
}

struct Listing<'a> {
    sandbox: &'a Sandbox,
    entries: Vec<FileEntry>,
    seen: u64,
}

impl Listing<'_> {
    fn add(&mut self, path: &Path, meta: &std::fs::Metadata) {
        self.seen += 1;
        if self.entries.len() >= MAX_LISTED {
            return;
        }
        let kind = meta.file_type();
        let (kind, bytes) = if kind.is_symlink() {
            ("symlink", 0)
        } else if kind.is_dir() {
            ("dir", 0)
        } else if kind.is_file() {
            ("file", meta.len())
        } else {
            ("other", 0)
        };
        let mut shown = self.sandbox.shown(path);
        if kind == "dir" {
            shown.push('/');
        }
        self.entries.push(FileEntry { path: shown, bytes, kind: kind.to_string() });
    }

    /// The entries under folder `dir` (not itself), depth first in name order.
    fn walk(&mut self, dir: &Path) -> Result<(), Refusal> {
        let mut children: Vec<_> = std::fs::read_dir(dir)
            .map_err(|e| format!("could not list path {}: {e}", self.sandbox.shown(dir)))?
            .filter_map(Result::ok)
            .map(|e| e.path())
            .filter(|p| !p.file_name().is_some_and(|n| n.to_string_lossy().starts_with(STAGING_PREFIX)))
            .filter(|p| !p.starts_with(&self.sandbox.data_dir))
            .collect();
        children.sort();
        for child in children {
            if self.seen >= MAX_WALKED {
                return Ok(());
            }
            let Ok(meta) = child.symlink_metadata() else { continue };
            self.add(&child, &meta);
            if meta.is_dir() {
                self.walk(&child)?;
            }
        }
        Ok(())
    }
}
