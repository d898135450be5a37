//! Reading and writing PNGs, with errors that name the file.

use crate::{EvalError, RgbImage};
use std::path::Path;

/// Reads a PNG (8- or 16-bit; grey, grey + alpha, RGB or RGBA) as 8-bit RGB.
///
/// Alpha is **dropped**, not composited: the colour channels are kept as stored. Sylvan's renders
/// are opaque, and compositing over an arbitrary background would invent colours neither image
/// has. 16-bit channels are rounded to 8 bits; grey is copied to R, G and B.
///
/// # Errors
///
/// [`EvalError::Read`] naming `path` when it cannot be opened or decoded.
pub fn load_rgb(path: impl AsRef<Path>) -> Result<RgbImage, EvalError> {
    let path = path.as_ref();
    let read = || -> Result<RgbImage, image::ImageError> {
        let image = image::ImageReader::open(path)?
            .with_guessed_format()?
            .decode()?;
        Ok(image.to_rgb8())
    };
    read().map_err(|source| EvalError::Read {
        path: path.to_owned(),
        source,
    })
}

/// Writes `image` as an 8-bit RGB PNG (e.g. a ꟻLIP heat-map).
///
/// # Errors
///
/// [`EvalError::Write`] naming `path` when it cannot be written.
pub fn save_png(path: impl AsRef<Path>, image: &RgbImage) -> Result<(), EvalError> {
    let path = path.as_ref();
    image
        .save_with_format(path, image::ImageFormat::Png)
        .map_err(|source| EvalError::Write {
            path: path.to_owned(),
            source,
        })
}
