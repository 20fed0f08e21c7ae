//! The reply budget (docs/tools.md "Conventions"), measured where a call is decided: no reply — the
//! serialized JSON-RPC message — exceeds `--max-reply-bytes` (the Python MCP SDK drops an SSE
//! event over 1 MiB). The simulation layer measures a reply *before* it commits or logs the
//! call, so a reply never contradicts the log:
//!
//! - a state-changing call's reply is shortened to fit ([`shorten`]: its longest lists cut,
//!   with `truncated: true` and the counts left out) or the call is refused before anything
//!   commits — never an error after a commit;
//! - a read's reply, images included, is measured before the read is logged; one that does
//!   not fit is refused and logged as refused, saying what to change.
//!
//! The MCP layer sends exactly what was measured: the same functions build it (`summarized`,
//! `shorten`), and `mcp::reply::fit` is only a last guard. Tools with a documented
//! per-element upper bound (ray_test_batch per ray, get_camera_image per pixel) also refuse
//! before the work with [`check_bound`].

use rmcp::model::{CallToolResult, ContentBlock};
use serde_json::Value;

use crate::value::Refusal;

/// structuredContent over this many bytes (compact JSON) gets a text summary, not a copy.
pub const SUMMARY_OVER: usize = 64 * 1024;

/// Bytes kept for what wraps a result on the wire: the JSON-RPC envelope
/// (`{"jsonrpc":"2.0","id":…,"result":…}`) and the SSE framing (`id:`, `data: `, blank line).
pub const ENVELOPE: usize = 256;

/// The smallest `--max-reply-bytes` accepted: every state-changing reply, its lists
/// shortened, fits in it, so a change is never refused for its reply's size alone.
pub const MIN_REPLY_BYTES: usize = 16 * 1024;

/// The most bytes one ray_test_batch result takes in the reply (compact JSON, comma
/// included): field names and punctuation (~100 B), object and link ids (≤ 21 B) and seven
/// f32 numbers in shortest form (≤ 15 B each).
pub const RAY_BYTES_MAX: usize = 240;

/// The most bytes one depth value takes in a camera reply: an f32 in shortest form and a comma.
pub const DEPTH_BYTES_MAX: usize = 16;

/// The most bytes one segmentation value takes in a camera reply: an object id and a comma.
pub const SEGMENT_BYTES_MAX: usize = 11;

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

/// Where the rest of a shortened list can be read, per tool.
fn where_the_rest_is(tool: &str) -> &'static str {
    match tool {
        "load_mjcf" => "get_num_joints and get_joint_info list every link and joint",
        _ => "ask for less at a time",
    }
}

/// The refusal of a reply of `bytes` bytes over `budget`: one sentence naming the fix.
pub fn over_budget(tool: &str, bytes: u64, budget: usize) -> Refusal {
    format!(
        "The {tool} reply would be {bytes} bytes, over the reply budget of {budget} bytes (--max-reply-bytes); ask for {}",
        what_to_change(tool)
    )
}

