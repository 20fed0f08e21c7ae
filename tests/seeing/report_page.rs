//! The session report tells the story of a session recorded through the real server: two red
//! boxes and a green one (static) beside a two-link arm moved by its motors, with reads, an
//! undo/redo and an undone step. The page plots the objects that moved (and only those) in their
//! own colours, the second red box dashed, the fixed-base arm by its end effector, the arm's
//! joints; the undone step is marked with its time; its counts add up to replay's; arguments never
//! break inside a token; the read runs are folded; its thumbnails and movie frame the whole
//! scene even when the only mover barely moves. In a real browser (ignored here; `.ci/run`
//! runs it): no two pieces of text overlap, line colours are the objects' colours, no console
//! message, no request.

use crate::common;

use std::collections::BTreeSet;
use std::io::{Read, Write};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::Command;

use common::Server;
use physics_mcp::seeing::style::object_hex;
use serde_json::{json, Value};

const RED: [f32; 4] = [0.9, 0.1, 0.1, 1.0];
const GREEN: [f32; 4] = [0.1, 0.7, 0.2, 1.0];

/// The recorded session: its log (a copy, taken while the server ran, and the final one) and
/// the ids of what is in it.
struct Session {
    while_running: PathBuf,
    log: PathBuf,
    falling: u32,
    sliding: u32,
    still: u32,
    arm: u32,
}

async fn record(dir: &Path) -> Session {
    let server = Server::start(dir, &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    let id = |v: Value| v["object_id"].as_u64().unwrap() as u32;
    let falling = id(c.call("add_box", json!({"sim_id": sim, "dimensions": [0.2, 0.2, 0.2], "position": [0, 0, 1], "color": RED})).await);
    let sliding = id(c.call("add_box", json!({"sim_id": sim, "dimensions": [0.2, 0.2, 0.2], "position": [1, 0, 0.1], "color": RED})).await);
    let still = id(c.call("add_box", json!({"sim_id": sim, "dimensions": [0.2, 0.2, 0.2], "position": [-1, 0, 0.1], "color": GREEN, "mass": 0})).await);
    let arm = id(c.call("load_urdf", json!({"sim_id": sim, "file_path": "two_link_arm.urdf", "position": [0, 2, 1], "use_fixed_base": true})).await);
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": sliding, "linear_velocity": [2, 0, 0]})).await;
    for (joint, target) in [(0, 1.0), (1, -0.8)] {
        c.call(
            "set_joint_motor_control",
            json!({"sim_id": sim, "object_id": arm, "joint_index": joint, "control_mode": "POSITION_CONTROL", "target_position": target}),
        )
        .await;
    }
    c.step(&sim, 120).await;
    for object in [falling, sliding, still] {
        c.state(&sim, object.into()).await;
    }
    c.call("get_joint_state", json!({"sim_id": sim, "object_id": arm, "joint_index": 0})).await;
    c.step(&sim, 60).await;
    c.call("undo", json!({"sim_id": sim})).await;
    c.call("redo", json!({"sim_id": sim})).await;
    c.step(&sim, 60).await;
    // A step undone and replaced: it stays in the log, off the head's chain.
    c.step(&sim, 30).await;
    c.call("undo", json!({"sim_id": sim})).await;
    c.step(&sim, 20).await;
    c.hash(&sim).await;
    c.hash(&sim).await;
    let live = server.data.join(format!("{sim}.sqlite"));
    assert!(live.exists(), "{}", live.display());
    // A report made beside the running server (on the live file: the lock is the server's),
    // a second after the last reads: they are in it (idle simulations' reads are committed).
    tokio::time::sleep(std::time::Duration::from_millis(1500)).await;
    let while_running = dir.join("while_running.html");
    report(&live, &while_running);
    server.terminate();
    let log = dir.join("session.sqlite");
    std::fs::copy(&live, &log).unwrap();
    Session { while_running, log, falling, sliding, still, arm }
}

/// The report's one camera frames the whole scene, not what moves: two static boxes 4 m apart
/// and a ball between them that barely rolls — framed on the mover (render_animation's
/// default), the boxes fall out of the picture; the last thumbnail and the movie's last frame
/// show both.
#[tokio::test(flavor = "multi_thread")]
async fn the_reports_pictures_keep_the_scene_when_the_mover_barely_moves() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    for (x, color) in [(-2, RED), (2, GREEN)] {
        c.call("add_box", json!({"sim_id": sim, "dimensions": [0.2, 0.2, 0.2], "position": [x, 0, 0.2], "color": color, "mass": 0})).await;
    }
    let ball = c.call("add_sphere", json!({"sim_id": sim, "radius": 0.05, "position": [0, 0, 0.05]})).await["object_id"].clone();
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": ball, "linear_velocity": [0.02, 0, 0]})).await;
    c.step(&sim, 60).await;
    let log = server.data.join(format!("{sim}.sqlite"));
    server.terminate();
    let out = dir.path().join("report.html");
    report(&log, &out);
    let page = std::fs::read_to_string(&out).unwrap();
    let decode = |b64: &str| base64::Engine::decode(&base64::engine::general_purpose::STANDARD, b64).unwrap();
    let images = |mime: &str| -> Vec<Vec<u8>> {
        let key = format!("src=\"data:{mime};base64,");
        page.match_indices(&key).map(|(i, _)| decode(&page[i + key.len()..i + key.len() + page[i + key.len()..].find('"').unwrap()])).collect()
    };
    // Red and green as lit faces show them (either side of the light).
    let shows = |rgb: &[u8]| {
        let (mut red, mut green) = (0, 0);
        for p in rgb.chunks(3) {
            let (r, g, b) = (i32::from(p[0]), i32::from(p[1]), i32::from(p[2]));
            red += usize::from(r > 60 && r > 2 * g && r > 2 * b);
            green += usize::from(g > 60 && g > 2 * r && g > 2 * b);
        }
        (red, green)
    };
    let thumbs = images("image/png");
    assert!(thumbs.len() >= 2, "{} thumbnails", thumbs.len());
    let (w, h, last) = common::pictures::png_rgb(thumbs.last().unwrap());
    let (red, green) = shows(&last);
    assert!(red > 0 && green > 0, "the last thumbnail ({w}x{h}) shows {red} red and {green} green pixels: a box is out of the picture");
    let movie = common::pictures::Gif::decode(&images("image/gif")[0]);
    let (red, green) = shows(&movie.rgb(movie.frames.len() - 1));
    assert!(red > 0 && green > 0, "the movie's last frame shows {red} red and {green} green pixels");
}

