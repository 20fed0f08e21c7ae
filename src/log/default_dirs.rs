//! Where the data directory and the workspace go when the command line names them not: MCP
//! clients start stdio servers wherever they like — often with the working directory at `/`,
//! sometimes at the home directory or somewhere read-only — and `./physics-mcp-data` there is
//! refused, uncreatable, or (as root) silently made at the file system's root. So the working
//! directory is used as before where it can hold them, and the user's data directory
//! (`$XDG_DATA_HOME/physics-mcp`, else `~/.local/share/physics-mcp`) where it cannot.

use std::ffi::OsString;
use std::path::{Path, PathBuf};

/// The data directory's name in the working directory (today's default, `./physics-mcp-data`).
pub const CWD_DATA: &str = "physics-mcp-data";
/// The workspace's name in the working directory (`./physics-mcp-workspace`).
pub const CWD_WORKSPACE: &str = "physics-mcp-workspace";

/// The directories a server starts with.
#[derive(Debug, PartialEq)]
pub struct Chosen {
    /// `--data`, or its default.
    pub data: PathBuf,
    /// `--workspace`, or its default.
    pub workspace: PathBuf,
    /// The line to print first when the defaults moved to the user's data directory, saying
    /// where and why (a desktop user finds their files from it); None otherwise.
    pub note: Option<String>,
}

/// Fills in `--data` and `--workspace` when they are not given: `./physics-mcp-data` and
/// `./physics-mcp-workspace` when the working directory is usable — writable, neither `/` nor
/// the home directory — or already holds a `physics-mcp-data` (always used, so no earlier
/// simulation goes missing); else `data` and `workspace` under the user's data directory.
/// A flag given is kept as it is.
pub fn choose(data: Option<PathBuf>, workspace: Option<PathBuf>) -> anyhow::Result<Chosen> {
    if let (Some(data), Some(workspace)) = (&data, &workspace) {
        return Ok(Chosen { data: data.clone(), workspace: workspace.clone(), note: None });
    }
    let home = std::env::var_os("HOME").filter(|h| !h.is_empty());
    let cwd = std::env::current_dir();
    let why = match &cwd {
        Ok(cwd) => why_unusable(cwd, home.as_deref().map(Path::new)),
        Err(e) => Some(format!("unknown ({e})")),
    };
    let Some(why) = why else {
        return Ok(Chosen {
            data: data.unwrap_or_else(|| Path::new(".").join(CWD_DATA)),
            workspace: workspace.unwrap_or_else(|| Path::new(".").join(CWD_WORKSPACE)),
            note: None,
        });
    };
    let cwd = cwd.map(|c| c.display().to_string()).unwrap_or_else(|_| "?".into());
    let Some(base) = user_data_dir(std::env::var_os("XDG_DATA_HOME"), home) else {
        anyhow::bail!(
            "the working directory {cwd} is {why} and neither XDG_DATA_HOME nor HOME names an \
             absolute directory for physics-mcp's files; pass --data DIR and --workspace DIR"
        );
    };
    let data = data.unwrap_or_else(|| base.join("data"));
    let workspace = workspace.unwrap_or_else(|| base.join("workspace"));
    let note = format!(
        "physics-mcp: data in {}, workspace in {} (the working directory {cwd} is {why}; \
         --data and --workspace choose others)",
        data.display(),
        workspace.display()
    );
    Ok(Chosen { data, workspace, note: Some(note) })
}

/// Why the working directory `cwd` cannot hold the default directories, or None when it can.
fn why_unusable(cwd: &Path, home: Option<&Path>) -> Option<String> {
    if cwd.join(CWD_DATA).exists() {
        return None;
    }
    let canonical = |p: &Path| p.canonicalize().unwrap_or_else(|_| p.to_path_buf());
    let cwd = canonical(cwd);
    if cwd == Path::new("/") {
        return Some("the file system's root".into());
    }
    if home.map(canonical).is_some_and(|h| h == cwd) {
        return Some("the home directory".into());
    }
    // An unnamed file, gone when dropped: the honest test of "can this process write here"
    // (permissions, ACLs, a read-only mount, another user's directory).
    match tempfile::tempfile_in(&cwd) {
        Ok(_) => None,
        Err(e) => Some(format!("not writable ({e})")),
    }
}

/// `$XDG_DATA_HOME/physics-mcp`, else `$HOME/.local/share/physics-mcp` (the XDG Base Directory
/// rule: a relative or empty `XDG_DATA_HOME` is ignored); None without an absolute one.
fn user_data_dir(xdg_data_home: Option<OsString>, home: Option<OsString>) -> Option<PathBuf> {
    let absolute = |v: Option<OsString>| v.map(PathBuf::from).filter(|p| p.is_absolute());
    absolute(xdg_data_home)
        .or_else(|| absolute(home).map(|h| h.join(".local/share")))
        .map(|base| base.join("physics-mcp"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_user_data_directory_follows_xdg() {
        let dir = |xdg: Option<&str>, home: Option<&str>| user_data_dir(xdg.map(Into::into), home.map(Into::into));
        assert_eq!(dir(Some("/x/data"), Some("/home/u")), Some(PathBuf::from("/x/data/physics-mcp")));
        assert_eq!(dir(None, Some("/home/u")), Some(PathBuf::from("/home/u/.local/share/physics-mcp")));
        // Relative or empty XDG_DATA_HOME is invalid and ignored, as the XDG rule says.
        assert_eq!(dir(Some("rel/data"), Some("/home/u")), Some(PathBuf::from("/home/u/.local/share/physics-mcp")));
        assert_eq!(dir(Some(""), Some("/home/u")), Some(PathBuf::from("/home/u/.local/share/physics-mcp")));
        assert_eq!(dir(None, Some("relative")), None);
        assert_eq!(dir(None, None), None);
    }

    #[test]
    fn the_root_the_home_directory_and_no_write_permission_are_unusable() {
        let tmp = tempfile::tempdir().unwrap();
        assert_eq!(why_unusable(tmp.path(), None), None);
        assert_eq!(why_unusable(tmp.path(), Some(tmp.path())).as_deref(), Some("the home directory"));
        // An existing ./physics-mcp-data is always used, even in the home directory.
        std::fs::create_dir(tmp.path().join(CWD_DATA)).unwrap();
        assert_eq!(why_unusable(tmp.path(), Some(tmp.path())), None);
        if !Path::new("/").join(CWD_DATA).exists() {
            assert_eq!(why_unusable(Path::new("/"), None).as_deref(), Some("the file system's root"));
        }
        let missing = tmp.path().join("gone");
        assert!(why_unusable(&missing, None).is_some_and(|w| w.starts_with("not writable")));
    }

    #[test]
    fn flags_given_are_kept() {
        let chosen = choose(Some("/d".into()), Some("/w".into())).unwrap();
        assert_eq!(chosen, Chosen { data: "/d".into(), workspace: "/w".into(), note: None });
    }
}
