//! Decoding what the server draws, for comparisons: PNGs (get_camera_image, viewer frames) and
//! GIFs (render_animation, `replay --render`), both with the maintained decoders (`png`, `gif`).

use base64::Engine;
use rmcp::model::CallToolResult;

/// A decoded GIF: its global palette and every frame composited as a viewer shows it, as
/// palette indices (a frame's transparent pixels keep what the frame before left).
pub struct Gif {
    pub width: usize,
    pub height: usize,
    pub palette: Vec<[u8; 3]>,
    pub frames: Vec<Vec<u8>>,
    /// Each frame's delay in hundredths of a second.
    pub delays: Vec<u16>,
    /// Whether the file asks to loop forever.
    pub loops: bool,
}

impl Gif {
    /// Decodes GIF bytes.
    pub fn decode(bytes: &[u8]) -> Gif {
        let mut opts = gif::DecodeOptions::new();
        opts.set_color_output(gif::ColorOutput::Indexed);
        let mut d = opts.read_info(bytes).expect("a GIF");
        let (width, height) = (d.width() as usize, d.height() as usize);
        let palette: Vec<[u8; 3]> = d.global_palette().expect("a global palette").chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
        let mut canvas = vec![0u8; width * height];
        let (mut frames, mut delays) = (Vec::new(), Vec::new());
        while let Some(f) = d.read_next_frame().expect("a frame") {
            assert!(f.palette.is_none(), "frames use the global palette");
            for y in 0..f.height as usize {
                for x in 0..f.width as usize {
                    let v = f.buffer[y * f.width as usize + x];
                    if Some(v) != f.transparent {
                        canvas[(f.top as usize + y) * width + f.left as usize + x] = v;
                    }
                }
            }
            frames.push(canvas.clone());
            delays.push(f.delay);
        }
        let loops = d.repeat() == gif::Repeat::Infinite;
        Gif { width, height, palette, frames, delays, loops }
    }

    /// Frame `k` as RGB bytes.
    pub fn rgb(&self, k: usize) -> Vec<u8> {
        self.frames[k].iter().flat_map(|i| self.palette[*i as usize]).collect()
    }

    /// The palette entry nearest to `px` (squared distance, lowest index on ties), as the
    /// encoder maps colours.
    pub fn nearest(&self, px: &[u8]) -> u8 {
        let d = |e: &[u8; 3]| (0..3).map(|k| (i32::from(px[k]) - i32::from(e[k])).pow(2)).sum::<i32>();
        let mut best = (i32::MAX, 0);
        for (i, e) in self.palette.iter().enumerate() {
            if d(e) < best.0 {
                best = (d(e), i);
            }
        }
        best.1 as u8
    }
}

/// A decoded PNG as RGB bytes with its size.
pub fn png_rgb(bytes: &[u8]) -> (usize, usize, Vec<u8>) {
    let mut r = png::Decoder::new(std::io::Cursor::new(bytes)).read_info().expect("a PNG");
    let mut buf = vec![0; r.output_buffer_size().expect("size")];
    let info = r.next_frame(&mut buf).expect("a frame");
    let ch = info.color_type.samples();
    let rgb = buf[..info.buffer_size()].chunks(ch).flat_map(|p| [p[0], p[1], p[2]]).collect();
    (info.width as usize, info.height as usize, rgb)
}

/// The bytes of the first image content of a tool result with this MIME type.
pub fn image_of(r: &CallToolResult, mime: &str) -> Vec<u8> {
    let img = r
        .content
        .iter()
        .find_map(|c| c.as_image().filter(|i| i.mime_type == mime))
        .unwrap_or_else(|| panic!("no {mime} image content in {r:?}"));
    base64::engine::general_purpose::STANDARD.decode(&img.data).expect("base64")
}

/// The mean row (from the top) of the pixels `is` picks, or None if there are none.
pub fn mean_row(rgb: &[u8], width: usize, is: impl Fn(&[u8]) -> bool) -> Option<f64> {
    let (mut sum, mut n) = (0.0, 0u64);
    for (i, px) in rgb.chunks(3).enumerate() {
        if is(px) {
            sum += (i / width) as f64;
            n += 1;
        }
    }
    (n > 0).then(|| sum / n as f64)
}
