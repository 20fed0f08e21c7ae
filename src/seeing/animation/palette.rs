//! One palette for a whole animation, built from the colours its frames actually hold.
//!
//! Flat-shaded frames hold few distinct colours (each object's colour times a handful of face
//! shades, and the background), so when there are at most `max` of them the palette is exact
//! and the GIF is lossless. Otherwise a weighted median cut over the histogram picks `max`
//! colours, always splitting the box with the largest squared error, and every colour maps to
//! its nearest entry (lowest index on ties; no dithering). Everything is ordered by colour
//! value, so the same frames always give the same palette, whatever thread counted them.

use std::collections::HashMap;

/// An RGB colour packed as 0xRRGGBB.
pub type Rgb = u32;

/// Packs three bytes.
pub fn pack(p: &[u8]) -> Rgb {
    (u32::from(p[0]) << 16) | (u32::from(p[1]) << 8) | u32::from(p[2])
}

fn channels(c: Rgb) -> [i64; 3] {
    [i64::from((c >> 16) & 0xff), i64::from((c >> 8) & 0xff), i64::from(c & 0xff)]
}

/// How many pixels of each colour some frames hold.
#[derive(Default, Debug, Clone)]
pub struct Histogram(pub HashMap<Rgb, u64>);

impl Histogram {
    /// Counts an RGB image (3 bytes a pixel). Runs of one colour — most of a flat-shaded
    /// frame — cost one comparison a pixel, not a hash lookup.
    pub fn of_rgb(rgb: &[u8]) -> Histogram {
        let mut h = HashMap::new();
        let mut run: Option<(Rgb, u64)> = None;
        for px in rgb.chunks_exact(3) {
            let c = pack(px);
            match &mut run {
                Some((rc, n)) if *rc == c => *n += 1,
                _ => {
                    if let Some((rc, n)) = run.take() {
                        *h.entry(rc).or_insert(0) += n;
                    }
                    run = Some((c, 1));
                }
            }
        }
        if let Some((rc, n)) = run {
            *h.entry(rc).or_insert(0) += n;
        }
        Histogram(h)
    }

    /// Adds another histogram's counts.
    pub fn merge(mut self, other: Histogram) -> Histogram {
        for (c, n) in other.0 {
            *self.0.entry(c).or_insert(0) += n;
        }
        self
    }
}

/// A box of the colour cube during the median cut: its colours (with counts).
struct Cut {
    colors: Vec<(Rgb, u64)>,
    /// Sum over its pixels of the squared distance to their weighted mean.
    error: f64,
}

impl Cut {
    fn new(colors: Vec<(Rgb, u64)>) -> Cut {
        let mean = mean(&colors);
        let error = colors
            .iter()
            .map(|(c, n)| {
                let ch = channels(*c);
                (0..3).map(|k| (ch[k] as f64 - mean[k]).powi(2)).sum::<f64>() * *n as f64
            })
            .sum();
        Cut { colors, error }
    }

    /// Splits at the weighted median of the channel with the widest range; None for one colour.
    fn split(mut self) -> Result<(Cut, Cut), Cut> {
        if self.colors.len() < 2 {
            return Err(self);
        }
        let range = |k: usize| {
            let vals = self.colors.iter().map(|(c, _)| channels(*c)[k]);
            vals.clone().max().unwrap_or(0) - vals.min().unwrap_or(0)
        };
        let axis = (0..3).max_by_key(|&k| (range(k), std::cmp::Reverse(k))).unwrap_or(0);
        self.colors.sort_by_key(|(c, _)| (channels(*c)[axis], *c));
        let total: u64 = self.colors.iter().map(|(_, n)| n).sum();
        let mut acc = 0;
        let mut at = 1;
        for (i, (_, n)) in self.colors.iter().enumerate() {
            acc += n;
            if acc * 2 >= total {
                at = (i + 1).clamp(1, self.colors.len() - 1);
                break;
            }
        }
        let high = self.colors.split_off(at);
        Ok((Cut::new(self.colors), Cut::new(high)))
    }
}

fn mean(colors: &[(Rgb, u64)]) -> [f64; 3] {
    let total: u64 = colors.iter().map(|(_, n)| n).sum::<u64>().max(1);
    let mut m = [0.0; 3];
    for (c, n) in colors {
        let ch = channels(*c);
        for k in 0..3 {
            m[k] += ch[k] as f64 * *n as f64;
        }
    }
    m.map(|v| v / total as f64)
}

/// A palette and the map from every colour it was built from to its entry.
#[derive(Debug, Clone)]
pub struct Palette {
    /// Entries, RGB.
    pub colors: Vec<[u8; 3]>,
    index: HashMap<Rgb, u8>,
}

