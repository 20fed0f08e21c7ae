//! The report's plots: SVG line charts over simulated time, written by hand so that every
//! piece of text is placed by rules the browser's layout respects — the title and the legend
//! are HTML (the browser flows them, so they never collide), and the SVG holds only tick labels
//! and axis names in margins sized from the tick labels they must clear.
//!
//! A line is drawn in its object's colour (`crate::seeing::style`, the colour the animation
//! draws the object in). Lines that share a colour are told apart: the second, third and
//! fourth of one colour are dashed, and from the fifth on they are also lighter.

use std::fmt::Write;

use super::page::esc;

/// One line of a chart: one object's (or one joint's) value at each sample.
#[derive(Debug, Clone)]
pub struct Line {
    /// The object it follows.
    pub object_id: u32,
    /// The joint (PyBullet index) for joint plots.
    pub joint: Option<usize>,
    /// What the legend says (`#3 box`, `#5 iiwa14`, `iiwa_joint_2 (iiwa_link_2)`).
    pub label: String,
    /// The object's (or the joint's link's) colour, as the scene draws it.
    pub rgb: [u8; 3],
    /// (time s, value) at each sample; `None` where the object did not exist.
    pub points: Vec<Option<(f64, f64)>>,
}

/// One chart: a title, the y axis's name, its lines.
#[derive(Debug, Clone)]
pub struct Chart {
    /// The chart's element id on the page.
    pub id: String,
    /// Shown above the chart.
    pub title: String,
    /// The y axis's name with its unit.
    pub unit: String,
    /// At most `MAX_PLOTTED`.
    pub lines: Vec<Line>,
}

/// Plot area size in the SVG's user units (= CSS pixels).
const WIDTH: f64 = 560.0;
const HEIGHT: f64 = 280.0;
/// Tick labels' font size and a generous per-character width for it (digits, '-', '.').
const TICK_FONT: f64 = 11.0;
const CHAR_W: f64 = 7.0;
/// Dash patterns for the 1st, 2nd, … line of one colour (then repeated lighter).
const DASHES: [&str; 4] = ["", "7 4", "2 3", "9 3 2 3"];

/// How line `i` of `lines` is drawn: its stroke colour (`#rrggbb`) and dash pattern ("" =
/// solid). The k-th line of a colour (k from 0) gets `DASHES[k % 4]`, and is mixed toward
/// white by 35 % per full round of the dashes.
pub fn stroke(lines: &[Line], i: usize) -> (String, &'static str) {
    let rgb = lines[i].rgb;
    let k = lines[..i].iter().filter(|l| l.rgb == rgb).count();
    let light = (k / DASHES.len()) as f64 * 0.35;
    let [r, g, b] = rgb.map(|c| (f64::from(c) + (255.0 - f64::from(c)) * light.min(0.8)).round() as u8);
    (format!("#{r:02x}{g:02x}{b:02x}"), DASHES[k % DASHES.len()])
}

/// Round tick positions covering `[lo, hi]`: steps of 1, 2 or 5 × 10^k, about five of them.
fn ticks(lo: f64, hi: f64) -> (Vec<f64>, usize) {
    let raw = (hi - lo) / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * mag).find(|s| *s >= raw).unwrap_or(10.0 * mag);
    let decimals = (-(step.log10().floor())).max(0.0) as usize;
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    let values = (first..=last).map(|k| k as f64 * step).collect();
    (values, decimals)
}

/// A value's range, padded; a flat or empty range gets a unit-wide one.
fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if !lo.is_finite() || !hi.is_finite() {
        (0.0, 1.0)
    } else if hi - lo < 1e-9 {
        (lo - 0.5, hi + 0.5)
    } else {
        let pad = (hi - lo) * 0.05;
        (lo - pad, hi + pad)
    }
}