/// `physics-mcp report LOG -o OUT`.
fn report(log: &Path, out: &Path) {
    let run = Command::new(common::bin()).arg("report").arg(log).arg("-o").arg(out).output().unwrap();
    assert!(run.status.success(), "report failed: {}", String::from_utf8_lossy(&run.stderr));
}

/// The text of the first element with `id="{id}"` (no nested tags).
fn by_id<'a>(page: &'a str, id: &str) -> &'a str {
    let start = page.find(&format!("id=\"{id}\">")).unwrap_or_else(|| panic!("no #{id}")) + id.len() + 6;
    &page[start..start + page[start..].find('<').unwrap()]
}

/// The `<figure>` with `id`.
fn figure<'a>(page: &'a str, id: &str) -> &'a str {
    let start = page.find(&format!("<figure class=\"chart\" id=\"{id}\">")).unwrap_or_else(|| panic!("no chart {id}"));
    &page[start..start + page[start..].find("</figure>").unwrap()]
}

/// Every value of `attr="…"` in `text`, in order.
fn attrs<'a>(text: &'a str, attr: &str) -> Vec<&'a str> {
    let key = format!(" {attr}=\"");
    text.match_indices(&key).map(|(i, _)| &text[i + key.len()..i + key.len() + text[i + key.len()..].find('"').unwrap()]).collect()
}

