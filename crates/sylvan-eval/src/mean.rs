//! The mean colour of an 8-bit sRGB image, in linear light: what a bias between two renders is
//! measured in (ꟻLIP, SSIM and PSNR mix bias with texture).

use crate::{EvalError, RgbImage};

/// The mean linear R, G and B of `image` (each sample sRGB-decoded, then averaged).
///
/// # Errors
///
/// [`EvalError::Empty`] for an image without pixels.
pub fn mean_linear(image: &RgbImage) -> Result<[f64; 3], EvalError> {
    let pixels = u64::from(image.width()) * u64::from(image.height());
    if pixels == 0 {
        return Err(EvalError::Empty);
    }
    let decode: Vec<f64> = (0..=255u8)
        .map(|v| srgb_to_linear(f64::from(v) / 255.0))
        .collect();
    let mut sum = [0.0f64; 3];
    for p in image.pixels() {
        for (s, &v) in sum.iter_mut().zip(&p.0) {
            *s += decode[usize::from(v)];
        }
    }
    Ok(sum.map(|s| s / pixels as f64))
}

/// The sRGB transfer function's inverse (IEC 61966-2-1).
fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn means_are_linear() {
        let mut img = RgbImage::new(2, 1);
        img.put_pixel(0, 0, image::Rgb([255, 0, 188]));
        img.put_pixel(1, 0, image::Rgb([0, 0, 188]));
        let m = mean_linear(&img).unwrap();
        assert!((m[0] - 0.5).abs() < 1e-12, "{m:?}");
        assert_eq!(m[1], 0.0);
        // sRGB 188 is linear ≈ 0.5029.
        assert!((m[2] - 0.5029).abs() < 1e-3, "{m:?}");
        assert!(matches!(
            mean_linear(&RgbImage::new(0, 0)),
            Err(EvalError::Empty)
        ));
    }
}
