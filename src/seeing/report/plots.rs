//! The report's plots: one SVG line chart per quantity (height, speed) over simulated time,
//! a line per object, drawn by `plotters` into a string with its SVG backend. Built without
//! plotters' default features (they pull in system font libraries): text goes out as SVG
//! `<text>` placed by plotters' own estimate, and the browser draws it.

use plotters::prelude::*;

use super::Course;

/// Line colours, one per plotted object (at most `MAX_PLOTTED`).
const COLORS: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// An SVG chart of `series(course)` for every course, titled `title`, y labelled `unit`.
pub fn chart(title: &str, unit: &str, courses: &[Course], series: impl Fn(&Course) -> &[(f64, f64)]) -> Result<String, String> {
    let mut svg = String::new();
    {
        let fail = |e: String| format!("the {title} plot could not be drawn: {e}");
        let points: Vec<&(f64, f64)> = courses.iter().flat_map(|c| series(c).iter()).collect();
        let range = |f: fn(&(f64, f64)) -> f64| {
            let lo = points.iter().map(|p| f(p)).fold(f64::INFINITY, f64::min);
            let hi = points.iter().map(|p| f(p)).fold(f64::NEG_INFINITY, f64::max);
            if !lo.is_finite() || !hi.is_finite() {
                (0.0, 1.0)
            } else if hi - lo < 1e-9 {
                (lo - 0.5, hi + 0.5)
            } else {
                let pad = (hi - lo) * 0.05;
                (lo - pad, hi + pad)
            }
        };
        let (x0, x1) = range(|p| p.0);
        let (y0, y1) = range(|p| p.1);
        let root = SVGBackend::with_string(&mut svg, (560, 300)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| fail(e.to_string()))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(8)
            .x_label_area_size(32)
            .y_label_area_size(48)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| fail(e.to_string()))?;
        chart
            .configure_mesh()
            .x_desc("simulated time (s)")
            .y_desc(unit)
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(|e| fail(e.to_string()))?;
        for (i, c) in courses.iter().enumerate() {
            let color = COLORS[i % COLORS.len()];
            chart
                .draw_series(LineSeries::new(series(c).iter().copied(), color.stroke_width(2)))
                .map_err(|e| fail(e.to_string()))?
                .label(format!("object {}", c.object_id))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2)));
        }
        if !courses.is_empty() {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(200, 200, 200))
                .draw()
                .map_err(|e| fail(e.to_string()))?;
        }
        root.present().map_err(|e| fail(e.to_string()))?;
    }
    Ok(svg)
}
