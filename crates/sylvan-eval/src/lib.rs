//! Image metrics for Sylvan: ꟻLIP, SSIM and PSNR, and a small fidelity harness.
//!
//! Every technique is measured against the full-geometry ground truth by comparing two sRGB PNGs.
//! This crate owns those comparisons; it never renders.
//!
//! # Metrics
//!
//! - **ꟻLIP** ([`flip`]): NVIDIA's perceptual difference metric (Andersson et al. 2020), through
//!   the `nv-flip` crate — the same binding wgpu's own image tests use. `nv-flip` wraps the
//!   **LDR** variant of ꟻLIP only, which is the right one here: Sylvan's outputs are 8-bit sRGB
//!   PNGs, already tone-mapped. We use the default **67 pixels per degree**
//!   ([`PIXELS_PER_DEGREE`], `nv_flip::DEFAULT_PIXELS_PER_DEGREE`): a 0.7 m wide 4K monitor seen
//!   from 0.7 m, the viewing condition ꟻLIP's authors use for their reported numbers, so our
//!   means are comparable with theirs and with wgpu's thresholds. Lower is better; 0 = identical.
//! - **SSIM** ([`ssim`]): Wang et al. 2004, on Rec.709 luma of the sRGB-encoded values, with an
//!   11×11 Gaussian window (σ = 1.5), K1 = 0.01, K2 = 0.03, L = 255, averaged over the windows
//!   that fit inside the image (no padding, no down-sampling). 1 = identical.
//! - **PSNR** ([`psnr`]): over all R, G and B samples, 8-bit peak 255. Identical images give
//!   `f64::INFINITY`; `serde_json` writes that as `null` (JSON has no infinity), so a JSON
//!   reader must read `"psnr": null` as "identical".
//!
//! [`compare`] computes all three as [`Metrics`] ([`compare_detailed`] also keeps the ꟻLIP
//! heat-map and percentiles); [`load_rgb`] and [`save_png`] read and write the PNGs;
//! [`fidelity`] turns per-technique metrics into a Markdown table.

mod error;
pub mod fidelity;
mod flip;
mod io;
mod mean;
mod psnr;
mod ssim;

pub use error::EvalError;
pub use fidelity::{FidelityRow, markdown_table};
pub use flip::{Flip, PIXELS_PER_DEGREE, flip};
pub use image::RgbImage;
pub use io::{MAX_IMAGE_FILE_BYTES, MAX_IMAGE_PIXELS, load_rgb, save_png};
pub use mean::mean_linear;
pub use psnr::psnr;
pub use ssim::ssim;

use serde::Serialize;

/// The three metrics of one comparison, as `sylvan compare --json` prints them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Metrics {
    /// Mean ꟻLIP error in [0, 1]; 0 = identical.
    pub flip_mean: f32,
    /// Mean SSIM of the luma, in [-1, 1]; 1 = identical. `None` (JSON `null`) when the images
    /// are smaller than SSIM's 11×11 window: ꟻLIP, PSNR and the means still apply there.
    pub ssim: Option<f64>,
    /// PSNR over RGB in dB; `f64::INFINITY` when identical (serialised by `serde_json` as `null`).
    pub psnr: f64,
}

/// Compares `test` against `reference` with all three metrics.
///
/// # Errors
///
/// [`EvalError::SizeMismatch`] when the sizes differ, [`EvalError::Empty`] when they are empty.
/// Images smaller than SSIM's 11×11 window (a few rows of a render) are compared without it.
pub fn compare(reference: &RgbImage, test: &RgbImage) -> Result<Metrics, EvalError> {
    compare_detailed(reference, test).map(|(metrics, _)| metrics)
}

/// [`compare`], also returning the full ꟻLIP result (heat-map, percentiles), computed once.
///
/// # Errors
///
/// As [`compare`].
pub fn compare_detailed(
    reference: &RgbImage,
    test: &RgbImage,
) -> Result<(Metrics, Flip), EvalError> {
    // SSIM first: it checks both the sizes, before any ꟻLIP work.
    let ssim = match ssim(reference, test) {
        Ok(s) => Some(s),
        Err(EvalError::TooSmall { .. }) => None,
        Err(e) => return Err(e),
    };
    let flip = flip(reference, test)?;
    let metrics = Metrics {
        flip_mean: flip.mean,
        ssim,
        psnr: psnr(reference, test)?,
    };
    Ok((metrics, flip))
}

/// Checks that two images have the same, non-zero size.
fn check_sizes(reference: &RgbImage, test: &RgbImage) -> Result<(), EvalError> {
    if reference.dimensions() != test.dimensions() {
        return Err(EvalError::SizeMismatch {
            reference: reference.dimensions(),
            test: test.dimensions(),
        });
    }
    if reference.width() == 0 || reference.height() == 0 {
        return Err(EvalError::Empty);
    }
    Ok(())
}