/// The `<g class="line" …>` opening tags of a chart.
fn lines(chart: &str) -> Vec<&str> {
    chart.match_indices("<g class=\"line\"").map(|(i, _)| &chart[i..i + chart[i..].find('>').unwrap()]).collect()
}

#[tokio::test(flavor = "multi_thread")]
async fn the_report_plots_what_moved_in_its_colours_and_counts_as_replay_does() {
    let dir = tempfile::tempdir().unwrap();
    let s = record(dir.path()).await;
    let out = dir.path().join("report.html");
    report(&s.log, &out);
    let page = std::fs::read_to_string(&out).unwrap();

    // Counts: state-changing and moves apart, summing to replay's state events.
    let replayed = physics_mcp::log::replay::replay(&s.log, None, |_, _| {}).unwrap();
    let n = |id: &str| by_id(&page, id).parse::<u64>().unwrap();
    assert_eq!(n("moves"), 3, "two undos, one redo");
    assert_eq!(n("state-changing") + n("moves"), replayed.state_events);
    assert_eq!(n("state-events"), replayed.state_events);
    let events = physics_mcp::log::replay::events(&s.log).unwrap();
    assert_eq!(n("state-changing") + n("moves") + n("reads") + n("refused"), events.len() as u64);

    // The objects that moved, and only those, in their colours; the second red one dashed; the
    // fixed-base arm by its end effector (its base does not move).
    let height = figure(&page, "plot-height");
    let plotted: BTreeSet<u32> = attrs(height, "data-object").iter().map(|v| v.parse().unwrap()).collect();
    assert_eq!(plotted, BTreeSet::from([s.falling, s.sliding, s.arm]), "the still box and the ground did not move");
    let arm_line = lines(height).into_iter().find(|l| attrs(l, "data-object")[0] == s.arm.to_string()).unwrap();
    assert!(attrs(arm_line, "data-label")[0].ends_with("two_link_arm end effector (link 1)"), "{arm_line}");
    for line in lines(height).into_iter().filter(|l| *l != arm_line) {
        let id: u32 = attrs(line, "data-object")[0].parse().unwrap();
        assert_eq!(attrs(line, "stroke")[0], object_hex(id, Some(RED)), "{line}");
        assert!(attrs(line, "data-label")[0].ends_with(" box"), "{line}");
    }
    let dashed: Vec<bool> = lines(height).iter().map(|l| l.contains("stroke-dasharray")).collect();
    assert_eq!(dashed.iter().filter(|d| **d).count(), 1, "one of the two red lines is dashed: {dashed:?}");
    assert!(!page.contains(&format!("data-object=\"{}\"", s.still)), "the still box is not plotted");
    // The legend names them.
    for id in [s.falling, s.sliding] {
        assert!(height.contains(&format!("<span>#{id} box</span>")), "legend for {id}");
    }

    // The arm's joints, both moved by their motors, named.
    let joints = figure(&page, &format!("plot-joints-{}", s.arm));
    assert!(joints.contains("Joint positions of #") && joints.contains("two_link_arm"), "{joints}");
    assert_eq!(attrs(joints, "data-joint"), ["0", "1"]);
    assert!(joints.contains("shoulder (upper_arm)") && joints.contains("elbow (forearm)"));

    // The timeline: tokens never break; the reads between steps are one row.
    assert!(!page.contains("overflow-wrap: anywhere") && !page.contains("word-break"));
    assert!(page.contains("<span class=\"arg\">control_mode=&quot;POSITION_CONTROL&quot;</span>"));
    assert!(page.contains("4 reads: get_object_state ×3, get_joint_state ×1"), "the reads folded");
    assert_eq!(page.matches("<tr class=\"event").count(), events.len(), "every event still has its row");
    // No picture of the empty world after create.
    let first = events.iter().find(|e| e.tool == "create_simulation").unwrap();
    let row = &page[page.find(&format!("data-seq=\"{}\"", first.seq)).unwrap()..];
    assert!(!row[..row.find("</tr>").unwrap()].contains("<img"), "no thumbnail of an empty world");
    assert!(page.contains("width=\"480\" height=\"360\""), "the larger animation");

    // The undone step: marked, with its time.
    let undone = events.iter().filter(|e| e.tool == "step_simulation").rev().nth(1).unwrap();
    let row = &page[page.find(&format!("data-seq=\"{}\"", undone.seq)).unwrap()..];
    let row = &row[..row.find("</tr>").unwrap()];
    assert!(page[..page.find(&format!("data-seq=\"{}\"", undone.seq)).unwrap()].ends_with("<tr class=\"event undone\" "), "{row}");
    assert!(row.contains("undone (not on the head&#39;s chain)"), "{row}");
    assert!(row.contains("<td class=\"mono\">1.1250</td>"), "its time, 270 steps of 1/240 s: {row}");

    // The running server's note only while it ran.
    let note = physics_mcp::seeing::report::RUNNING_NOTE;
    assert!(!page.contains(note), "no note once the server stopped");
    let running = std::fs::read_to_string(&s.while_running).unwrap();
    assert!(running.contains(note), "the note while the server ran");
    assert_eq!(running.matches("<tr class=\"event").count(), events.len(), "the trailing reads were in the log while it ran");
    assert!(page.len() <= physics_mcp::seeing::report::MAX_PAGE_BYTES);
}

