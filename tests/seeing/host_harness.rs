//! The MCP Apps test host itself (tests/browser/host.html behind `common::host::Host`), in a
//! real browser against the real server, before any tool has a UI: the page connects through
//! the same-origin proxy (with and without a bearer token), lists the tools, and says cleanly
//! which tool lacks `_meta.ui.resourceUri`. `#[ignore]`d like the other browser tests.

use crate::browser_viewer::headless;
use crate::common::host::{self, Host};
use crate::common::Server;

/// The text of `<pre id="ID">` in a dumped DOM.
fn pre(dom: &str, id: &str) -> String {
    let open = format!("<pre id=\"{id}\">");
    let Some(start) = dom.find(&open) else { return format!("no #{id} in {} bytes of DOM", dom.len()) };
    let rest = &dom[start + open.len()..];
    rest[..rest.find("</pre>").unwrap_or(rest.len())].to_string()
}

/// The host page's `#host-error` for `url`, given more virtual time if the page is not done.
fn host_error(url: &str, profile: &std::path::Path) -> String {
    let mut error = String::new();
    for (attempt, budget) in [3_000, 15_000].into_iter().enumerate() {
        let mut flags = host::CHROMIUM_FLAGS.to_vec();
        flags.push("--dump-dom");
        let dom = headless(url, &profile.join(attempt.to_string()), budget, &flags);
        error = pre(&dom, "host-error");
        if !error.is_empty() {
            break;
        }
    }
    error
}

#[test]
#[ignore = "needs Chromium; run by .ci/run with --ignored"]
fn browser_the_host_page_lists_tools_and_names_a_missing_ui_resource() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let host = Host::start(server.base_url());
    let error = host_error(&host.url("list_simulations", "{}"), &dir.path().join("profile-a"));
    assert!(
        error.starts_with(r#"Error: tool list_simulations has no _meta.ui.resourceUri (nor _meta["ui/resourceUri"]) in tools/list"#),
        "host error: {error:?}"
    );
    let error = host_error(&host.url("no_such_tool", "{}"), &dir.path().join("profile-b"));
    assert!(error.starts_with("Error: no tool named no_such_tool in tools/list"), "host error: {error:?}");
}

#[test]
#[ignore = "needs Chromium; run by .ci/run with --ignored"]
fn browser_the_host_page_sends_the_bearer_token() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--token", "s3cret"]);
    let host = Host::start(server.base_url());
    let error = host_error(&host.url_with_token("list_simulations", "{}", "s3cret"), &dir.path().join("profile-a"));
    assert!(error.contains("has no _meta.ui.resourceUri"), "with the token: {error:?}");
    let error = host_error(&host.url("list_simulations", "{}"), &dir.path().join("profile-b"));
    assert!(!error.is_empty() && !error.contains("has no _meta.ui.resourceUri"), "without the token: {error:?}");
}
