//! One scene style for every picture of a simulation (camera images, animations, the report's
//! thumbnails and plots, the viewer): the colour an object is drawn in, the sky, the ground
//! checker and the light. Keeping them in one place is what makes a report's plot line the
//! same colour as the box it follows in the animation beside it.
//!
//! None of this is state: colours given by the agent (`color`, URDF/MJCF materials) are the
//! world's; what is here only decides how objects without one, and the surroundings, look.

/// Colours for objects that were given none, chosen by object id: muted, told apart from one
/// another and from the sky and the ground's checker.
const PALETTE: [[f32; 3]; 8] = [
    [0.85, 0.55, 0.25], // orange
    [0.30, 0.55, 0.80], // blue
    [0.45, 0.70, 0.35], // green
    [0.80, 0.35, 0.35], // red
    [0.60, 0.45, 0.75], // violet
    [0.85, 0.75, 0.30], // ochre
    [0.35, 0.70, 0.70], // teal
    [0.75, 0.50, 0.60], // rose
];

/// The linear RGB (0–1) an object is drawn in: its own colour (the object's `color` or its
/// link's material), else the palette's entry for its id.
pub fn object_rgb(object_id: u32, color: Option<[f32; 4]>) -> [f32; 3] {
    match color {
        Some(c) => [c[0], c[1], c[2]].map(|v| if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.8 }),
        None => PALETTE[object_id as usize % PALETTE.len()],
    }
}

/// `object_rgb` with the object's own alpha (1 when it has no colour): what the browser viewer
/// and the MCAP export draw with, so a translucent object is translucent in both.
pub fn object_rgba(object_id: u32, color: Option<[f32; 4]>) -> [f32; 4] {
    let [r, g, b] = object_rgb(object_id, color);
    let a = color.map_or(1.0, |c| if c[3].is_finite() { c[3].clamp(0.0, 1.0) } else { 1.0 });
    [r, g, b, a]
}

/// `object_rgb` as 8-bit sRGB-ish bytes (what a pixel of a fully lit face shows, and what a
/// plot line uses).
pub fn object_bytes(object_id: u32, color: Option<[f32; 4]>) -> [u8; 3] {
    object_rgb(object_id, color).map(|v| (v * 255.0).round() as u8)
}

/// `object_bytes` as a CSS/SVG colour, `#rrggbb`.
pub fn object_hex(object_id: u32, color: Option<[f32; 4]>) -> String {
    let [r, g, b] = object_bytes(object_id, color);
    format!("#{r:02x}{g:02x}{b:02x}")
}