/// The page the browser test loads: the report in a same-origin frame, measured by a script
/// of the harness (the report itself forbids scripts), the result written into `#result`.
const HARNESS: &str = r#"<!doctype html><html><body style="margin:0">
<pre id="result">pending</pre>
<iframe id="r" src="report.html" style="width:1100px;height:30000px;border:0"></iframe>
<script>
document.getElementById('r').addEventListener('load', () => {
  const d = document.getElementById('r').contentDocument;
  d.querySelectorAll('details').forEach(x => { x.open = true; });
  const boxes = [];
  const walker = d.createTreeWalker(d.body, NodeFilter.SHOW_TEXT);
  let n;
  while ((n = walker.nextNode())) {
    if (!n.data.trim()) continue;
    const range = d.createRange();
    range.selectNodeContents(n);
    for (const b of range.getClientRects()) {
      if (b.width > 0 && b.height > 0) boxes.push({t: n.data.trim().slice(0, 40), x: b.left, y: b.top, r: b.right, b: b.bottom});
    }
  }
  const overlaps = [];
  for (let i = 0; i < boxes.length; i++) for (let j = i + 1; j < boxes.length; j++) {
    const a = boxes[i], b = boxes[j];
    if (a.x < b.r - 0.5 && b.x < a.r - 0.5 && a.y < b.b - 0.5 && b.y < a.b - 0.5) overlaps.push(a.t + ' | ' + b.t);
  }
  const lines = [...d.querySelectorAll('g.line')].map(g => ({chart: g.closest('figure').id, object: +g.dataset.object,
    joint: g.dataset.joint === undefined ? null : +g.dataset.joint, stroke: getComputedStyle(g).stroke}));
  const legends = [...d.querySelectorAll('figure')].map(f => ({chart: f.id, items: [...f.querySelectorAll('ul.legend li')].map(li => li.textContent)}));
  document.getElementById('result').textContent = 'RESULT' + JSON.stringify({texts: boxes.length, overlaps, lines, legends}) + 'END';
});
</script></body></html>"#;

/// Serves `report.html` and the harness from `dir` on loopback until the test ends.
fn serve(dir: &Path) -> u16 {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let report = std::fs::read(dir.join("report.html")).unwrap();
    std::thread::spawn(move || {
        for conn in listener.incoming().flatten() {
            let mut conn = conn;
            let mut buf = [0u8; 2048];
            let n = conn.read(&mut buf).unwrap_or(0);
            let request = String::from_utf8_lossy(&buf[..n]);
            let body: &[u8] = if request.starts_with("GET /report.html") {
                &report
            } else if request.starts_with("GET /harness.html") {
                HARNESS.as_bytes()
            } else {
                b""
            };
            let status = if body.is_empty() { "404 Not Found" } else { "200 OK" };
            let _ = write!(conn, "HTTP/1.1 {status}\r\nContent-Type: text/html; charset=utf-8\r\nContent-Length: {}\r\nConnection: close\r\n\r\n", body.len());
            let _ = conn.write_all(body);
        }
    });
    port
}

