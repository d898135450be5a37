//! ꟻLIP (LDR) through `nv-flip`, with the heat-map and exact per-pixel percentiles.

use crate::{EvalError, RgbImage, check_sizes};

/// Pixels per degree of visual angle used for every ꟻLIP comparison: `nv-flip`'s default, 67
/// (a 0.7 m wide 3840-pixel monitor seen from 0.7 m). See the crate docs for why.
pub const PIXELS_PER_DEGREE: f32 = nv_flip::DEFAULT_PIXELS_PER_DEGREE;

/// The result of one ꟻLIP comparison.
#[derive(Debug, Clone)]
pub struct Flip {
    /// Mean per-pixel error in [0, 1] (`nv_flip::FlipPool::mean`); 0 = identical. ꟻLIP's authors
    /// recommend this as the single number to report.
    pub mean: f32,
    /// Median per-pixel error: half of the pixels have an error at or below it.
    pub p50: f32,
    /// 95th percentile of the per-pixel error: 95 % of the pixels are at or below it.
    pub p95: f32,
    /// Largest per-pixel error.
    pub max: f32,
    /// The error map coloured with ꟻLIP's magma colour map (black = 0, pale yellow = 1), made by
    /// `nv-flip`'s own look-up table, the same as the `flip` command-line tool's output.
    pub heatmap: RgbImage,
}

/// Runs ꟻLIP (LDR, [`PIXELS_PER_DEGREE`]) on two sRGB images.
///
/// Percentiles are exact, nearest-rank, over the pixels of the error map, unweighted (ꟻLIP's
/// own "weighted" percentiles weight each pixel by its error, which is not what p95 usually means).
///
/// # Errors
///
/// [`EvalError::SizeMismatch`] or [`EvalError::Empty`].
pub fn flip(reference: &RgbImage, test: &RgbImage) -> Result<Flip, EvalError> {
    check_sizes(reference, test)?;
    let (width, height) = reference.dimensions();
    let to_flip = |img: &RgbImage| nv_flip::FlipImageRgb8::with_data(width, height, img.as_raw());
    let error_map = nv_flip::flip(to_flip(reference), to_flip(test), PIXELS_PER_DEGREE);

    let mean = nv_flip::FlipPool::from_image(&error_map).mean();
    let coloured = error_map.apply_color_lut(&nv_flip::magma_lut());
    let heatmap = RgbImage::from_raw(width, height, coloured.to_vec())
        .expect("nv-flip returns width × height × 3 bytes");

    let mut errors = error_map.to_vec();
    errors.sort_by(f32::total_cmp);
    Ok(Flip {
        mean,
        p50: percentile(&errors, 0.50),
        p95: percentile(&errors, 0.95),
        max: *errors.last().expect("check_sizes rejects empty images"),
        heatmap,
    })
}

/// Nearest-rank percentile `p` in [0, 1] of sorted, non-empty `values`.
fn percentile(sorted: &[f32], p: f64) -> f32 {
    let rank = (p * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

#[cfg(test)]
mod tests {
    use super::percentile;

    #[test]
    fn nearest_rank_percentiles() {
        let v: Vec<f32> = (1..=20).map(|i| i as f32).collect();
        assert_eq!(percentile(&v, 0.5), 10.0);
        assert_eq!(percentile(&v, 0.95), 19.0);
        assert_eq!(percentile(&v, 1.0), 20.0);
        assert_eq!(percentile(&v, 0.0), 1.0);
        assert_eq!(percentile(&[0.25], 0.95), 0.25);
    }
}