/// Refuses before the work when `elements` × `per_element` bytes (a documented upper bound)
/// cannot fit the budget.
pub fn check_bound(tool: &str, elements: u64, per_element: usize, budget: usize) -> Result<(), Refusal> {
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
pub fn check_structured_bound(tool: &str, structured: u64, budget: usize) -> Result<(), Refusal> {
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

/// An image a reply carries beside its structured content (camera PNG, animation GIF).
pub struct Image<'a> {
    /// The encoded image.
    pub bytes: &'a [u8],
    /// Its MIME type.
    pub mime: &'static str,
}

/// The reply of `tool` carrying `structured` and `images`, as it goes out: the images first,
/// then the text copy (or its summary).
pub fn reply(tool: &str, structured: Value, images: &[Image]) -> CallToolResult {
    use base64::Engine;
    let mut result = summarized(tool, CallToolResult::structured(structured));
    for (i, image) in images.iter().enumerate() {
        let b64 = base64::engine::general_purpose::STANDARD.encode(image.bytes);
        result.content.insert(i, ContentBlock::image(b64, image.mime));
    }
    result
}

/// The bytes the reply of `tool` carrying `structured` and `images` takes, envelope included.
pub fn reply_bytes_with(tool: &str, structured: Value, images: &[Image]) -> usize {
    bytes_of(&reply(tool, structured, images))
}

/// The bytes a successful reply of `tool` carrying `structured` takes, envelope included.
pub fn reply_bytes(tool: &str, structured: Value) -> usize {
    reply_bytes_with(tool, structured, &[])
}

/// The serialized size of a result, envelope included.
pub fn bytes_of(result: &CallToolResult) -> usize {
    serde_json::to_vec(result).map_or(usize::MAX, |v| v.len()).saturating_add(ENVELOPE)
}

/// The reply `structured` of a state-changing call as it may go out within `budget`: as it
/// is when it fits; else its longest lists are cut (halving, first items kept) until it does,
/// with `truncated: true`, `omitted` (per list, how many items were left out) and `rest`
/// (where to read them). Refused only when even empty lists would not fit. Deterministic, so
/// what the simulation measured before committing is what the MCP layer sends.
pub fn shorten(tool: &str, structured: Value, budget: usize) -> Result<Value, Refusal> {
    let full = reply_bytes(tool, structured.clone());
    if full <= budget {
        return Ok(structured);
    }
    let Value::Object(mut fields) = structured else {
        return Err(over_budget(tool, full as u64, budget));
    };
    let totals: Vec<(String, usize)> = fields
        .iter()
        .filter_map(|(k, v)| v.as_array().filter(|a| !a.is_empty()).map(|a| (k.clone(), a.len())))
        .collect();
    loop {
        let longest = fields
            .iter()
            .filter_map(|(k, v)| v.as_array().filter(|a| !a.is_empty()).map(|a| (k.clone(), serde_json::to_vec(a).map_or(0, |b| b.len()))))
            .max_by_key(|(_, bytes)| *bytes);
        let Some((name, _)) = longest else {
            return Err(over_budget(tool, full as u64, budget));
        };
        if let Some(Value::Array(items)) = fields.get_mut(&name) {
            items.truncate(items.len() / 2);
        }
        let omitted: serde_json::Map<String, Value> = totals
            .iter()
            .filter_map(|(k, total)| {
                let kept = fields.get(k).and_then(Value::as_array).map_or(0, Vec::len);
                (kept < *total).then(|| (k.clone(), Value::from(total - kept)))
            })
            .collect();
        fields.insert("truncated".into(), Value::Bool(true));
        fields.insert("omitted".into(), Value::Object(omitted));
        fields.insert("rest".into(), Value::String(where_the_rest_is(tool).into()));
        let shortened = Value::Object(fields.clone());
        if reply_bytes(tool, shortened.clone()) <= budget {
            return Ok(shortened);
        }
    }
}

/// `result` with its text copy replaced by a summary when structuredContent is over
/// [`SUMMARY_OVER`].
pub fn summarized(tool: &str, mut result: CallToolResult) -> CallToolResult {
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

// ---- What a request costs, estimated before it runs (docs/guarantees.md "Isolation") ----

/// What a batch's reply carries besides its results: the JSON-RPC envelope, `head_seq`,
/// `time`, `state_hash` and the text copy's framing (the text copy itself is measured at the
/// end; what is metered as calls run is the structured results, each once).
pub const BATCH_ENVELOPE: usize = ENVELOPE + 160;

/// The fewest bytes one object takes in get_simulation_info's `objects` (compact JSON: its id,
/// shape, position, mass, …; measured ≥ 90 on boxes): a lower bound, so pricing never refuses
/// what would fit.
pub const INFO_BYTES_PER_OBJECT_MIN: usize = 60;

/// The fewest bytes any other read takes in a batch's reply.
pub const READ_BYTES_MIN: usize = 40;

/// Memory a world takes per body (rapier's sets, the broad and narrow phase, our tables),
/// measured on boxes resting in a pile (≈ 4.8 KiB each) and rounded up: what a world copy
/// (a batch's, a sweep fork's) is priced at.
pub const WORLD_BYTES_PER_BODY: usize = 6 * 1024;

/// The memory `world` is priced at: its bodies (a robot's links each count) times
/// [`WORLD_BYTES_PER_BODY`].
pub fn world_bytes(world: &crate::world::World) -> usize {
    let bodies: usize = world.objects().map(|(id, _)| 1 + world.link_count(id)).sum();
    bodies.max(1).saturating_mul(WORLD_BYTES_PER_BODY)
}

/// Refuses before the work a batch whose reads alone would reply more than `budget`: each
/// get_simulation_info read at least [`INFO_BYTES_PER_OBJECT_MIN`] per object of the world as
/// it is, every other read at least [`READ_BYTES_MIN`]. The sentence says how many fit.
pub fn batch_reads(calls: &[crate::sim::apply::Call], world: &crate::world::World, budget: usize) -> Result<(), Refusal> {
    use crate::sim::apply::Planned;
    use crate::sim::reads::Read;
    let per_info = world.object_count().saturating_mul(INFO_BYTES_PER_OBJECT_MIN).max(READ_BYTES_MIN);
    let (mut infos, mut others) = (0usize, 0usize);
    for c in calls {
        match &c.planned {
            Planned::Read(Ok(r)) if matches!(**r, Read::SimulationInfo(_)) => infos += 1,
            Planned::Read(_) => others += 1,
            Planned::Change(_) => {}
        }
    }
    let least = infos.saturating_mul(per_info).saturating_add(others.saturating_mul(READ_BYTES_MIN)).saturating_add(BATCH_ENVELOPE);
    if least <= budget || infos == 0 {
        return Ok(());
    }
    let fit = budget.saturating_sub(BATCH_ENVELOPE) / per_info;
    Err(format!(
        "calls: the batch's {infos} get_simulation_info reads of {} objects would reply at least {least} bytes, over the reply budget of {budget} bytes (--max-reply-bytes); at most {fit} such reads fit in one batch",
        world.object_count()
    ))
}

/// Refuses a call in a batch whose result would take the batch's reply past `budget` (the
/// batch then stops there and changes nothing).
pub fn batch_over_budget(index: usize, budget: usize) -> Refusal {
    format!(
        "its result would take the batch's reply past the reply budget of {budget} bytes (--max-reply-bytes); send calls[..{index}] in one batch and the rest in another, or fewer reads per batch"
    )
}

/// Refuses before the work a request (`what`) that would copy `world` when the copy would
/// take more than `max` bytes (`--max-request-bytes`).
pub fn world_copy(world: &crate::world::World, max: usize, what: &str) -> Result<(), Refusal> {
    let bytes = world_bytes(world);
    if bytes <= max {
        return Ok(());
    }
    Err(format!(
        "the {what} would copy a world of {} objects (about {} MiB), over the {} MiB one request may hold (--max-request-bytes)",
        world.object_count(),
        bytes >> 20,
        max >> 20
    ))
}

/// Refuses before the work a sweep whose forks would take more than `max` bytes: the forks in
/// flight (one per worker) and the kept ones, each priced as a copy of `world`. The sentence
/// says how many variants (kept) or workers fit.
pub fn sweep_forks(world: &crate::world::World, variants: usize, workers: usize, keep: bool, max: usize) -> Result<(), Refusal> {
    let each = world_bytes(world);
    let held = if keep { variants } else { workers.min(variants) };
    let bytes = held.saturating_mul(each);
    if bytes <= max {
        return Ok(());
    }
    let fit = (max / each.max(1)).max(if keep { 0 } else { 1 });
    Err(format!(
        "the sweep would hold {held} forks of {} objects in memory (about {} MiB), over the {} MiB one request may hold (--max-request-bytes); {}",
        world.object_count(),
        bytes >> 20,
        max >> 20,
        if keep { format!("keep at most {fit} variants per sweep, or set keep=false") } else { "sweep a smaller world".to_string() }
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn a_long_list_is_cut_to_fit_with_counts() {
        let names: Vec<Value> = (0..4000).map(|i| json!({"name": format!("body_with_a_long_name_{i:05}"), "link_index": i})).collect();
        let full = json!({"object_id": 3, "bodies": names, "ignored": ["a", "b"]});
        let out = shorten("load_mjcf", full, 64 * 1024).unwrap();
        assert!(reply_bytes("load_mjcf", out.clone()) <= 64 * 1024);
        assert_eq!(out["truncated"], true);
        let kept = out["bodies"].as_array().unwrap().len();
        assert_eq!(out["omitted"]["bodies"].as_u64().unwrap() as usize, 4000 - kept);
        assert_eq!(out["ignored"], json!(["a", "b"]));
        assert_eq!(out["object_id"], 3);
    }

    #[test]
    fn a_reply_that_fits_is_untouched() {
        let small = json!({"object_id": 1, "bodies": [1, 2, 3]});
        assert_eq!(shorten("load_mjcf", small.clone(), 1 << 20).unwrap(), small);
    }

    #[test]
    fn images_are_measured_as_sent() {
        let png = vec![7u8; 1000];
        let sent = reply("get_camera_image", json!({"width": 2}), &[Image { bytes: &png, mime: "image/png" }]);
        assert_eq!(reply_bytes_with("get_camera_image", json!({"width": 2}), &[Image { bytes: &png, mime: "image/png" }]), bytes_of(&sent));
        assert!(bytes_of(&sent) > 1000 * 4 / 3);
    }
}
