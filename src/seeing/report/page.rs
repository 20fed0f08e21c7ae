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
table.header td { padding: 2px 12px 2px 0; vertical-align: top; } table.header td:first-child { color: #666; }
code, .mono { font-family: ui-monospace, monospace; font-size: 12px; }
.ok { color: #1a7f37; } .bad { color: #cf222e; } .warn { color: #9a6700; }
.plots { display: flex; flex-wrap: wrap; gap: 16px 24px; }
figure.chart { margin: 0; width: 560px; }
figure.chart figcaption { font-weight: 600; margin-bottom: 4px; }
figure.chart > svg { display: block; }
ul.legend { list-style: none; padding: 0; margin: 4px 0 0 0; display: flex; flex-wrap: wrap; gap: 4px 16px; font-size: 13px; }
ul.legend li { display: flex; align-items: center; gap: 6px; }
ul.legend li svg { flex: none; }
table.timeline { border-collapse: collapse; width: 100%; }
table.timeline th { text-align: left; border-bottom: 2px solid #ccc; padding: 4px; position: sticky; top: 0; background: #fff; }
table.timeline td { border-bottom: 1px solid #eee; padding: 3px 4px; vertical-align: top; }
tr.refused td { color: #999; } tr.refused td.outcome { color: #cf222e; }
tr.inherited td.seq::after { content: ' ↰'; color: #999; }
tr.undone td { color: #888; text-decoration: line-through; }
tr.undone td.outcome, tr.undone td.mono { text-decoration: none; }
td.args { max-width: 420px; }
span.arg { display: inline-block; white-space: nowrap; margin-right: 0.6em; }
tr.reads summary { cursor: pointer; color: #555; }
tr.reads table.timeline { margin-top: 4px; }
span.same { color: #888; font-size: 12px; }
";

/// Escapes text for HTML content and attribute values.
pub(super) fn esc(s: &str) -> String {
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

/// Longest `name=value` token shown (a token never breaks, so it must fit its column).
const MAX_TOKEN: usize = 48;
/// Longest argument text shown, all tokens together.
const MAX_ARGS: usize = 120;

fn clip(text: &str, max: usize) -> String {
    if text.chars().count() > max {
        format!("{}…", text.chars().take(max - 1).collect::<String>())
    } else {
        text.to_string()
    }
}

/// An event's arguments in short, as HTML: `name=value` tokens without the sim_id, each in a
/// span that never breaks (a line breaks only between tokens), at most `MAX_ARGS` characters.
fn short_args(e: &Event) -> String {
    let tokens: Vec<String> = match serde_json::from_str::<serde_json::Value>(&e.arguments) {
        Ok(serde_json::Value::Object(m)) => m.iter().filter(|(k, _)| k.as_str() != "sim_id").map(|(k, v)| clip(&format!("{k}={v}"), MAX_TOKEN)).collect(),
        _ => vec![clip(&e.arguments, MAX_TOKEN)],
    };
    let mut out = String::new();
    let mut used = 0;
    for t in tokens {
        let n = t.chars().count();
        if used + n > MAX_ARGS {
            out.push_str("<span class=\"arg\">…</span>");
            break;
        }
        used += n + 1;
        let _ = write!(out, "<span class=\"arg\">{}</span>", esc(&t));
    }
    out
}

fn b64(bytes: &[u8]) -> String {
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

/// The header's counts: state-changing (root + change) and moves (undo/redo) apart, which
/// together are what replay counts as state events.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Counts {
    /// Root and change events.
    pub state_changing: usize,
    /// Undo and redo.
    pub moves: usize,
    /// Accepted reads.
    pub reads: usize,
    /// Rejected calls.
    pub refused: usize,
}

impl Counts {
    /// The counts of `events`.
    pub fn of(events: &[Event]) -> Counts {
        let n = |k: Kind| events.iter().filter(|e| e.kind == k).count();
        Counts { state_changing: n(Kind::Root) + n(Kind::Change), moves: n(Kind::Move), reads: n(Kind::Read), refused: n(Kind::Refused) }
    }
}

/// What the header says when a server held the log's data directory.
pub const RUNNING_NOTE: &str = "the server was running when this report was made; reads of its last second may not be in the log yet";

/// The page for a gathered story.
pub fn html(story: &Story) -> Result<String, String> {
    page(story).map_err(|e| e.to_string()).and_then(|p| {
        if p.len() > super::MAX_PAGE_BYTES {
            Err(format!("the report would be {} MiB, over its 10 MiB limit", p.len() / (1024 * 1024)))
        } else {
            Ok(p)
        }
    })
}

fn page(story: &Story) -> Result<String, std::fmt::Error> {
    let mut p = String::new();
    let sim = esc(&story.simulation_id);
    write!(
        p,
        "<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; img-src data:; style-src 'unsafe-inline'\">\n\
         <title>physics-mcp report · {sim}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n"
    )?;
    let c = Counts::of(&story.events);
    let state_events = c.state_changing + c.moves;
    let replayed = match story.replayed_state_events {
        Some(n) if n as usize == state_events => ", as replay counts".to_string(),
        Some(n) => format!("; replay counted {n}"),
        None => String::new(),
    };
    let verdict_class = if story.verdict.starts_with("verified") { "ok" } else { "bad" };
    write!(
        p,
        "<h1>Session report</h1>\n<table class=\"header\">\n\
         <tr><td>simulation</td><td><code>{sim}</code></td></tr>\n\
         <tr><td>events</td><td id=\"counts\">{total}: <span id=\"state-changing\">{sc}</span> state-changing (create and changes), \
         <span id=\"moves\">{mv}</span> moves (undo/redo), <span id=\"reads\">{rd}</span> reads, <span id=\"refused\">{rf}</span> refused</td></tr>\n\
         <tr><td>state events</td><td><span id=\"state-events\">{state_events}</span> ({sc} state-changing + {mv} moves{replayed})</td></tr>\n",
        total = story.events.len(),
        sc = c.state_changing,
        mv = c.moves,
        rd = c.reads,
        rf = c.refused,
    )?;
    if story.server_running {
        writeln!(p, "<tr><td>note</td><td class=\"warn\" id=\"running\">{RUNNING_NOTE}</td></tr>")?;
    }
    write!(
        p,
        "<tr><td>simulated time</td><td>{:.4} s</td></tr>\n\
         <tr><td>final state hash</td><td><code>{}</code></td></tr>\n\
         <tr><td>replay</td><td class=\"{verdict_class}\" id=\"verdict\">{}</td></tr>\n</table>\n",
        story.end_time,
        esc(&story.final_hash),
        esc(&story.verdict)
    )?;
    let (mw, mh) = super::MOVIE;
    write!(
        p,
        "<h2>The run</h2>\n<p><img id=\"animation\" width=\"{mw}\" height=\"{mh}\" alt=\"the whole run, {} frames\" src=\"data:image/gif;base64,{}\"></p>\n",
        story.frames,
        b64(&story.gif)
    )?;
    if !story.charts.is_empty() {
        p.push_str("<h2>What moved</h2>\n<div class=\"plots\">\n");
        for chart in &story.charts {
            p.push_str(&plots::figure(chart)?);
        }
        p.push_str("</div>\n");
    }
    p.push_str("<h2>Timeline</h2>\n<table class=\"timeline\">\n<thead><tr><th>seq</th><th>tool</th><th>arguments</th><th>outcome</th><th>time (s)</th><th>state</th><th>after</th></tr></thead>\n<tbody>\n");
    let events = &story.events;
    let mut i = 0;
    while i < events.len() {
        let run = events[i..].iter().take_while(|e| e.kind == Kind::Read).count();
        if run >= 2 {
            reads_row(&mut p, story, &events[i..i + run])?;
            i += run;
        } else {
            row(&mut p, story, &events[i])?;
            i += 1;
        }
    }
    p.push_str("</tbody>\n</table>\n</body>\n</html>\n");
    Ok(p)
}

/// A run of consecutive reads as one row: how many of which tool, the rows themselves behind a
/// `<details>` (no script needed to open it).
fn reads_row(p: &mut String, story: &Story, run: &[Event]) -> std::fmt::Result {
    let mut tools: Vec<(&str, usize)> = Vec::new();
    for e in run {
        match tools.iter_mut().find(|(t, _)| *t == e.tool) {
            Some((_, n)) => *n += 1,
            None => tools.push((&e.tool, 1)),
        }
    }
    tools.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(b.0)));
    let what = tools.iter().map(|(t, n)| format!("{} ×{n}", esc(t))).collect::<Vec<_>>().join(", ");
    let (first, last) = (run[0].seq, run[run.len() - 1].seq);
    write!(
        p,
        "<tr class=\"reads\" data-from=\"{first}\" data-to=\"{last}\"><td class=\"seq mono\">{first}–{last}</td><td colspan=\"6\">\
         <details><summary>{} reads: {what}</summary>\n<table class=\"timeline\"><tbody>\n",
        run.len()
    )?;
    for e in run {
        row(p, story, e)?;
    }
    p.push_str("</tbody></table></details></td></tr>\n");
    Ok(())
}

/// The simulated time an event's recorded result gives (`landed.time`, or `current_time`):
/// how an undone change, whose state the head's chain never reaches, still shows its time.
fn recorded_time(e: &Event) -> Option<f64> {
    let result: serde_json::Value = serde_json::from_str(e.result.as_deref()?).ok()?;
    result["landed"]["time"].as_f64().or_else(|| result["current_time"].as_f64())
}

/// One event's row.
fn row(p: &mut String, story: &Story, e: &Event) -> std::fmt::Result {
    let refused = e.kind == Kind::Refused;
    let outcome = if refused { format!("refused: {}", e.result.as_deref().unwrap_or("")) } else { e.kind.as_str().to_string() };
    let undone = e.kind == Kind::Change && !e.inherited && !story.chain.contains(&e.seq);
    let outcome = if undone { "change, undone (not on the head's chain)".to_string() } else { outcome };
    let time = story
        .time_at
        .get(&e.seq)
        .or_else(|| story.time_of_hash.get(&e.state_hash))
        .copied()
        .or_else(|| recorded_time(e))
        .map_or(String::new(), |t| format!("{t:.4}"));
    let (tw, th) = super::THUMB;
    let thumb = match (story.thumbnails.get(&e.seq), story.same_picture.get(&e.seq)) {
        (Some(png), _) => format!("<img width=\"{tw}\" height=\"{th}\" alt=\"after seq {}\" src=\"data:image/png;base64,{}\">", e.seq, b64(png)),
        (None, Some(first)) => format!("<span class=\"same\">same picture as seq {first}</span>"),
        (None, None) => String::new(),
    };
    let class = match (refused, e.inherited, undone) {
        (true, _, _) => "event refused",
        (false, true, _) => "event inherited",
        (false, false, true) => "event undone",
        _ => "event",
    };
    writeln!(
        p,
        "<tr class=\"{class}\" data-seq=\"{seq}\" data-kind=\"{kind}\"><td class=\"seq mono\">{seq}</td><td>{tool}</td><td class=\"args mono\">{args}</td>\
         <td class=\"outcome\">{outcome}</td><td class=\"mono\">{time}</td><td class=\"mono\">{hash}</td><td>{thumb}</td></tr>",
        seq = e.seq,
        kind = e.kind.as_str(),
        tool = esc(&e.tool),
        args = short_args(e),
        outcome = esc(&outcome),
        hash = esc(&e.state_hash.chars().take(12).collect::<String>()),
    )
}
