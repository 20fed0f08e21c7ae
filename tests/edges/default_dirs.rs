//! Where `physics-mcp stdio` keeps its files when a client starts it with no `--data` or
//! `--workspace`, from wherever the client likes: the working directory when it is usable, the
//! user's data directory when it is `/`, the home directory or not writable — said on the first
//! log line — and a second server on the same defaults is told exactly what to do. Each test
//! starts the real binary over stdio with rmcp's client, in a clean environment.

use std::path::Path;
use std::process::Stdio;

use rmcp::model::CallToolRequestParams;
use rmcp::transport::{ConfigureCommandExt, TokioChildProcess};
use rmcp::ServiceExt;

/// `cmd` with only the variables a desktop client passes: HOME (when given), PATH and, when
/// given, XDG_DATA_HOME.
fn clean_env(cmd: &mut tokio::process::Command, home: Option<&Path>, xdg: Option<&Path>) {
    cmd.env_clear().env("PATH", "/usr/bin:/bin");
    if let Some(home) = home {
        cmd.env("HOME", home);
    }
    if let Some(xdg) = xdg {
        cmd.env("XDG_DATA_HOME", xdg);
    }
}

/// A stdio server started with no directory flags from `cwd`, its stderr kept in `log`.
async fn start(cwd: &Path, home: Option<&Path>, xdg: Option<&Path>, log: &Path) -> (rmcp::service::RunningService<rmcp::RoleClient, ()>, u32) {
    let stderr = std::fs::File::create(log).unwrap();
    let (transport, _) = TokioChildProcess::builder(tokio::process::Command::new(crate::common::bin()).configure(|cmd| {
        cmd.arg("stdio").current_dir(cwd);
        clean_env(cmd, home, xdg);
    }))
    .stderr(Stdio::from(stderr))
    .spawn()
    .unwrap();
    let pid = transport.id().expect("a pid");
    (().serve(transport).await.expect("stdio initialize"), pid)
}

/// Starts a server from `cwd`, makes a simulation, ends the session; returns the simulation's
/// id and the server's stderr.
async fn one_simulation(cwd: &Path, home: Option<&Path>, xdg: Option<&Path>, log: &Path) -> (String, String) {
    let (client, _) = start(cwd, home, xdg, log).await;
    let sim = create(&client).await;
    client.cancel().await.unwrap();
    (sim, std::fs::read_to_string(log).unwrap())
}

async fn create(client: &rmcp::service::RunningService<rmcp::RoleClient, ()>) -> String {
    let r = client.call_tool(CallToolRequestParams::new("create_simulation").with_arguments(Default::default())).await.unwrap();
    assert_ne!(r.is_error, Some(true), "{:?}", r.content);
    r.structured_content.unwrap()["simulation_id"].as_str().unwrap().to_string()
}

/// The first log line when the defaults moved to `base` (the user's data directory).
fn note(base: &Path, why: &str) -> String {
    format!(
        "physics-mcp: data in {}, workspace in {} (the working directory {why}; --data and --workspace choose others)",
        base.join("data").display(),
        base.join("workspace").display()
    )
}

/// Whether this machine's `/` already holds a `physics-mcp-data`, which is always used (an
/// earlier release, run as root from `/`, made it there): then `/` is not the case to test.
fn root_holds_data() -> bool {
    let held = Path::new("/physics-mcp-data").exists();
    if held {
        eprintln!("skipped: /physics-mcp-data exists on this machine, and an existing ./physics-mcp-data is always used");
    }
    held
}

#[tokio::test(flavor = "multi_thread")]
async fn from_the_root_they_go_to_the_user_data_directory() {
    if root_holds_data() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let home = tmp.path().join("home");
    std::fs::create_dir(&home).unwrap();
    let (sim, log) = one_simulation(Path::new("/"), Some(&home), None, &tmp.path().join("log")).await;
    let base = home.join(".local/share/physics-mcp");
    assert!(base.join("data").join(format!("{sim}.sqlite")).is_file(), "{log}");
    assert!(base.join("workspace").is_dir());
    assert_eq!(log.lines().next(), Some(note(&base, "/ is the file system's root").as_str()), "{log}");
    assert!(!Path::new("/physics-mcp-data").exists() && !Path::new("/physics-mcp-workspace").exists());
}

#[tokio::test(flavor = "multi_thread")]
async fn from_the_home_directory_they_go_to_xdg_data_home() {
    let tmp = tempfile::tempdir().unwrap();
    let (home, xdg) = (tmp.path().join("home"), tmp.path().join("xdg"));
    std::fs::create_dir(&home).unwrap();
    let (sim, log) = one_simulation(&home, Some(&home), Some(&xdg), &tmp.path().join("log")).await;
    let base = xdg.join("physics-mcp");
    assert!(base.join("data").join(format!("{sim}.sqlite")).is_file(), "{log}");
    let why = format!("{} is the home directory", home.canonicalize().unwrap().display());
    assert_eq!(log.lines().next(), Some(note(&base, &why).as_str()), "{log}");
    assert!(!home.join("physics-mcp-data").exists(), "the home directory got a physics-mcp-data");
}

