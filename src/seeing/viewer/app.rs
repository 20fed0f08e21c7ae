//! The viewer page, assembled once: `page.html` with three.js (vendored, `vendor/`) inlined,
//! so the page — in a browser tab or as the MCP App `ui://physics-mcp/viewer` in a host's
//! sandboxed iframe — loads nothing from anywhere. The same page runs in both: in a tab it
//! asks the server over HTTP (`/viewer/{id}/{kind}`); as an app it asks the host to read
//! `sim://{id}/viewer/{kind}` (MCP Apps, SEP-1865), never making a request of its own.

use std::sync::LazyLock;

use rmcp::model::MetaObject;
use serde_json::json;

/// The app's resource URI, linked from tools' `_meta.ui.resourceUri`.
pub const APP_URI: &str = "ui://physics-mcp/viewer";
/// MCP Apps' HTML resource type.
pub const APP_MIME: &str = "text/html;profile=mcp-app";
/// The extension a client announces to get app links (`io.modelcontextprotocol/ui`).
pub const UI_EXTENSION: &str = "io.modelcontextprotocol/ui";
/// The tools whose results a person wants to look at: a host shows the app beside them.
pub const LINKED_TOOLS: [&str; 4] = ["create_simulation", "step_simulation", "render_animation", "get_trajectory"];

const TEMPLATE: &str = include_str!("page.html");
/// three.js, bundled by `scripts/vendor_refresh.sh` into one script that defines `THREE`.
const THREE: &str = include_str!("vendor/three.min.js");

/// The page with three.js inlined and `mode` ("page" or "app") and `sim_id` filled in.
fn assemble(mode: &str, sim_id: &str) -> String {
    // The id is a UUID we issued, but keep only its characters: it lands in HTML and JS.
    let safe: String = sim_id.chars().filter(|c| c.is_ascii_alphanumeric() || *c == '-').collect();
    TEMPLATE.replace("{{MODE}}", mode).replace("{{SIM_ID}}", &safe).replace("{{THREE}}", THREE)
}

/// The page for simulation `sim_id` in a browser tab.
pub fn page(sim_id: &str) -> String {
    assemble("page", sim_id)
}

static APP: LazyLock<String> = LazyLock::new(|| assemble("app", ""));

/// The MCP App's HTML (which simulation it shows comes from the tool call the host shows it
/// beside).
pub fn app_html() -> &'static str {
    &APP
}

/// The app resource's `_meta.ui`: no outside origin needed, and no border (the page draws
/// its own).
pub fn resource_meta() -> MetaObject {
    let ui = json!({"csp": {"connectDomains": [], "resourceDomains": []}, "prefersBorder": false});
    MetaObject(serde_json::Map::from_iter([("ui".to_string(), ui)]))
}

/// A linked tool's `_meta`: the app to show beside its result.
pub fn tool_meta() -> MetaObject {
    MetaObject(serde_json::Map::from_iter([("ui".to_string(), json!({"resourceUri": APP_URI}))]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_page_is_self_contained_and_fits_a_reply() {
        assert!(!THREE.contains("</script"), "the bundle would end its inline script early");
        let html = app_html();
        assert!(html.len() < 1024 * 1024, "the app is {} bytes; a reply must stay under 1 MiB", html.len());
        for outside in ["src=\"http", "href=\"http", "fetch(\"http", "fetch(`http", "url(http", "import("] {
            assert!(!TEMPLATE.contains(outside), "the page references {outside}");
        }
        assert!(!page("abc\"<x").contains("abc\"<x"), "the id is filtered");
    }
}
