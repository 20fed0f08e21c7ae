//! The bearer token of `serve` and `call`, taken from where other local users cannot read it:
//! a file (`--token-file PATH`) or the environment (`PHYSICS_MCP_TOKEN`). `--token TOKEN`
//! still works for old scripts, but `ps` and `/proc/PID/cmdline` show it to every local user.

use std::path::Path;

/// The environment variable `serve` and `call` read the token from when no flag gives one.
pub const TOKEN_ENV: &str = "PHYSICS_MCP_TOKEN";

/// Largest token file read (a token is a line; a bigger file is surely the wrong one).
pub const MAX_TOKEN_FILE_BYTES: u64 = 4096;

/// The token `serve` requires (or `call` sends): `--token`, else `--token-file`'s first line,
/// else `PHYSICS_MCP_TOKEN`; None when none is given (clap refuses both flags at once).
pub fn token(flag: Option<String>, file: Option<&Path>) -> Result<Option<String>, String> {
    let from_file = match file {
        Some(path) => {
            let bytes = crate::files::read::read_operator_file(path, MAX_TOKEN_FILE_BYTES).map_err(|why| format!("--token-file: {why}"))?;
            let text = String::from_utf8(bytes).map_err(|_| format!("--token-file: {} is not UTF-8 text", path.display()))?;
            Some(checked(text.lines().next().unwrap_or(""), &format!("--token-file {}", path.display()))?)
        }
        None => None,
    };
    if let Some(t) = flag {
        return checked(&t, "--token").map(Some);
    }
    if from_file.is_some() {
        return Ok(from_file);
    }
    match std::env::var(TOKEN_ENV) {
        Ok(v) if !v.is_empty() => checked(&v, TOKEN_ENV).map(Some),
        _ => Ok(None),
    }
}

/// A token as given by `source`, without surrounding whitespace: non-empty, visible ASCII only
/// (it travels in an HTTP header and a URL query).
fn checked(given: &str, source: &str) -> Result<String, String> {
    let t = given.trim();
    if t.is_empty() {
        return Err(format!("{source} gives an empty token"));
    }
    if !t.bytes().all(|b| b.is_ascii_graphic()) {
        return Err(format!("{source} gives a token with spaces or characters other than visible ASCII"));
    }
    Ok(t.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_are_trimmed_and_checked() {
        assert_eq!(checked(" abc\n", "x").unwrap(), "abc");
        assert!(checked("  \n", "--token-file t").unwrap_err().contains("--token-file t gives an empty token"));
        assert!(checked("a b", "x").unwrap_err().contains("visible ASCII"));
    }
}