#[tokio::test(flavor = "multi_thread")]
async fn from_a_usable_directory_they_stay_there_as_before() {
    let tmp = tempfile::tempdir().unwrap();
    let project = tmp.path().join("project");
    std::fs::create_dir(&project).unwrap();
    let (sim, log) = one_simulation(&project, Some(&tmp.path().join("home")), None, &tmp.path().join("log")).await;
    assert!(project.join("physics-mcp-data").join(format!("{sim}.sqlite")).is_file(), "{log}");
    assert!(project.join("physics-mcp-workspace").is_dir());
    assert!(!log.contains("data in"), "a usable directory needs no note: {log}");
    assert!(!tmp.path().join("home").exists(), "nothing was made in the home directory");
}

#[tokio::test(flavor = "multi_thread")]
async fn an_existing_data_directory_is_always_used_even_at_home() {
    let tmp = tempfile::tempdir().unwrap();
    let home = tmp.path().join("home");
    std::fs::create_dir_all(home.join("physics-mcp-data")).unwrap();
    let (sim, log) = one_simulation(&home, Some(&home), None, &tmp.path().join("log")).await;
    assert!(home.join("physics-mcp-data").join(format!("{sim}.sqlite")).is_file(), "{log}");
    assert!(!home.join(".local").exists(), "the user data directory was used instead: {log}");
}

#[tokio::test(flavor = "multi_thread")]
async fn from_a_directory_it_cannot_write_they_go_to_the_user_data_directory() {
    // SAFETY: geteuid reads the process's effective user id and cannot fail.
    if unsafe { libc::geteuid() } == 0 {
        eprintln!(
            "skipped: root writes to any directory; .ci/run checks this as another user \
             (scripts/install_check.py, with setpriv)"
        );
        return;
    }
    use std::os::unix::fs::PermissionsExt;
    let tmp = tempfile::tempdir().unwrap();
    let (home, locked) = (tmp.path().join("home"), tmp.path().join("read-only"));
    std::fs::create_dir(&home).unwrap();
    std::fs::create_dir(&locked).unwrap();
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
    let (sim, log) = one_simulation(&locked, Some(&home), None, &tmp.path().join("log")).await;
    let base = home.join(".local/share/physics-mcp");
    assert!(base.join("data").join(format!("{sim}.sqlite")).is_file(), "{log}");
    let first = log.lines().next().unwrap_or_default();
    assert!(first.starts_with(&format!("physics-mcp: data in {}", base.join("data").display())), "{log}");
    assert!(first.contains("is not writable"), "{log}");
}

/// Two desktop apps starting `uvx physics-mcp stdio` at once share the defaults. The data
/// directory serves one process (its lock), so the second is refused at start — never left
/// waiting — with the holder's pid and the exact ways out; the first is untouched.
#[tokio::test(flavor = "multi_thread")]
async fn a_second_server_on_the_same_defaults_is_told_what_to_do() {
    let tmp = tempfile::tempdir().unwrap();
    let home = tmp.path().join("home");
    std::fs::create_dir(&home).unwrap();
    let (first, pid) = start(&home, Some(&home), None, &tmp.path().join("first.log")).await;
    create(&first).await;

    let second = std::process::Command::new(crate::common::bin())
        .arg("stdio")
        .current_dir(&home)
        .env_clear()
        .env("PATH", "/usr/bin:/bin")
        .env("HOME", &home)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&second.stderr);
    assert!(!second.status.success(), "the second server started: {said}");
    let data = home.join(".local/share/physics-mcp/data");
    for part in [
        format!("another physics-mcp process (pid {pid}) is using the data directory {}", data.display()),
        "--data DIR --workspace DIR".to_string(),
        r#""args": ["physics-mcp", "stdio", "--data", "DIR", "--workspace", "DIR"]"#.to_string(),
        "one `physics-mcp serve` over HTTP".to_string(),
    ] {
        assert!(said.contains(&part), "missing {part:?} in: {said}");
    }
    // The first still serves, and still has its simulation.
    let listed = first.call_tool(CallToolRequestParams::new("list_simulations").with_arguments(Default::default())).await.unwrap();
    assert_eq!(listed.structured_content.unwrap()["simulations"].as_array().map(Vec::len), Some(1));
    first.cancel().await.unwrap();
}

#[test]
fn without_a_home_it_asks_for_the_flags_and_makes_nothing() {
    if root_holds_data() {
        return;
    }
    let out = std::process::Command::new(crate::common::bin())
        .arg("stdio")
        .current_dir("/")
        .env_clear()
        .env("PATH", "/usr/bin:/bin")
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{said}");
    assert!(
        said.contains("the working directory / is the file system's root and neither XDG_DATA_HOME nor HOME names an absolute directory")
            && said.contains("pass --data DIR and --workspace DIR"),
        "{said}"
    );
    assert!(!Path::new("/physics-mcp-data").exists());
}

