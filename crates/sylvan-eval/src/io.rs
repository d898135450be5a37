//! Reading and writing PNGs, with errors that name the file.

use crate::{EvalError, RgbImage};
use std::path::Path;

/// Largest image file read, bytes (read through `sylvan_io`, checked while reading).
pub const MAX_IMAGE_FILE_BYTES: u64 = 256 << 20;
/// Most pixels (width × height) in an image compared, checked from the header before decoding:
/// 4096² keeps ꟻLIP's working buffers for two images well under 1 GB.
pub const MAX_IMAGE_PIXELS: u64 = 4096 * 4096;

/// Reads a PNG (8- or 16-bit; grey, grey + alpha, RGB or RGBA) as 8-bit RGB.
///
/// Alpha is **dropped**, not composited: the colour channels are kept as stored. Sylvan's renders
/// are opaque, and compositing over an arbitrary background would invent colours neither image
/// has. 16-bit channels are rounded to 8 bits; grey is copied to R, G and B.
///
/// # Errors
///
/// [`EvalError::File`] when `path` is not a readable regular file of at most
/// [`MAX_IMAGE_FILE_BYTES`]; [`EvalError::TooManyPixels`] when its header declares more than
/// [`MAX_IMAGE_PIXELS`] (checked before decoding); [`EvalError::Read`] when it cannot be decoded.
pub fn load_rgb(path: impl AsRef<Path>) -> Result<RgbImage, EvalError> {
    let path = path.as_ref();
    let bytes = sylvan_io::read(path, MAX_IMAGE_FILE_BYTES).map_err(|source| EvalError::File {
        path: path.to_owned(),
        source,
    })?;
    let reader = || image::ImageReader::new(std::io::Cursor::new(&bytes[..])).with_guessed_format();
    let read_err = |source| EvalError::Read {
        path: path.to_owned(),
        source,
    };
    let (width, height) = reader()
        .map_err(|e| read_err(e.into()))?
        .into_dimensions()
        .map_err(read_err)?;
    if u64::from(width) * u64::from(height) > MAX_IMAGE_PIXELS {
        return Err(EvalError::TooManyPixels {
            path: path.to_owned(),
            width,
            height,
            limit: MAX_IMAGE_PIXELS,
        });
    }
    let image = reader()
        .map_err(|e| read_err(e.into()))?
        .decode()
        .map_err(read_err)?;
    Ok(image.to_rgb8())
}

/// Writes `image` as an 8-bit RGB PNG (e.g. a ꟻLIP heat-map).
///
/// # Errors
///
/// [`EvalError::Write`] naming `path` when it cannot be written.
pub fn save_png(path: impl AsRef<Path>, image: &RgbImage) -> Result<(), EvalError> {
    let path = path.as_ref();
    if path.is_dir() {
        return Err(EvalError::WriteToFolder {
            path: path.to_owned(),
        });
    }
    image
        .save_with_format(path, image::ImageFormat::Png)
        .map_err(|source| EvalError::Write {
            path: path.to_owned(),
            source,
        })
}
