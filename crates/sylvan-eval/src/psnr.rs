//! Peak signal-to-noise ratio over the R, G and B samples of 8-bit images.

use crate::{EvalError, RgbImage, check_sizes};

/// PSNR in dB of `test` against `reference`: `10·log10(255² / MSE)`, the mean squared error taken
/// over every R, G and B sample. Symmetric. `f64::INFINITY` when the images are identical
/// (`serde_json` writes it as `null`).
///
/// # Errors
///
/// [`EvalError::SizeMismatch`] or [`EvalError::Empty`].
pub fn psnr(reference: &RgbImage, test: &RgbImage) -> Result<f64, EvalError> {
    check_sizes(reference, test)?;
    // Exact integer sum: at most 255² per sample, so u64 cannot overflow for any real image.
    let sum_sq: u64 = reference
        .as_raw()
        .iter()
        .zip(test.as_raw())
        .map(|(&a, &b)| u64::from(a.abs_diff(b)).pow(2))
        .sum();
    if sum_sq == 0 {
        return Ok(f64::INFINITY);
    }
    let mse = sum_sq as f64 / reference.as_raw().len() as f64;
    Ok(10.0 * (255.0_f64 * 255.0 / mse).log10())
}
