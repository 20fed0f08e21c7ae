//! The reply budget (SPEC "Conventions"): one place that sees every tools/call result as it
//! goes out. The Python MCP SDK drops an SSE event over 1 MiB, so a reply that does not fit
//! `--max-reply-bytes` is replaced by a refusal that says what to change; and a result whose
//! structuredContent is large carries a short text summary instead of a second full copy.
//!
//! Tools whose reply size has a documented per-element upper bound (ray_test_batch per ray,
//! get_camera_image's depth and segmentation per pixel) also refuse *before* the work with
//! [`check_bound`], so a client is not made to wait for a result it cannot receive. A
//! state-changing tool's reply is a few hundred bytes (ids, a sentence, a hash) and cannot be
//! over budget in practice; the check covers it anyway, at no cost to its recorded event.

use rmcp::model::{CallToolResult, ContentBlock};
use serde_json::Value;

use crate::value::Refusal;

/// structuredContent over this many bytes (compact JSON) gets a text summary, not a copy.
pub(crate) const SUMMARY_OVER: usize = 64 * 1024;

/// Bytes kept for what wraps a result on the wire: the JSON-RPC envelope
/// (`{"jsonrpc":"2.0","id":…,"result":…}`) and the SSE framing (`id:`, `data: `, blank line).
pub(crate) const ENVELOPE: usize = 256;

/// The most bytes one ray_test_batch result takes in the reply (compact JSON, comma
/// included): field names and punctuation (~100 B), object and link ids (≤ 21 B) and seven
/// f32 numbers in shortest form (≤ 15 B each).
pub(crate) const RAY_BYTES_MAX: usize = 240;

/// The most bytes one depth value takes in a camera reply: an f32 in shortest form and a comma.
pub(crate) const DEPTH_BYTES_MAX: usize = 16;

/// The most bytes one segmentation value takes in a camera reply: an object id and a comma.
pub(crate) const SEGMENT_BYTES_MAX: usize = 11;

/// What to change, per tool, when its reply would not fit.
fn what_to_change(tool: &str) -> &'static str {
    match tool {
        "ray_test_batch" => "fewer rays, or output_path (a .json file in the workspace)",
        "get_camera_image" => {
            "a smaller width and height, no include_depth/include_segmentation, or output_path (a .png file in the workspace)"
        }
        "get_trajectory" => "a larger every, fewer object_ids, or output_path (a .csv or .jsonl file in the workspace)",
        "render_animation" => "a larger every, a smaller width and height, or output_path (a .gif file in the workspace)",
        "step_simulation" => "a larger sample_every or fewer sample_objects",
        "get_history" => "a smaller limit",
        "get_all_collisions" => "get_collisions_for_pair for the pairs you need",
        "batch" => "fewer calls per batch (or fewer reads in it)",
        "run_sweep" => "fewer object_ids, a larger every, or fewer variants per sweep",
        _ => "a smaller request",
    }
}

/// The refusal of a reply of `bytes` bytes over `budget`: one sentence naming the fix.
pub(crate) fn over_budget(tool: &str, bytes: u64, budget: usize) -> Refusal {
    format!(
        "The {tool} reply would be {bytes} bytes, over the reply budget of {budget} bytes (--max-reply-bytes); ask for {}",
        what_to_change(tool)
    )
}

/// Refuses before the work when `elements` × `per_element` bytes (a documented upper bound)
/// cannot fit the budget.
pub(crate) fn check_bound(tool: &str, elements: u64, per_element: usize, budget: usize) -> Result<(), Refusal> {
    let bytes = elements.saturating_mul(per_element as u64);
    if bytes.saturating_add(ENVELOPE as u64) > budget as u64 {
        return Err(over_budget(tool, bytes, budget));
    }
    Ok(())
}

/// Refuses before the work when a result whose structuredContent is at most `structured`
/// bytes could not fit: for a state-changing call (step_simulation's samples), which cannot be
/// refused once its steps are taken. Below [`SUMMARY_OVER`] the text copy rides along, its
/// escaping at most doubling it; above, a summary of at most a few KB does.
pub(crate) fn check_structured_bound(tool: &str, structured: u64, budget: usize) -> Result<(), Refusal> {
    let reply = if structured > SUMMARY_OVER as u64 {
        structured.saturating_add(4096)
    } else {
        structured.saturating_mul(3).saturating_add(1024)
    };
    if reply.saturating_add(ENVELOPE as u64) > budget as u64 {
        return Err(over_budget(tool, reply, budget));
    }
    Ok(())
}

