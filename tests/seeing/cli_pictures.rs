//! The command line: `replay FILE --render OUT.gif` and
//! `report FILE -o OUT.html` on every recorded session in `replays/` (copied first: those
//! files are never touched). The GIF decodes to the frames it says; the page has one
//! timeline row per event of the log, requests nothing (no URL but `data:` ones, no script).

use crate::common;

use std::path::PathBuf;
use std::process::Command;

use common::pictures::Gif;

fn replays() -> Vec<PathBuf> {
    let files = common::recorded_logs();
    assert!(files.len() >= 5, "recorded sessions: {files:?}");
    files
}

fn run(args: &[&std::ffi::OsStr]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_physics-mcp")).args(args).output().expect("run physics-mcp");
    (out.status.success(), String::from_utf8_lossy(&out.stdout).into_owned(), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn every_recorded_session_renders_and_reports() {
    let dir = tempfile::tempdir().unwrap();
    for original in replays() {
        let name = original.file_stem().unwrap().to_string_lossy().into_owned();
        let file = dir.path().join(original.file_name().unwrap());
        std::fs::copy(&original, &file).unwrap();

        let gif_path = dir.path().join(format!("{name}.gif"));
        let (ok, stdout, stderr) = run(&["replay".as_ref(), file.as_os_str(), "--render".as_ref(), gif_path.as_os_str(), "--size".as_ref(), "96x72".as_ref()]);
        assert!(ok, "{name}: replay --render failed: {stderr}");
        let gif = Gif::decode(&std::fs::read(&gif_path).unwrap());
        assert_eq!((gif.width, gif.height), (96, 72), "{name}");
        assert!(gif.loops);
        assert!(stdout.contains(&format!("{} frames", gif.frames.len())), "{name}: {stdout}");

        let html_path = dir.path().join(format!("{name}.html"));
        let (ok, _, stderr) = run(&["report".as_ref(), file.as_os_str(), "-o".as_ref(), html_path.as_os_str()]);
        assert!(ok, "{name}: report failed: {stderr}");
        let page = std::fs::read_to_string(&html_path).unwrap();
        let events = physics_mcp::log::replay::events(&file).unwrap();
        let rows = page.matches("<tr class=\"event").count();
        assert_eq!(rows, events.len(), "{name}: one timeline row per event");
        for e in &events {
            assert!(page.contains(&format!("data-seq=\"{}\"", e.seq)), "{name}: row for seq {}", e.seq);
        }
        assert!(page.contains("data:image/gif;base64,"), "{name}: the animation is inline");
        assert!(page.contains("<svg"), "{name}: plots");
        assert!(!page.contains("<script"), "{name}: no script");
        for scheme in ["http:", "https:", "//"] {
            let outside = page.match_indices(&format!("src=\"{scheme}")).count() + page.match_indices(&format!("href=\"{scheme}")).count();
            assert_eq!(outside, 0, "{name}: no {scheme} URL");
        }
        assert!(page.contains("verified"), "{name}: the header says whether the log verified");
        assert!(page.len() <= 10 * 1024 * 1024);
        // The originals are untouched.
        assert_eq!(std::fs::read(&original).unwrap(), std::fs::read(&file).unwrap(), "{name}");
    }
}

#[test]
fn render_refuses_what_it_cannot_draw() {
    let file = replays().into_iter().next().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let copy = dir.path().join("log.sqlite");
    std::fs::copy(&file, &copy).unwrap();
    let out = dir.path().join("x.gif");
    for (extra, word) in [(vec!["--size", "0x10"], "--size"), (vec!["--every", "1", "--from", "999999"], "999999")] {
        let mut args: Vec<&std::ffi::OsStr> = vec!["replay".as_ref(), copy.as_os_str(), "--render".as_ref(), out.as_os_str()];
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        let (ok, _, stderr) = run(&args);
        assert!(!ok, "{extra:?} must fail");
        assert!(stderr.contains(word), "{extra:?}: {stderr}");
    }
    // A GIF is not written into a file named otherwise.
    let png = dir.path().join("clip.png");
    let (ok, _, stderr) = run(&["replay".as_ref(), copy.as_os_str(), "--render".as_ref(), png.as_os_str()]);
    assert!(!ok && stderr.contains(".gif"), "{stderr}");
    assert!(!png.exists());
}
