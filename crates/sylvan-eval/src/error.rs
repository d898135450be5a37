//! The one error type of this crate.

use std::path::PathBuf;

/// What can go wrong when reading, writing or comparing images.
///
/// `Display` is one line, `FILE: what — fix` where a file applies, `what — fix` otherwise.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EvalError {
    /// An image file could not be opened or decoded.
    #[error("{}: cannot read image: {source} — check that the file exists and is a PNG", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: image::ImageError,
    },
    /// An image file could not be read at all (missing, a device or FIFO, too large).
    #[error("{}: {source} — {}", path.display(), source.fix())]
    File {
        /// The file.
        path: PathBuf,
        /// Why.
        source: sylvan_io::ReadError,
    },
    /// The image header declares more pixels than [`crate::MAX_IMAGE_PIXELS`]; refused before
    /// decoding.
    #[error(
        "{}: the image is {width}x{height}, more than the limit of {limit} pixels — compare images of at most 4096x4096 pixels (render at a smaller --size)",
        path.display()
    )]
    TooManyPixels {
        /// The file.
        path: PathBuf,
        /// Width from the header.
        width: u32,
        /// Height from the header.
        height: u32,
        /// The limit, pixels.
        limit: u64,
    },
    /// An image file could not be written to a path that is a folder.
    #[error("{}: cannot write image: it is a folder — give a file name, e.g. {}/out.png", path.display(), path.display())]
    WriteToFolder {
        /// The folder.
        path: PathBuf,
    },
    /// An image file could not be written.
    #[error("{}: cannot write image: {source} — check that the folder exists and is writable", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        source: image::ImageError,
    },
    /// The two images differ in size.
    #[error(
        "image sizes differ: reference is {}x{}, test is {}x{} — compare images rendered at the same --size",
        reference.0, reference.1, test.0, test.1
    )]
    SizeMismatch {
        /// Width and height of the reference image.
        reference: (u32, u32),
        /// Width and height of the test image.
        test: (u32, u32),
    },
    /// The images have no pixels.
    #[error("images are empty (0 pixels) — compare images of at least 11x11 pixels")]
    Empty,
    /// The images are smaller than SSIM's window.
    #[error(
        "images are {width}x{height}, smaller than SSIM's {min}x{min} window — compare images of at least {min}x{min} pixels"
    )]
    TooSmall {
        /// Width of both images.
        width: u32,
        /// Height of both images.
        height: u32,
        /// The smallest width and height SSIM accepts.
        min: u32,
    },
}