/// The reply `result` of `tool` as it may go out: a short text summary in place of the text
/// copy when structuredContent is over [`SUMMARY_OVER`], and a refusal instead of a reply
/// over `budget` bytes.
pub(crate) fn fit(tool: &str, result: CallToolResult, budget: usize) -> CallToolResult {
    let result = summarized(tool, result);
    let bytes = serde_json::to_vec(&result).map_or(usize::MAX, |v| v.len());
    if bytes.saturating_add(ENVELOPE) <= budget {
        return result;
    }
    let why = over_budget(tool, bytes as u64, budget);
    tracing::info!(tool, bytes, budget, "refused: {why}");
    CallToolResult::error(vec![ContentBlock::text(why)])
}

/// The bytes a successful reply of `tool` carrying `structured` takes, envelope included, as
/// `fit` would send it: for tools that shorten a result to fit (get_history's pages).
pub(crate) fn reply_bytes(tool: &str, structured: serde_json::Value) -> usize {
    let result = summarized(tool, CallToolResult::structured(structured));
    serde_json::to_vec(&result).map_or(usize::MAX, |v| v.len()).saturating_add(ENVELOPE)
}

/// `result` with its text copy replaced by a summary when structuredContent is over
/// [`SUMMARY_OVER`].
fn summarized(tool: &str, mut result: CallToolResult) -> CallToolResult {
    if let Some(structured) = &result.structured_content {
        let bytes = serde_json::to_vec(structured).map_or(0, |v| v.len());
        if bytes > SUMMARY_OVER {
            let text = summary(tool, structured, bytes);
            let mut put = false;
            result.content.retain_mut(|c| match c {
                ContentBlock::Text(_) if !put => {
                    *c = ContentBlock::text(text.clone());
                    put = true;
                    true
                }
                ContentBlock::Text(_) => false,
                _ => true,
            });
        }
    }
    result
}

/// A few lines a model can act on without the full JSON: the tool, the size, and each
/// top-level field's count or value.
fn summary(tool: &str, structured: &Value, bytes: usize) -> String {
    let mut parts = Vec::new();
    if let Value::Object(fields) = structured {
        for (k, v) in fields {
            let part = match v {
                Value::Array(items) => format!("{k}: {} items", items.len()),
                Value::Object(inner) => format!("{k}: {{{} fields}}", inner.len()),
                Value::String(s) if s.len() > 80 => format!("{k}: a string of {} bytes", s.len()),
                other => format!("{k}: {other}"),
            };
            parts.push(part);
        }
    }
    format!(
        "{tool}: {bytes} bytes of JSON, full result in structuredContent. {}",
        parts.join("; ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn a_large_result_keeps_structured_content_and_a_short_text() {
        let big = json!({"results": vec![json!({"hit": false}); 10_000], "head_seq": 3});
        let out = fit("ray_test_batch", CallToolResult::structured(big.clone()), 1 << 20);
        assert_eq!(out.structured_content, Some(big));
        assert_eq!(out.content.len(), 1);
        let text = &out.content[0].as_text().unwrap().text;
        assert!(text.contains("results: 10000 items") && text.contains("head_seq: 3"), "{text}");
        assert!(text.len() < 300, "{text}");
    }

    #[test]
    fn a_small_result_is_untouched() {
        let small = json!({"a": 1});
        let out = fit("get_object_state", CallToolResult::structured(small.clone()), 1 << 20);
        assert_eq!(out.content[0].as_text().unwrap().text, small.to_string());
    }

    #[test]
    fn over_budget_is_a_refusal_naming_the_fix() {
        let big = json!({"results": vec![1.5; 100_000]});
        let out = fit("ray_test_batch", CallToolResult::structured(big), 100_000);
        assert_eq!(out.is_error, Some(true));
        assert!(out.structured_content.is_none());
        let text = &out.content[0].as_text().unwrap().text;
        assert!(text.contains("fewer rays") && text.contains("output_path"), "{text}");
        assert!(check_bound("ray_test_batch", 16_384, RAY_BYTES_MAX, 1 << 20).is_err());
        assert!(check_bound("ray_test_batch", 1_000, RAY_BYTES_MAX, 1 << 20).is_ok());
    }
}
