//! Rendered frames → one looping GIF (the `gif` crate's encoder; no hand-written LZW).
//!
//! One global palette for all frames (`palette.rs`: exact when the frames hold at most 255
//! colours); index 255 is transparent. The first frame is whole; each later one is the
//! rectangle that changed since the one before, its unchanged pixels transparent (disposal
//! `Keep`), so a static ground costs nothing after the first frame. Counting colours, mapping
//! pixels and LZW compression run on all cores; only the final write is sequential.

use gif::{DisposalMethod, Encoder, Frame, Repeat};
use rayon::prelude::*;

use super::pacing;
use super::palette::{Histogram, Palette};

/// The palette index that means "unchanged since the previous frame".
pub const TRANSPARENT: u8 = 255;

/// What a GIF is made of: RGB frames of one size, each shown for its delay.
pub struct Frames<'a> {
    /// Width in pixels (≤ 65535).
    pub width: u32,
    /// Height in pixels (≤ 65535).
    pub height: u32,
    /// RGB bytes of each frame, row-major from the top-left.
    pub rgb: &'a [Vec<u8>],
    /// Each frame's delay in hundredths of a second (`pacing::pace`).
    pub delays: &'a [u16],
}

/// The smallest rectangle (left, top, width, height) holding every index that differs.
fn changed_rect(prev: &[u8], next: &[u8], width: usize) -> Option<(usize, usize, usize, usize)> {
    let height = next.len() / width;
    let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
    for y in 0..height {
        let (a, b) = (&prev[y * width..(y + 1) * width], &next[y * width..(y + 1) * width]);
        if a == b {
            continue;
        }
        let first = a.iter().zip(b).position(|(p, q)| p != q).unwrap_or(0);
        let last = width - 1 - a.iter().rev().zip(b.iter().rev()).position(|(p, q)| p != q).unwrap_or(0);
        x0 = x0.min(first);
        x1 = x1.max(last);
        y0 = y0.min(y);
        y1 = y;
    }
    (x0 != usize::MAX).then(|| (x0, y0, x1 - x0 + 1, y1 - y0 + 1))
}

/// Frame `k` as a GIF frame: whole for the first, else the changed rectangle with unchanged
/// pixels transparent (a 1×1 transparent pixel when nothing changed), LZW-compressed.
fn delta_frame(indexed: &[Vec<u8>], k: usize, width: usize, delay: u16) -> Frame<'static> {
    let next = &indexed[k];
    let (rect, pixels) = if k == 0 {
        ((0, 0, width, next.len() / width), next.clone())
    } else {
        let prev = &indexed[k - 1];
        match changed_rect(prev, next, width) {
            None => ((0, 0, 1, 1), vec![TRANSPARENT]),
            Some((x, y, w, h)) => {
                let mut px = Vec::with_capacity(w * h);
                for row in y..y + h {
                    let span = row * width + x..row * width + x + w;
                    px.extend(prev[span.clone()].iter().zip(&next[span]).map(|(p, q)| if p == q { TRANSPARENT } else { *q }));
                }
                ((x, y, w, h), px)
            }
        }
    };
    let mut f = Frame {
        left: rect.0 as u16,
        top: rect.1 as u16,
        width: rect.2 as u16,
        height: rect.3 as u16,
        delay,
        dispose: DisposalMethod::Keep,
        transparent: (k > 0).then_some(TRANSPARENT),
        buffer: pixels.into(),
        ..Frame::default()
    };
    f.make_lzw_pre_encoded();
    f
}

/// Encodes `frames` as a GIF that loops forever; also returns the palette used.
pub fn encode(frames: &Frames) -> Result<(Vec<u8>, Palette), String> {
    let (w, h) = (u16::try_from(frames.width), u16::try_from(frames.height));
    let (Ok(w16), Ok(h16)) = (w, h) else {
        return Err(format!("a GIF is at most 65535 pixels a side; got {}x{}", frames.width, frames.height));
    };
    let hist = frames.rgb.par_iter().map(|f| Histogram::of_rgb(f)).reduce(Histogram::default, Histogram::merge);
    // 255 colours: the last index is the transparent "unchanged" one.
    let palette = Palette::build(&hist, 255);
    let indexed: Vec<Vec<u8>> = frames.rgb.par_iter().map(|f| palette.map_rgb(f)).collect();
    let encoded: Vec<Frame> =
        (0..indexed.len()).into_par_iter().map(|k| delta_frame(&indexed, k, frames.width as usize, frames.delays.get(k).copied().unwrap_or(pacing::MIN_DELAY_CS))).collect();
    let mut flat = palette.flat();
    flat.resize(256 * 3, 0);
    let fail = |e: gif::EncodingError| format!("GIF encoding failed: {e}");
    let mut enc = Encoder::new(Vec::new(), w16, h16, &flat).map_err(fail)?;
    enc.set_repeat(Repeat::Infinite).map_err(fail)?;
    for f in &encoded {
        enc.write_lzw_pre_encoded_frame(f).map_err(fail)?;
    }
    Ok((enc.into_inner().map_err(fail)?, palette))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Decodes a GIF into whole frames of palette indices (composited as a viewer would).
    fn decode(bytes: &[u8]) -> (Vec<[u8; 3]>, Vec<Vec<u8>>) {
        let mut opts = gif::DecodeOptions::new();
        opts.set_color_output(gif::ColorOutput::Indexed);
        let mut d = opts.read_info(bytes).unwrap();
        let (w, h) = (d.width() as usize, d.height() as usize);
        let pal: Vec<[u8; 3]> = d.global_palette().unwrap().chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
        let mut canvas = vec![0u8; w * h];
        let mut out = Vec::new();
        while let Some(f) = d.read_next_frame().unwrap() {
            for y in 0..f.height as usize {
                for x in 0..f.width as usize {
                    let v = f.buffer[y * f.width as usize + x];
                    if Some(v) != f.transparent {
                        canvas[(f.top as usize + y) * w + f.left as usize + x] = v;
                    }
                }
            }
            out.push(canvas.clone());
        }
        (pal, out)
    }

    #[test]
    fn frames_round_trip_exactly_with_few_colours() {
        let (w, h) = (8u32, 6u32);
        let frames: Vec<Vec<u8>> = (0..5)
            .map(|k| {
                let mut f = vec![255u8; (w * h * 3) as usize];
                let at = (k * 9 % (w * h) as usize) * 3;
                f[at..at + 3].copy_from_slice(&[200, 10, 10]);
                f
            })
            .collect();
        let (bytes, _) = encode(&Frames { width: w, height: h, rgb: &frames, delays: &[3; 5] }).unwrap();
        let (pal, decoded) = decode(&bytes);
        assert_eq!(decoded.len(), 5);
        for (f, d) in frames.iter().zip(&decoded) {
            let rgb: Vec<u8> = d.iter().flat_map(|i| pal[*i as usize]).collect();
            assert_eq!(&rgb, f);
        }
    }
}
