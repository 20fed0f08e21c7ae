//! `physics-mcp call URL TOOL '{json}'`: one tool call from a shell, through rmcp's own
//! streamable-HTTP client (initialize, call, end the session), so every example in the README
//! runs from a clone of this repository alone, with no other MCP client installed.

use rmcp::model::{CallToolRequestParams, CallToolResult};
use rmcp::transport::streamable_http_client::StreamableHttpClientTransportConfig;
use rmcp::transport::StreamableHttpClientTransport;
use rmcp::ServiceExt;
use serde_json::Value;

/// What a call printed and whether the tool refused it.
pub struct Called {
    /// The result as a shell user wants it: structuredContent as pretty JSON, else the text
    /// content; images and other binary content are summarised, not dumped.
    pub output: String,
    /// The tool's `isError`.
    pub is_error: bool,
}

/// Calls `tool` with `args` (a JSON object, as text) on the MCP server at `url`.
pub async fn call(url: &str, tool: &str, args: &str, token: Option<&str>) -> anyhow::Result<Called> {
    let args: Value = serde_json::from_str(args).map_err(|e| anyhow::anyhow!("the arguments are not JSON: {e}"))?;
    let Value::Object(args) = args else { anyhow::bail!("the arguments must be a JSON object, e.g. '{{\"sim_id\": \"...\"}}'") };
    let mut config = StreamableHttpClientTransportConfig::with_uri(url);
    if let Some(t) = token {
        config = config.auth_header(t);
    }
    let service = ().serve(StreamableHttpClientTransport::from_config(config)).await?;
    let result = service.call_tool(CallToolRequestParams::new(tool.to_string()).with_arguments(args)).await;
    let _ = service.cancel().await;
    Ok(render(&result?))
}

/// A result as printed: structured JSON when there is some, else its contents.
fn render(r: &CallToolResult) -> Called {
    let is_error = r.is_error == Some(true);
    let mut parts: Vec<String> = Vec::new();
    if let (false, Some(v)) = (is_error, &r.structured_content) {
        parts.push(serde_json::to_string_pretty(v).unwrap_or_default());
    } else {
        parts.extend(r.content.iter().filter_map(|c| c.as_text().map(|t| t.text.clone())));
    }
    for c in &r.content {
        if let Some(img) = c.as_image() {
            parts.push(format!("[{} image, {} bytes of base64 not shown]", img.mime_type, img.data.len()));
        }
    }
    Called { output: parts.join("\n"), is_error }
}