impl Palette {
    /// At most `max` (1..=256) colours for `hist`: exact when it holds no more.
    pub fn build(hist: &Histogram, max: usize) -> Palette {
        let max = max.clamp(1, 256);
        let mut all: Vec<(Rgb, u64)> = hist.0.iter().map(|(c, n)| (*c, *n)).collect();
        all.sort_unstable();
        let colors: Vec<[u8; 3]> = if all.len() <= max {
            all.iter().map(|(c, _)| unpack(*c)).collect()
        } else {
            let mut cuts = vec![Cut::new(all.clone())];
            while cuts.len() < max {
                // The box with the most error (first on ties: deterministic).
                let Some(worst) = (0..cuts.len())
                    .filter(|&i| cuts[i].colors.len() > 1)
                    .max_by(|&a, &b| cuts[a].error.total_cmp(&cuts[b].error).then(b.cmp(&a)))
                else {
                    break;
                };
                match cuts.swap_remove(worst).split() {
                    Ok((a, b)) => {
                        cuts.push(a);
                        cuts.push(b);
                    }
                    Err(c) => {
                        cuts.push(c);
                        break;
                    }
                }
            }
            let mut entries: Vec<[u8; 3]> =
                cuts.iter().map(|c| mean(&c.colors).map(|v| v.round().clamp(0.0, 255.0) as u8)).collect();
            entries.sort_unstable();
            entries.dedup();
            entries
        };
        let index = all.iter().map(|(c, _)| (*c, nearest(&colors, *c))).collect();
        Palette { colors, index }
    }

    /// The entry for a colour: its own when the palette was built from it, else the nearest.
    pub fn index_of(&self, c: Rgb) -> u8 {
        self.index.get(&c).copied().unwrap_or_else(|| nearest(&self.colors, c))
    }

    /// The entries as the GIF format's flat `[r, g, b, …]`.
    pub fn flat(&self) -> Vec<u8> {
        self.colors.iter().flatten().copied().collect()
    }

    /// Maps an RGB image to palette indices (runs of one colour looked up once).
    pub fn map_rgb(&self, rgb: &[u8]) -> Vec<u8> {
        let mut out = Vec::with_capacity(rgb.len() / 3);
        let mut last: Option<(Rgb, u8)> = None;
        for px in rgb.chunks_exact(3) {
            let c = pack(px);
            let i = match last {
                Some((lc, li)) if lc == c => li,
                _ => self.index_of(c),
            };
            last = Some((c, i));
            out.push(i);
        }
        out
    }
}

fn unpack(c: Rgb) -> [u8; 3] {
    [(c >> 16) as u8, (c >> 8) as u8, c as u8]
}

/// The entry nearest to `c` (squared RGB distance; lowest index on ties).
pub fn nearest(colors: &[[u8; 3]], c: Rgb) -> u8 {
    let ch = channels(c);
    let mut best = (i64::MAX, 0usize);
    for (i, e) in colors.iter().enumerate() {
        let d: i64 = (0..3).map(|k| (ch[k] - i64::from(e[k])).pow(2)).sum();
        if d < best.0 {
            best = (d, i);
        }
    }
    best.1 as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn few_colours_give_an_exact_palette() {
        let rgb = [255, 255, 255, 255, 255, 255, 10, 20, 30, 255, 0, 0];
        let p = Palette::build(&Histogram::of_rgb(&rgb), 255);
        assert_eq!(p.colors.len(), 3);
        let idx = p.map_rgb(&rgb);
        for (i, px) in idx.iter().zip(rgb.chunks(3)) {
            assert_eq!(&p.colors[*i as usize][..], px);
        }
    }

    #[test]
    fn many_colours_are_cut_to_the_limit_deterministically() {
        let rgb: Vec<u8> = (0..4096u32).flat_map(|i| [(i % 16 * 16) as u8, (i / 16 % 16 * 16) as u8, (i / 256 * 16) as u8]).collect();
        let a = Palette::build(&Histogram::of_rgb(&rgb), 255);
        let b = Palette::build(&Histogram::of_rgb(&rgb).merge(Histogram::default()), 255);
        assert!(a.colors.len() <= 255 && a.colors.len() > 200, "{}", a.colors.len());
        assert_eq!(a.colors, b.colors);
        // Every pixel maps to its nearest entry.
        for px in rgb.chunks(3) {
            assert_eq!(a.index_of(pack(px)), nearest(&a.colors, pack(px)));
        }
    }
}
