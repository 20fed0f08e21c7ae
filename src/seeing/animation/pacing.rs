//! When each frame of an animation is shown: at real time by default — a frame's delay is the
//! simulated time until the next one, divided by `speed` — in GIF's hundredths of a second.
//!
//! - Frames closer than `1 / fps` of playback are skipped (when several share a moment, the
//!   latest is kept: a scene being built shows once, built), so no delay is under 20 ms,
//!   which browsers would show as 100 ms. The last frame is always kept.
//! - Each frame is shown from halfway after the previous one to halfway before the next (the
//!   first from the start, the last to the end), with the boundaries rounded to hundredths, so
//!   the delays add up to the interval's simulated time / speed within a hundredth.
//! - An interval in which no time passes (only adds, poses, …) is shown at `fps`.

/// The shortest delay a frame gets (hundredths of a second).
pub const MIN_DELAY_CS: u16 = 2;

/// How an animation is timed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pacing {
    /// At most this many frames per second of playback (1–50).
    pub fps: u32,
    /// Playback speed: 1 real time, 2 twice as fast, 0.5 half.
    pub speed: f64,
}

impl Default for Pacing {
    fn default() -> Self {
        Pacing { fps: 30, speed: 1.0 }
    }
}

/// The frames shown (indices into `times`, the simulated time of each sample, ascending) and
/// each one's delay in hundredths of a second.
pub fn pace(times: &[f64], p: Pacing) -> Vec<(usize, u16)> {
    let Some((&t0, &t_end)) = times.first().zip(times.last()) else { return Vec::new() };
    let gap = 1.0 / f64::from(p.fps.clamp(1, 50));
    let speed = if p.speed.is_finite() && p.speed > 0.0 { p.speed } else { 1.0 };
    let play = |t: f64| (t - t0) / speed;
    if play(t_end) <= 0.0 {
        let delay = ((100.0 * gap).round() as u16).max(MIN_DELAY_CS);
        return (0..times.len()).map(|k| (k, delay)).collect();
    }
    let last = times.len() - 1;
    let mut kept: Vec<usize> = vec![0];
    for k in 1..times.len() {
        let prev = *kept.last().unwrap_or(&0);
        let d = play(times[k]) - play(times[prev]);
        if d >= gap - 1e-9 {
            kept.push(k);
        } else if d <= 0.0 || (k == last && kept.len() > 1) {
            // Same moment (keep the later state), or the end (always shown).
            if let Some(slot) = kept.last_mut() {
                *slot = k;
            }
        } else if k == last {
            kept.push(k);
        }
    }
    let total = play(t_end);
    let n = kept.len();
    // Boundaries in seconds of playback: 0, the midpoints, the end.
    let mut bounds = Vec::with_capacity(n + 1);
    bounds.push(0.0);
    for w in kept.windows(2) {
        bounds.push((play(times[w[0]]) + play(times[w[1]])) / 2.0);
    }
    bounds.push(total);
    let mut shown = 0i64; // hundredths already given out
    let mut out = Vec::with_capacity(n);
    for (j, &k) in kept.iter().enumerate() {
        let end = (bounds[j + 1] * 100.0).round() as i64;
        let delay = (end - shown).max(i64::from(MIN_DELAY_CS)).min(i64::from(u16::MAX));
        shown += delay;
        out.push((k, delay as u16));
    }
    out
}

/// Playing time of one loop (s).
pub fn duration_s(delays: &[(usize, u16)]) -> f64 {
    delays.iter().map(|(_, d)| f64::from(*d)).sum::<f64>() / 100.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn times(n: usize, dt: f64) -> Vec<f64> {
        (0..n).map(|k| k as f64 * dt).collect()
    }

    #[test]
    fn real_time_adds_up_to_the_interval() {
        // 2 s at 240 Hz sampled every 5 steps: 97 samples, 20.8 ms apart.
        let t: Vec<f64> = (0..=96).map(|k| (k * 5) as f64 / 240.0).chain([2.0]).collect();
        let d = pace(&t, Pacing { fps: 30, speed: 1.0 });
        assert!((duration_s(&d) - 2.0).abs() <= 0.02, "{}", duration_s(&d));
        assert!(d.iter().all(|(_, c)| *c >= MIN_DELAY_CS));
        assert_eq!(d.last().map(|(k, _)| *k), Some(t.len() - 1), "the end is shown");
        assert!(d.len() <= 61, "at most 30 frames a second: {}", d.len());
    }

    #[test]
    fn speed_scales_and_fps_caps() {
        let t = times(201, 0.01);
        let slow = pace(&t, Pacing { fps: 50, speed: 0.5 });
        assert!((duration_s(&slow) - 4.0).abs() <= 0.04);
        let fast = pace(&t, Pacing { fps: 10, speed: 4.0 });
        assert!((duration_s(&fast) - 0.5).abs() <= 0.02, "{}", duration_s(&fast));
        assert!(fast.iter().all(|(_, c)| *c >= 2));
    }

    #[test]
    fn same_moment_keeps_the_latest_and_no_time_uses_fps() {
        let d = pace(&[0.0, 0.0, 0.0, 0.5, 1.0], Pacing { fps: 30, speed: 1.0 });
        assert_eq!(d.iter().map(|(k, _)| *k).collect::<Vec<_>>(), vec![2, 3, 4]);
        let still = pace(&[0.0, 0.0, 0.0], Pacing { fps: 25, speed: 1.0 });
        assert_eq!(still, vec![(0, 4), (1, 4), (2, 4)]);
    }
}