/// `rgb(r, g, b)` for `#rrggbb`.
fn css_rgb(hex: &str) -> String {
    let v = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).unwrap();
    format!("rgb({}, {}, {})", v(1), v(3), v(5))
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs Chromium; run by .ci/run with --ignored"]
async fn browser_the_report_page_has_no_overlapping_text_and_lines_in_object_colours() {
    use super::browser_viewer::{headless, watched};
    let dir = tempfile::tempdir().unwrap();
    let s = record(dir.path()).await;
    let site = dir.path().join("site");
    std::fs::create_dir_all(&site).unwrap();
    let page = site.join("report.html");
    report(&s.log, &page);

    // Quiet and offline, as a file.
    let w = watched(&format!("file://{}", page.display()), &dir.path().join("profile-watch"), 3_000, &["--window-size=1100,1000"]);
    assert!(w.console.is_empty(), "console: {:?}", w.console);
    assert!(w.outside.is_empty(), "requests to other origins: {:?}", w.outside);

    // Measured in the browser's layout.
    let port = serve(&site);
    let url = format!("http://127.0.0.1:{port}/harness.html");
    let mut result = None;
    for (attempt, budget) in [5_000, 20_000].into_iter().enumerate() {
        let dom = headless(&url, &dir.path().join(format!("profile-dom-{attempt}")), budget, &["--dump-dom"]);
        if let (Some(a), Some(b)) = (dom.find("RESULT"), dom.find("END")) {
            let text = dom[a + 6..b].replace("&amp;", "&").replace("&lt;", "<").replace("&gt;", ">").replace("&quot;", "\"");
            result = Some(serde_json::from_str::<Value>(&text).unwrap());
            break;
        }
    }
    let r = result.expect("the harness measured the page");
    assert!(r["texts"].as_u64().unwrap() > 100, "texts measured: {}", r["texts"]);
    assert_eq!(r["overlaps"], json!([]), "text boxes that intersect");

    // The arm's line is in its links' colour, as the page wrote it.
    let html = std::fs::read_to_string(&page).unwrap();
    let arm_line = lines(figure(&html, "plot-height")).into_iter().find(|l| attrs(l, "data-object")[0] == s.arm.to_string()).unwrap();
    let arm_stroke = attrs(arm_line, "stroke")[0].to_string();
    let colour = |id: u32| match id {
        _ if id == s.arm => arm_stroke.clone(),
        _ if id == s.still => object_hex(id, Some(GREEN)),
        _ => object_hex(id, Some(RED)),
    };
    let mut seen = BTreeSet::new();
    for line in r["lines"].as_array().unwrap() {
        if line["chart"] == "plot-height" || line["chart"] == "plot-speed" {
            let id = line["object"].as_u64().unwrap() as u32;
            assert_eq!(line["stroke"].as_str().unwrap(), css_rgb(&colour(id)), "{line}");
            seen.insert(id);
        }
    }
    assert_eq!(seen, BTreeSet::from([s.falling, s.sliding, s.arm]));
    let legends = r["legends"].as_array().unwrap();
    let height = legends.iter().find(|l| l["chart"] == "plot-height").unwrap();
    let items: Vec<&str> = height["items"].as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect();
    assert_eq!(items.len(), 3, "{items:?}");
    assert!(items.iter().any(|i| i.ends_with("two_link_arm end effector (link 1)")), "{items:?}");
    for id in [s.falling, s.sliding] {
        assert!(items.contains(&format!("#{id} box").as_str()), "{items:?}");
    }
    let joints = legends.iter().find(|l| l["chart"] == format!("plot-joints-{}", s.arm)).expect("a joint chart");
    assert_eq!(joints["items"].as_array().unwrap().len(), 2);
}
