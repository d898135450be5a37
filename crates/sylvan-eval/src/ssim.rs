//! Structural similarity (Wang, Bovik, Sheikh, Simoncelli 2004) on luma.

use crate::{EvalError, RgbImage, check_sizes};

/// Side of the Gaussian window, pixels.
const WINDOW: usize = 11;
/// Standard deviation of the Gaussian window, pixels.
const SIGMA: f64 = 1.5;
/// Dynamic range of 8-bit values.
const L: f64 = 255.0;
const C1: f64 = (0.01 * L) * (0.01 * L);
const C2: f64 = (0.03 * L) * (0.03 * L);

/// Mean SSIM of `a` and `b`, in [-1, 1]; 1 = identical. Symmetric.
///
/// As in the paper's reference code (`ssim_index.m`): luma is Rec.709
/// (`0.2126 R' + 0.7152 G' + 0.0722 B'`) of the sRGB-encoded 8-bit values, unrounded; local
/// statistics use an 11×11 Gaussian window with σ = 1.5, normalised to sum 1; K1 = 0.01,
/// K2 = 0.03, L = 255; the result is the mean of the SSIM map over every window position that
/// lies wholly inside the image (no padding, no down-sampling).
///
/// # Errors
///
/// [`EvalError::SizeMismatch`], [`EvalError::Empty`], or [`EvalError::TooSmall`] when either side
/// is under 11 pixels.
pub fn ssim(a: &RgbImage, b: &RgbImage) -> Result<f64, EvalError> {
    check_sizes(a, b)?;
    let (width, height) = a.dimensions();
    if (width as usize) < WINDOW || (height as usize) < WINDOW {
        return Err(EvalError::TooSmall {
            width,
            height,
            min: WINDOW as u32,
        });
    }
    let (w, h) = (width as usize, height as usize);
    let x = luma(a);
    let y = luma(b);
    let kernel = gaussian_kernel();
    let product =
        |p: &[f64], q: &[f64]| -> Vec<f64> { p.iter().zip(q).map(|(p, q)| p * q).collect() };

    let mu_x = filter_valid(&x, w, h, &kernel);
    let mu_y = filter_valid(&y, w, h, &kernel);
    let xx = filter_valid(&product(&x, &x), w, h, &kernel);
    let yy = filter_valid(&product(&y, &y), w, h, &kernel);
    let xy = filter_valid(&product(&x, &y), w, h, &kernel);

    let sum: f64 = (0..mu_x.len())
        .map(|i| {
            let (mx, my) = (mu_x[i], mu_y[i]);
            let var_x = xx[i] - mx * mx;
            let var_y = yy[i] - my * my;
            let cov = xy[i] - mx * my;
            ((2.0 * mx * my + C1) * (2.0 * cov + C2))
                / ((mx * mx + my * my + C1) * (var_x + var_y + C2))
        })
        .sum();
    Ok(sum / mu_x.len() as f64)
}

/// Rec.709 luma of the sRGB-encoded values, row-major.
fn luma(img: &RgbImage) -> Vec<f64> {
    img.pixels()
        .map(|p| {
            let [r, g, b] = p.0.map(f64::from);
            0.2126 * r + 0.7152 * g + 0.0722 * b
        })
        .collect()
}

/// 1-D Gaussian of [`WINDOW`] taps and σ = [`SIGMA`], summing to 1. The 2-D window is its outer
/// product with itself (the same as MATLAB's `fspecial('gaussian', 11, 1.5)`).
fn gaussian_kernel() -> [f64; WINDOW] {
    let centre = (WINDOW / 2) as f64;
    let mut k = [0.0; WINDOW];
    for (i, v) in k.iter_mut().enumerate() {
        let d = i as f64 - centre;
        *v = (-d * d / (2.0 * SIGMA * SIGMA)).exp();
    }
    let sum: f64 = k.iter().sum();
    k.map(|v| v / sum)
}

/// Separable 2-D correlation of a `w`×`h` row-major map with `kernel`⊗`kernel`, keeping only
/// the positions where the window lies inside the map: `(w - 10) × (h - 10)` values.
fn filter_valid(src: &[f64], w: usize, h: usize, kernel: &[f64; WINDOW]) -> Vec<f64> {
    let ow = w + 1 - WINDOW;
    let oh = h + 1 - WINDOW;
    // Horizontal pass: h rows of ow values.
    let mut rows = Vec::with_capacity(ow * h);
    for row in src.chunks_exact(w) {
        rows.extend(row.windows(WINDOW).map(|win| dot(win, kernel)));
    }
    // Vertical pass: oh rows of ow values.
    let mut out = Vec::with_capacity(ow * oh);
    let mut column = [0.0; WINDOW];
    for oy in 0..oh {
        for ox in 0..ow {
            for (k, c) in column.iter_mut().enumerate() {
                *c = rows[(oy + k) * ow + ox];
            }
            out.push(dot(&column, kernel));
        }
    }
    out
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(a, b)| a * b).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_is_normalised_and_symmetric() {
        let k = gaussian_kernel();
        assert!((k.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        for i in 0..WINDOW {
            assert_eq!(k[i], k[WINDOW - 1 - i]);
        }
        assert!(k[5] > k[4] && k[4] > k[0]);
    }

    #[test]
    fn valid_filter_of_a_constant_is_the_constant() {
        let src = vec![3.0; 13 * 12];
        let out = filter_valid(&src, 13, 12, &gaussian_kernel());
        assert_eq!(out.len(), 3 * 2);
        assert!(out.iter().all(|v| (v - 3.0).abs() < 1e-12));
    }

    #[test]
    fn valid_filter_picks_the_window_centre_weight() {
        // A single 1 at (6, 5) in a 12x11 map: output (ox, oy) sees it at tap (6-ox, 5-oy).
        let (w, h) = (12, 11);
        let mut src = vec![0.0; w * h];
        src[5 * w + 6] = 1.0;
        let k = gaussian_kernel();
        let out = filter_valid(&src, w, h, &k);
        assert_eq!(out.len(), 2);
        assert!((out[0] - k[6] * k[5]).abs() < 1e-15);
        assert!((out[1] - k[5] * k[5]).abs() < 1e-15);
    }
}
