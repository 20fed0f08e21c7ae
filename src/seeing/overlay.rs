//! Text drawn over rendered frames: the moment (simulated time, step, seq) in a corner, and
//! object ids at the objects, with a 5×7 bitmap font (no font files, no text engine: the
//! characters these labels use are all it knows).

use rapier3d::glamx::{DMat4, DVec4};

use crate::seeing::sensing::camera::Mat4;
use crate::seeing::sensing::capture::Scene;
use crate::seeing::sensing::shading::CASTER_MAX_SIZE;

/// What to draw over animation frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Overlay {
    /// Nothing.
    None,
    /// Time, step and seq in the bottom-left corner.
    #[default]
    Time,
    /// That, and each object's id at its centre.
    Ids,
}

impl Overlay {
    /// The parameter's value: "none", "time" or "ids".
    pub fn parse(s: &str) -> Result<Overlay, String> {
        match s {
            "none" => Ok(Overlay::None),
            "time" => Ok(Overlay::Time),
            "ids" => Ok(Overlay::Ids),
            other => Err(format!("overlay must be \"none\", \"time\" or \"ids\"; got \"{other}\"")),
        }
    }
}

/// At most this many id labels on one frame (beyond that they only hide the picture).
const MAX_LABELS: usize = 100;

/// The glyph rows (5 bits each, high bit left) of the characters labels use; others are blank.
fn glyph(c: char) -> [u8; 7] {
    match c {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        ':' => [0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        '=' => [0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00],
        '#' => [0x0A, 0x0A, 0x1F, 0x0A, 0x1F, 0x0A, 0x0A],
        't' => [0x08, 0x08, 0x1C, 0x08, 0x08, 0x09, 0x06],
        's' => [0x00, 0x00, 0x0E, 0x10, 0x0E, 0x01, 0x1E],
        'e' => [0x00, 0x00, 0x0E, 0x11, 0x1F, 0x10, 0x0E],
        'p' => [0x00, 0x00, 0x1E, 0x11, 0x1E, 0x10, 0x10],
        'q' => [0x00, 0x00, 0x0F, 0x11, 0x0F, 0x01, 0x01],
        _ => [0; 7],
    }
}

/// An RGB image being written on.
pub struct Canvas<'a> {
    /// RGB bytes, row-major.
    pub rgb: &'a mut [u8],
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

impl Canvas<'_> {
    /// Text scale for this image: 1 up to 360 px high, then larger.
    fn scale(&self) -> i64 {
        (i64::from(self.height) / 360).clamp(1, 4)
    }

    fn put(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if x >= 0 && y >= 0 && x < i64::from(self.width) && y < i64::from(self.height) {
            let i = 3 * (y as usize * self.width as usize + x as usize);
            self.rgb[i..i + 3].copy_from_slice(&c);
        }
    }

    /// Pixel size (w, h) of `text`.
    pub fn measure(&self, text: &str) -> (i64, i64) {
        let s = self.scale();
        (text.chars().count() as i64 * 6 * s - s, 7 * s)
    }

    /// Writes `text` with its top-left at (x, y): `ink` glyphs on a `pad` box.
    pub fn text(&mut self, x: i64, y: i64, text: &str, ink: [u8; 3], pad: [u8; 3]) {
        let s = self.scale();
        let (w, h) = self.measure(text);
        for py in y - s..y + h + s {
            for px in x - s..x + w + s {
                self.put(px, py, pad);
            }
        }
        for (k, c) in text.chars().enumerate() {
            let ox = x + k as i64 * 6 * s;
            for (row, bits) in glyph(c).iter().enumerate() {
                for col in 0..5 {
                    if bits & (0x10 >> col) != 0 {
                        for dy in 0..s {
                            for dx in 0..s {
                                self.put(ox + col * s + dx, y + row as i64 * s + dy, ink);
                            }
                        }
                    }
                }
            }
        }
    }
}

/// The corner label of a moment: simulated time, steps since creation, and the event.
pub fn moment_label(time: f64, steps: u64, seq: u64) -> String {
    format!("t {time:.3} s  step {steps}  seq {seq}")
}

/// Draws what `overlay` asks for on a frame of `scene` taken with (view, proj).
pub fn draw(overlay: Overlay, canvas: &mut Canvas, scene: &Scene, seq: u64, view: &Mat4, proj: &Mat4) {
    if overlay == Overlay::None {
        return;
    }
    if overlay == Overlay::Ids {
        for (id, at) in object_centres(scene).into_iter().take(MAX_LABELS) {
            if let Some((x, y)) = project(view, proj, at, canvas.width, canvas.height) {
                let label = format!("#{id}");
                let (w, h) = canvas.measure(&label);
                canvas.text(x - w / 2, y - h / 2, &label, [20, 20, 20], [250, 250, 250]);
            }
        }
    }
    let label = moment_label(scene.time, scene.steps, seq);
    let (_, h) = canvas.measure(&label);
    let margin = 2 * canvas.scale() + 1;
    canvas.text(margin, i64::from(canvas.height) - h - margin, &label, [255, 255, 255], [40, 40, 40]);
}

/// Each object's centre (the middle of its parts' bounds), ground-sized objects left out.
fn object_centres(scene: &Scene) -> Vec<(u32, [f64; 3])> {
    let mut out: Vec<(u32, rapier3d::prelude::Vector, rapier3d::prelude::Vector)> = Vec::new();
    for p in &scene.parts {
        let b = p.shape.compute_aabb(&p.pose);
        match out.last_mut() {
            Some((id, lo, hi)) if *id == p.object_id => {
                *lo = lo.min(b.mins);
                *hi = hi.max(b.maxs);
            }
            _ => out.push((p.object_id, b.mins, b.maxs)),
        }
    }
    out.into_iter()
        .filter(|(_, lo, hi)| (*hi - *lo).max_element() <= CASTER_MAX_SIZE)
        .map(|(id, lo, hi)| (id, ((lo + hi) * 0.5).to_array().map(f64::from)))
        .collect()
}

/// The pixel a world point lands on, if in front of the camera and inside the image.
fn project(view: &Mat4, proj: &Mat4, p: [f64; 3], width: u32, height: u32) -> Option<(i64, i64)> {
    let c = (DMat4::from_cols_array(proj) * DMat4::from_cols_array(view) * DVec4::new(p[0], p[1], p[2], 1.0)).to_array();
    if c[3] <= 1e-9 {
        return None;
    }
    let (x, y) = (c[0] / c[3], c[1] / c[3]);
    if !(-1.0..=1.0).contains(&x) || !(-1.0..=1.0).contains(&y) {
        return None;
    }
    Some((((x * 0.5 + 0.5) * f64::from(width)) as i64, ((0.5 - y * 0.5) * f64::from(height)) as i64))
}
