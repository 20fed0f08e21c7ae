//! The MCP Apps test host itself (tests/browser/host.html behind `common::host::Host`), in a
//! real browser against the real server, before any tool has a UI: the page connects through
//! the same-origin proxy (with and without a bearer token), lists the tools, and says cleanly
//! which tool lacks `_meta.ui.resourceUri`. `#[ignore]`d like the other browser tests.

use crate::browser_viewer::run_until;
use crate::common::host::{self, Host};
use crate::common::Server;

/// The host page's first error for `url` (its `{host_error}` report), waiting in wall-clock
/// time; "" when none came within 60 s.
fn host_error(host: &Host, url: &str, profile: &std::path::Path) -> String {
    let before = host.reports().len();
    let error = || {
        host.reports()[before..]
            .iter()
            .filter_map(|r| serde_json::from_str::<serde_json::Value>(r).ok())
            .find_map(|r| r["host_error"].as_str().map(str::to_string))
    };
    let flags: Vec<&str> = host::CHROMIUM_FLAGS.iter().copied().filter(|f| !f.starts_with("--disable-features")).collect();
    run_until(url, profile, &flags, std::time::Duration::from_secs(60), || error().is_some());
    error().unwrap_or_default()
}

#[test]
#[ignore = "needs Chromium; run by .ci/run with --ignored"]
fn browser_the_host_page_lists_tools_and_names_a_missing_ui_resource() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let host = Host::start(server.base_url());
    let error = host_error(&host, &host.url("list_simulations", "{}"), &dir.path().join("profile-a"));
    assert!(
        error.starts_with(r#"Error: tool list_simulations has no _meta.ui.resourceUri (nor _meta["ui/resourceUri"]) in tools/list"#),
        "host error: {error:?}"
    );
    let error = host_error(&host, &host.url("no_such_tool", "{}"), &dir.path().join("profile-b"));
    assert!(error.starts_with("Error: no tool named no_such_tool in tools/list"), "host error: {error:?}");
}

#[test]
#[ignore = "needs Chromium; run by .ci/run with --ignored"]
fn browser_the_host_page_sends_the_bearer_token() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--token", "s3cret"]);
    let host = Host::start(server.base_url());
    let error = host_error(&host, &host.url_with_token("list_simulations", "{}", "s3cret"), &dir.path().join("profile-a"));
    assert!(error.contains("has no _meta.ui.resourceUri"), "with the token: {error:?}");
    let error = host_error(&host, &host.url("list_simulations", "{}"), &dir.path().join("profile-b"));
    assert!(!error.is_empty() && !error.contains("has no _meta.ui.resourceUri"), "without the token: {error:?}");
}
