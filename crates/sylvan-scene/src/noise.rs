//! Deterministic 2D gradient noise (Perlin-style, hashed gradients, quintic fade), fractal
//! Brownian motion and ridged multifractal noise, for procedural terrain. Written here so terrain
//! is identical across platforms and crate versions.

use crate::rng::hash2;

/// Gradient noise at `(x, y)`, roughly in [-1, 1], zero at integer lattice points.
pub fn gradient(seed: u64, x: f64, y: f64) -> f64 {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (ix, iy) = (x0 as i64, y0 as i64);
    let dot = |cx: i64, cy: i64, dx: f64, dy: f64| {
        let (gx, gy) = GRADIENTS[(hash2(seed, ix + cx, iy + cy) >> 60) as usize];
        gx * dx + gy * dy
    };
    let n00 = dot(0, 0, fx, fy);
    let n10 = dot(1, 0, fx - 1.0, fy);
    let n01 = dot(0, 1, fx, fy - 1.0);
    let n11 = dot(1, 1, fx - 1.0, fy - 1.0);
    let (u, v) = (fade(fx), fade(fy));
    let nx0 = n00 + u * (n10 - n00);
    let nx1 = n01 + u * (n11 - n01);
    // Max of 2D Perlin with unit gradients is √2/2; scale to ~[-1, 1].
    (nx0 + v * (nx1 - nx0)) * std::f64::consts::SQRT_2
}

const S: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// 16 evenly spaced unit gradients.
const GRADIENTS: [(f64, f64); 16] = [
    (1.0, 0.0),
    (0.923879532511287, 0.38268343236509),
    (S, S),
    (0.38268343236509, 0.923879532511287),
    (0.0, 1.0),
    (-0.38268343236509, 0.923879532511287),
    (-S, S),
    (-0.923879532511287, 0.38268343236509),
    (-1.0, 0.0),
    (-0.923879532511287, -0.38268343236509),
    (-S, -S),
    (-0.38268343236509, -0.923879532511287),
    (0.0, -1.0),
    (0.38268343236509, -0.923879532511287),
    (S, -S),
    (0.923879532511287, -0.38268343236509),
];

fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// Fractal Brownian motion: `octaves` of gradient noise, frequency ×2 and amplitude ×`gain` each.
/// Normalised to roughly [-1, 1].
pub fn fbm(seed: u64, x: f64, y: f64, octaves: u32, gain: f64) -> f64 {
    let (mut sum, mut amp, mut freq, mut norm) = (0.0, 1.0, 1.0, 0.0);
    for o in 0..octaves {
        // Rotate each octave a little to break lattice alignment.
        let (rx, ry) = rotate(x * freq, y * freq, o);
        sum += amp * gradient(seed.wrapping_add(o as u64 * 1013), rx, ry);
        norm += amp;
        amp *= gain;
        freq *= 2.0;
    }
    sum / norm
}

/// Ridged multifractal noise in [0, 1]: sharp crests where the noise crosses zero, with each
/// octave weighted by the previous one so valleys stay smooth (Musgrave's ridged multifractal).
pub fn ridged(seed: u64, x: f64, y: f64, octaves: u32) -> f64 {
    let (mut sum, mut amp, mut freq, mut norm, mut weight) = (0.0, 1.0, 1.0, 0.0, 1.0);
    for o in 0..octaves {
        let (rx, ry) = rotate(x * freq, y * freq, o + 7);
        let n = gradient(seed.wrapping_add(0xA5A5 + o as u64 * 7919), rx, ry);
        let r = (1.0 - n.abs()).powi(2) * weight;
        weight = (r * 2.0).clamp(0.0, 1.0);
        sum += amp * r;
        norm += amp;
        amp *= 0.5;
        freq *= 2.0;
    }
    sum / norm
}

fn rotate(x: f64, y: f64, octave: u32) -> (f64, f64) {
    let a = 0.5 + octave as f64 * 0.37;
    let (s, c) = a.sin_cos();
    (
        c * x - s * y + octave as f64 * 17.13,
        s * x + c * y - octave as f64 * 5.71,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_is_deterministic_and_bounded() {
        let mut lo: f64 = 0.0;
        let mut hi: f64 = 0.0;
        for i in 0..2000 {
            let (x, y) = (i as f64 * 0.137, i as f64 * 0.291 - 40.0);
            let n = gradient(3, x, y);
            assert_eq!(n, gradient(3, x, y));
            lo = lo.min(n);
            hi = hi.max(n);
            let f = fbm(3, x, y, 5, 0.5);
            assert!((-1.5..=1.5).contains(&f));
            let r = ridged(3, x, y, 5);
            assert!((0.0..=1.0).contains(&r));
        }
        assert!(lo < -0.3 && hi > 0.3, "noise has range {lo}..{hi}");
        assert_eq!(gradient(1, 4.0, -2.0), 0.0);
        assert_ne!(gradient(1, 0.5, 0.5), gradient(2, 0.5, 0.5));
    }
}
