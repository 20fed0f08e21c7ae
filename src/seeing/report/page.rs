//! The report as one HTML page with everything inline: pictures as `data:` URIs, plots as
//! inline SVG, styles in the page, no script at all. Its Content-Security-Policy forbids
//! every request (`default-src 'none'`, images only from `data:`), so a page that tried to
//! load anything would show it broken rather than reach out.

use std::fmt::Write;

use base64::Engine;

use super::{plots, Story};
use crate::log::sqlite::{Event, Kind};

const STYLE: &str = "
body { font: 14px system-ui, sans-serif; margin: 16px 24px; color: #222; max-width: 1200px; }
h1 { font-size: 20px; } h2 { font-size: 16px; margin-top: 24px; }
table.header td { padding: 2px 12px 2px 0; } table.header td:first-child { color: #666; }
code, td.mono { font-family: ui-monospace, monospace; font-size: 12px; }
.ok { color: #1a7f37; } .bad { color: #cf222e; }
.plots { display: flex; flex-wrap: wrap; gap: 12px; }
table.timeline { border-collapse: collapse; width: 100%; }
table.timeline th { text-align: left; border-bottom: 2px solid #ccc; padding: 4px; position: sticky; top: 0; background: #fff; }
table.timeline td { border-bottom: 1px solid #eee; padding: 3px 4px; vertical-align: top; }
tr.refused td { color: #999; } tr.refused td.outcome { color: #cf222e; }
tr.inherited td.seq::after { content: ' ↰'; color: #999; }
td.args { max-width: 420px; overflow-wrap: anywhere; }
";

/// Escapes text for HTML content and attribute values.
fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// An event's arguments in short: `name=value` without the sim_id, at most 120 characters.
fn short_args(e: &Event) -> String {
    let text = match serde_json::from_str::<serde_json::Value>(&e.arguments) {
        Ok(serde_json::Value::Object(m)) => m
            .iter()
            .filter(|(k, _)| k.as_str() != "sim_id")
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(" "),
        _ => e.arguments.clone(),
    };
    if text.chars().count() > 120 {
        format!("{}…", text.chars().take(119).collect::<String>())
    } else {
        text
    }
}

fn b64(bytes: &[u8]) -> String {
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

/// The page for a gathered story.
pub fn html(story: &Story) -> Result<String, String> {
    let mut p = String::new();
    let sim = esc(&story.simulation_id);
    let w = |r: std::fmt::Result| r.map_err(|e| e.to_string());
    w(write!(
        p,
        "<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; img-src data:; style-src 'unsafe-inline'\">\n\
         <title>physics-mcp report · {sim}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n"
    ))?;
    let changes = story.events.iter().filter(|e| e.kind.is_state_changing()).count();
    let refused = story.events.iter().filter(|e| e.kind == Kind::Refused).count();
    let verdict_class = if story.verdict.starts_with("verified") { "ok" } else { "bad" };
    w(write!(
        p,
        "<h1>Session report</h1>\n<table class=\"header\">\n\
         <tr><td>simulation</td><td><code>{sim}</code></td></tr>\n\
         <tr><td>events</td><td>{} ({changes} state-changing, {refused} refused)</td></tr>\n\
         <tr><td>simulated time</td><td>{:.4} s</td></tr>\n\
         <tr><td>final state hash</td><td><code>{}</code></td></tr>\n\
         <tr><td>replay</td><td class=\"{verdict_class}\" id=\"verdict\">{}</td></tr>\n</table>\n",
        story.events.len(),
        story.end_time,
        esc(&story.final_hash),
        esc(&story.verdict)
    ))?;
    w(write!(
        p,
        "<h2>The run</h2>\n<p><img id=\"animation\" width=\"320\" height=\"240\" alt=\"the whole run, {} frames\" src=\"data:image/gif;base64,{}\"></p>\n",
        story.frames,
        b64(&story.gif)
    ))?;
    if !story.courses.is_empty() {
        let height = plots::chart("Height over time", "height z (m)", &story.courses, |c| &c.height)?;
        let speed = plots::chart("Speed over time", "speed (m/s)", &story.courses, |c| &c.speed)?;
        w(write!(p, "<h2>Height and speed</h2>\n<div class=\"plots\">\n{height}\n{speed}\n</div>\n"))?;
    }
    w(write!(
        p,
        "<h2>Timeline</h2>\n<table class=\"timeline\">\n<thead><tr><th>seq</th><th>tool</th><th>arguments</th>\
         <th>outcome</th><th>time (s)</th><th>state</th><th>after</th></tr></thead>\n<tbody>\n"
    ))?;
    for e in &story.events {
        let refused = e.kind == Kind::Refused;
        let outcome = if refused {
            format!("refused: {}", e.result.as_deref().unwrap_or(""))
        } else {
            e.kind.as_str().to_string()
        };
        let time = story
            .time_at
            .get(&e.seq)
            .or_else(|| story.time_of_hash.get(&e.state_hash))
            .map_or(String::new(), |t| format!("{t:.4}"));
        let thumb = story.thumbnails.get(&e.seq).map_or(String::new(), |png| {
            format!("<img width=\"160\" height=\"120\" alt=\"after seq {}\" src=\"data:image/png;base64,{}\">", e.seq, b64(png))
        });
        let class = match (refused, e.inherited) {
            (true, _) => "event refused",
            (false, true) => "event inherited",
            _ => "event",
        };
        w(writeln!(
            p,
            "<tr class=\"{class}\" data-seq=\"{seq}\"><td class=\"seq mono\">{seq}</td><td>{tool}</td><td class=\"args mono\">{args}</td>\
             <td class=\"outcome\">{outcome}</td><td class=\"mono\">{time}</td><td class=\"mono\">{hash}</td><td>{thumb}</td></tr>",
            seq = e.seq,
            tool = esc(&e.tool),
            args = esc(&short_args(e)),
            outcome = esc(&outcome),
            hash = esc(&e.state_hash.chars().take(12).collect::<String>()),
        ))?;
    }
    w(write!(p, "</tbody>\n</table>\n</body>\n</html>\n"))?;
    if p.len() > super::MAX_PAGE_BYTES {
        return Err(format!("the report would be {} MiB, over its 10 MiB limit", p.len() / (1024 * 1024)));
    }
    Ok(p)
}