fn label(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    // "-0.00" reads as a negative zero.
    if s.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// The chart as a `<figure>`: title, the SVG, the legend (HTML, one entry per line).
pub fn figure(chart: &Chart) -> Result<String, std::fmt::Error> {
    let points = || chart.lines.iter().flat_map(|l| l.points.iter().flatten());
    let (x0, x1) = range(points().map(|p| p.0));
    let (y0, y1) = range(points().map(|p| p.1));
    let (xt, xd) = ticks(x0, x1);
    let (yt, yd) = ticks(y0, y1);
    let ylabels: Vec<String> = yt.iter().map(|v| label(*v, yd)).collect();
    let widest = ylabels.iter().map(|s| s.chars().count()).max().unwrap_or(1) as f64;
    // Left margin: the rotated axis name (a line of 12 px at x 4–18), a gap, the widest tick
    // label, a gap, the tick mark.
    let left = 24.0 + widest * CHAR_W + 10.0;
    let (top, right, bottom) = (10.0, 18.0, 46.0);
    let (pw, ph) = (WIDTH - left - right, HEIGHT - top - bottom);
    let sx = |x: f64| left + (x - x0) / (x1 - x0) * pw;
    let sy = |y: f64| top + (1.0 - (y - y0) / (y1 - y0)) * ph;

    let mut s = String::new();
    write!(s, "<figure class=\"chart\" id=\"{}\">\n<figcaption>{}</figcaption>\n", esc(&chart.id), esc(&chart.title))?;
    write!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{WIDTH}\" height=\"{HEIGHT}\" viewBox=\"0 0 {WIDTH} {HEIGHT}\" font-family=\"system-ui, sans-serif\">\n\
         <rect x=\"{left}\" y=\"{top}\" width=\"{pw}\" height=\"{ph}\" fill=\"#fff\" stroke=\"#bbb\"/>\n"
    )?;
    for (v, text) in yt.iter().zip(&ylabels) {
        let y = sy(*v);
        writeln!(
            s,
            "<line x1=\"{left}\" x2=\"{:.1}\" y1=\"{y:.1}\" y2=\"{y:.1}\" stroke=\"#eee\"/><line x1=\"{:.1}\" x2=\"{left}\" y1=\"{y:.1}\" y2=\"{y:.1}\" stroke=\"#888\"/>\
             <text class=\"tick\" x=\"{:.1}\" y=\"{y:.1}\" font-size=\"{TICK_FONT}\" text-anchor=\"end\" dominant-baseline=\"middle\">{text}</text>",
            left + pw,
            left - 4.0,
            left - 7.0
        )?;
    }
    // x tick labels: skip any that would come within a label's width of the previous one.
    let mut last_right = f64::NEG_INFINITY;
    for v in &xt {
        let x = sx(*v);
        let text = label(*v, xd);
        let half = text.chars().count() as f64 * CHAR_W / 2.0;
        let y = top + ph;
        write!(s, "<line x1=\"{x:.1}\" x2=\"{x:.1}\" y1=\"{top}\" y2=\"{y:.1}\" stroke=\"#eee\"/><line x1=\"{x:.1}\" x2=\"{x:.1}\" y1=\"{y:.1}\" y2=\"{:.1}\" stroke=\"#888\"/>", y + 4.0)?;
        if x - half > last_right + 6.0 && x + half <= WIDTH {
            write!(s, "<text class=\"tick\" x=\"{x:.1}\" y=\"{:.1}\" font-size=\"{TICK_FONT}\" text-anchor=\"middle\">{text}</text>", y + 17.0)?;
            last_right = x + half;
        }
        s.push('\n');
    }
    write!(
        s,
        "<text class=\"axis\" x=\"{:.1}\" y=\"{:.1}\" font-size=\"12\" text-anchor=\"middle\">simulated time (s)</text>\n\
         <text class=\"axis\" transform=\"translate(14 {:.1}) rotate(-90)\" font-size=\"12\" text-anchor=\"middle\" dominant-baseline=\"middle\">{}</text>\n",
        left + pw / 2.0,
        HEIGHT - 6.0,
        top + ph / 2.0,
        esc(&chart.unit)
    )?;
    for (i, line) in chart.lines.iter().enumerate() {
        let (color, dash) = stroke(&chart.lines, i);
        let joint = line.joint.map_or(String::new(), |j| format!(" data-joint=\"{j}\""));
        let dash = if dash.is_empty() { String::new() } else { format!(" stroke-dasharray=\"{dash}\"") };
        write!(
            s,
            "<g class=\"line\" data-object=\"{}\"{joint} data-label=\"{}\" fill=\"none\" stroke=\"{color}\" stroke-width=\"2\"{dash}>",
            line.object_id,
            esc(&line.label)
        )?;
        // One polyline per stretch where the object existed.
        for run in line.points.split(Option::is_none).filter(|r| !r.is_empty()) {
            s.push_str("<polyline points=\"");
            for (k, p) in run.iter().flatten().enumerate() {
                let sep = if k == 0 { "" } else { " " };
                write!(s, "{sep}{:.1},{:.1}", sx(p.0), sy(p.1))?;
            }
            s.push_str("\"/>");
        }
        s.push_str("</g>\n");
    }
    s.push_str("</svg>\n<ul class=\"legend\">\n");
    for (i, line) in chart.lines.iter().enumerate() {
        let (color, dash) = stroke(&chart.lines, i);
        let dash = if dash.is_empty() { String::new() } else { format!(" stroke-dasharray=\"{dash}\"") };
        writeln!(
            s,
            "<li data-object=\"{}\"><svg width=\"30\" height=\"10\" aria-hidden=\"true\"><line x1=\"1\" y1=\"5\" x2=\"29\" y2=\"5\" stroke=\"{color}\" stroke-width=\"2\"{dash}/></svg><span>{}</span></li>",
            line.object_id,
            esc(&line.label)
        )?;
    }
    s.push_str("</ul>\n</figure>\n");
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(id: u32, rgb: [u8; 3]) -> Line {
        Line { object_id: id, joint: None, label: format!("#{id}"), rgb, points: vec![Some((0.0, 0.0)), Some((1.0, 1.0))] }
    }

    #[test]
    fn lines_of_one_colour_are_told_apart_and_keep_their_colour() {
        let red = [200, 10, 10];
        let lines = [line(1, red), line(2, [0, 0, 255]), line(3, red), line(4, red), line(5, red), line(6, red)];
        let s: Vec<_> = (0..lines.len()).map(|i| stroke(&lines, i)).collect();
        assert_eq!(s[0], ("#c80a0a".into(), ""));
        assert_eq!(s[1], ("#0000ff".into(), ""));
        assert_eq!(s[2], ("#c80a0a".into(), DASHES[1]));
        assert_eq!(s[3], ("#c80a0a".into(), DASHES[2]));
        assert_eq!(s[4], ("#c80a0a".into(), DASHES[3]));
        assert_eq!(s[5].1, "");
        assert_ne!(s[5].0, "#c80a0a", "the fifth of a colour is lighter");
    }

    #[test]
    fn ticks_are_round_and_inside() {
        let (t, d) = ticks(-0.02, 1.07);
        assert_eq!(d, 1);
        assert!(t.first().unwrap() >= &-0.02 && t.last().unwrap() <= &1.07 && t.len() >= 3, "{t:?}");
        assert_eq!(t, [0.0, 0.5, 1.0]);
        assert_eq!(label(-0.0, 2), "0.00");
    }
}
