//! Sizes that fit a pixel budget: a refused picture names one, so the next call can succeed
//! without a guess (an agent told only "at most N pixels" has to do the arithmetic itself).

/// The largest `w × h` with the shape of `width × height` (each side scaled by the same
/// factor, rounded down, at least 1) holding at most `max_px` pixels.
pub fn size_that_fits(width: u32, height: u32, max_px: u64) -> (u32, u32) {
    let (w, h) = (f64::from(width.max(1)), f64::from(height.max(1)));
    let mut scale = (max_px as f64 / (w * h)).sqrt().min(1.0);
    loop {
        let fit = (((w * scale).floor() as u32).max(1), ((h * scale).floor() as u32).max(1));
        if u64::from(fit.0) * u64::from(fit.1) <= max_px || scale <= 0.0 || fit == (1, 1) {
            return fit;
        }
        scale *= 0.999;
    }
}

/// "; WxH keeps its shape and fits" for a refusal, or "" when no such size exists.
pub fn hint(width: u32, height: u32, max_px: u64) -> String {
    let (w, h) = size_that_fits(width, height, max_px);
    if u64::from(w) * u64::from(h) > max_px {
        return String::new();
    }
    format!("; {w}x{h} keeps its shape and fits")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_size_keeps_the_shape_and_fits() {
        for (w, h, max) in [(4000, 3000, 4_194_304), (10_000, 1, 5000), (1, 10_000, 5000), (321, 241, 320 * 240), (7, 13, 1)] {
            let (fw, fh) = size_that_fits(w, h, max);
            assert!(u64::from(fw) * u64::from(fh) <= max, "{w}x{h} in {max}: {fw}x{fh}");
            assert!(fw >= 1 && fh >= 1);
            let ratio = (f64::from(fw) / f64::from(fh)) / (f64::from(w) / f64::from(h));
            assert!(fw == 1 || fh == 1 || (0.9..1.1).contains(&ratio), "{w}x{h} → {fw}x{fh}");
        }
        assert_eq!(size_that_fits(4000, 3000, 4_194_304), (2364, 1773));
    }
}
