//! The last guard of the reply budget: one place that sees every tools/call result as it goes
//! out. The simulation layer has already measured every reply with `crate::sim::budget` before it
//! committed or logged the call, so here a reply is only given its text summary (large
//! results) and, should it still not fit, shortened the same way (`budget::shorten`) or —
//! a measurement missed somewhere, logged as an error — refused.

use rmcp::model::{CallToolResult, ContentBlock};

use crate::sim::budget::{self, bytes_of};

/// The reply `result` of `tool` as it may go out within `budget` bytes. A state-changing
/// tool's reply over the budget is shortened exactly as the simulation measured it before
/// committing (`budget::shorten` is deterministic); a read's never should be (it was measured
/// before it was logged), so one that is counts as a bug and is logged as an error.
pub(crate) fn fit(tool: &str, result: CallToolResult, budget: usize, read_only: bool) -> CallToolResult {
    let result = budget::summarized(tool, result);
    let bytes = bytes_of(&result);
    if bytes <= budget {
        return result;
    }
    if result.is_error != Some(true) && !result.content.iter().any(|c| c.as_text().is_none()) {
        if let Some(structured) = result.structured_content.clone() {
            if let Ok(short) = budget::shorten(tool, structured, budget) {
                if read_only {
                    tracing::error!(tool, bytes, budget, "a read's reply over the budget was not measured before it was logged");
                }
                return budget::reply(tool, short, &[]);
            }
        }
    }
    let why = budget::over_budget(tool, bytes as u64, budget);
    tracing::error!(tool, bytes, budget, "a reply over the budget was not measured before its call was recorded: {why}");
    CallToolResult::error(vec![ContentBlock::text(why)])
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn a_large_result_keeps_structured_content_and_a_short_text() {
        let big = json!({"results": vec![json!({"hit": false}); 10_000], "head_seq": 3});
        let out = fit("ray_test_batch", CallToolResult::structured(big.clone()), 1 << 20, true);
        assert_eq!(out.structured_content, Some(big));
        assert_eq!(out.content.len(), 1);
        let text = &out.content[0].as_text().unwrap().text;
        assert!(text.contains("results: 10000 items") && text.contains("head_seq: 3"), "{text}");
        assert!(text.len() < 300, "{text}");
    }

    #[test]
    fn a_small_result_is_untouched() {
        let small = json!({"a": 1});
        let out = fit("get_object_state", CallToolResult::structured(small.clone()), 1 << 20, true);
        assert_eq!(out.content[0].as_text().unwrap().text, small.to_string());
    }

    #[test]
    fn over_budget_is_shortened_or_refused_naming_the_fix() {
        let big = json!({"results": vec![1.5; 100_000]});
        let out = fit("ray_test_batch", CallToolResult::structured(big), 100_000, true);
        assert_ne!(out.is_error, Some(true));
        assert_eq!(out.structured_content.as_ref().unwrap()["truncated"], true);
        let scalar = json!({"text": "x".repeat(200_000)});
        let out = fit("ray_test_batch", CallToolResult::structured(scalar), 100_000, true);
        assert_eq!(out.is_error, Some(true));
        let text = &out.content[0].as_text().unwrap().text;
        assert!(text.contains("fewer rays") && text.contains("output_path"), "{text}");
        assert!(budget::check_bound("ray_test_batch", 16_384, budget::RAY_BYTES_MAX, 1 << 20).is_err());
        assert!(budget::check_bound("ray_test_batch", 1_000, budget::RAY_BYTES_MAX, 1 << 20).is_ok());
    }
}
