//! Grayscale rasters for heightmaps and density maps: 8/16-bit grayscale PNG (via `image`) and
//! single-band GeoTIFF (via `tiff`: 8/16-bit unsigned, 16-bit signed, 32/64-bit float).
//! Dimensions are checked against [`MAX_IMAGE_DIM`] and [`MAX_TERRAIN_SAMPLES`] from the header,
//! before any pixel buffer is allocated.

use crate::error::{ErrorKind, Location, SceneError, read_error};
use crate::file::MAX_ELEVATION_M;
use crate::terrain::MAX_TERRAIN_SAMPLES;
use crate::types::Terrain;
use std::io::Cursor;
use std::path::Path;

/// Largest heightmap or density-map file read, bytes (checked while reading).
pub const MAX_RASTER_BYTES: u64 = 512 << 20;

/// Largest width or height of a heightmap or density map, pixels.
pub const MAX_IMAGE_DIM: u32 = 16_384;

/// What a raster is for (chooses the error wording).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Purpose {
    Heightmap,
    DensityMap,
}

impl Purpose {
    fn expected(self) -> &'static str {
        match self {
            Purpose::Heightmap => "not a 16-bit PNG or GeoTIFF heightmap",
            Purpose::DensityMap => "not an 8- or 16-bit grayscale PNG density map",
        }
    }

    fn fix(self) -> &'static str {
        match self {
            Purpose::Heightmap => {
                "export the DEM as a single-band 16-bit grayscale PNG or a 16-bit/float GeoTIFF"
            }
            Purpose::DensityMap => "save the map as an 8- or 16-bit grayscale PNG",
        }
    }
}

/// A decoded single-band raster, row-major, row 0 first.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Raster {
    pub width: u32,
    pub height: u32,
    /// Normalised to [0, 1] when `metres` is false; heights in metres when true.
    pub values: Vec<f32>,
    /// Whether the samples are absolute values (float or signed GeoTIFF) rather than
    /// normalised integers.
    pub metres: bool,
}

/// Read `path` as a grayscale raster. `at` is where the scene names the file (used for I/O and
/// limit errors); format errors point at the image file itself.
pub(crate) fn read_gray(
    path: &Path,
    purpose: Purpose,
    at: &Location,
) -> Result<Raster, SceneError> {
    let role = match purpose {
        Purpose::Heightmap => "heightmap",
        Purpose::DensityMap => "density map",
    };
    let bytes =
        sylvan_io::read(path, MAX_RASTER_BYTES).map_err(|e| read_error(e, path, at, role))?;
    decode_gray(&bytes, path, purpose, at)
}

/// Decode a grayscale raster from `bytes` (the contents of `path`); see [`read_gray`].
pub(crate) fn decode_gray(
    bytes: &[u8],
    path: &Path,
    purpose: Purpose,
    at: &Location,
) -> Result<Raster, SceneError> {
    let not_image = |why: String| {
        SceneError::new(
            ErrorKind::Image,
            Location::file(path),
            format!("{} ({why})", purpose.expected()),
            purpose.fix(),
        )
    };
    let magic = &bytes[..bytes.len().min(8)];
    let raster = if magic.starts_with(b"\x89PNG") {
        read_png(bytes, path, &not_image, at)?
    } else if magic.starts_with(b"II*\0") || magic.starts_with(b"MM\0*") {
        if purpose == Purpose::DensityMap {
            return Err(not_image("a TIFF; density maps are PNG".into()));
        }
        read_tiff(bytes, path, &not_image, at)?
    } else {
        return Err(not_image("neither PNG nor TIFF signature".into()));
    };
    Ok(raster)
}

fn check_dims(w: u32, h: u32, at: &Location, path: &Path) -> Result<(), SceneError> {
    if w == 0
        || h == 0
        || w > MAX_IMAGE_DIM
        || h > MAX_IMAGE_DIM
        || w as u64 * h as u64 > MAX_TERRAIN_SAMPLES
    {
        return Err(SceneError::new(
            ErrorKind::Limit,
            at.clone(),
            format!(
                "{} is {w}×{h} pixels; the limit is {MAX_IMAGE_DIM} per side and \
                 {MAX_TERRAIN_SAMPLES} in all",
                path.display()
            ),
            "downsample the image",
        ));
    }
    Ok(())
}

fn read_png(
    bytes: &[u8],
    path: &Path,
    not_image: &dyn Fn(String) -> SceneError,
    at: &Location,
) -> Result<Raster, SceneError> {
    use image::{DynamicImage, ImageDecoder};
    let decoder = image::codecs::png::PngDecoder::new(Cursor::new(bytes))
        .map_err(|e| not_image(e.to_string()))?;
    let (w, h) = decoder.dimensions();
    check_dims(w, h, at, path)?;
    let color = decoder.color_type();
    let img = DynamicImage::from_decoder(decoder).map_err(|e| not_image(e.to_string()))?;
    let values: Vec<f32> = match img {
        DynamicImage::ImageLuma8(b) => b.into_raw().into_iter().map(|v| v as f32 / 255.0).collect(),
        DynamicImage::ImageLuma16(b) => b
            .into_raw()
            .into_iter()
            .map(|v| v as f32 / 65535.0)
            .collect(),
        DynamicImage::ImageLumaA8(b) => b
            .into_raw()
            .chunks_exact(2)
            .map(|p| p[0] as f32 / 255.0)
            .collect(),
        DynamicImage::ImageLumaA16(b) => b
            .into_raw()
            .chunks_exact(2)
            .map(|p| p[0] as f32 / 65535.0)
            .collect(),
        _ => return Err(not_image(format!("a {color:?} PNG, not grayscale"))),
    };
    Ok(Raster {
        width: w,
        height: h,
        values,
        metres: false,
    })
}

/// The first tag of the first TIFF directory that holds no values (count 0), if any. `tiff`
/// 0.10 indexes the first value of some tags unchecked (an empty SampleFormat panics), so such
/// files are refused before it sees them. `None` also when the directory cannot be walked: the
/// decoder then reports why.
fn empty_tiff_tag(b: &[u8]) -> Option<u16> {
    let le = match b.get(..2)? {
        b"II" => true,
        b"MM" => false,
        _ => return None,
    };
    let at = |o: usize, n: usize| -> Option<u64> {
        let s = b.get(o..o.checked_add(n)?)?;
        let mut v = 0u64;
        for i in 0..n {
            let byte = if le { s[n - 1 - i] } else { s[i] };
            v = v << 8 | u64::from(byte);
        }
        Some(v)
    };
    // Classic TIFF: 2-byte entry count, 12-byte entries with a 4-byte count; BigTIFF: 8 and 20
    // bytes with an 8-byte count.
    let (ifd, count_len, entry_len, value_count_len) = match at(2, 2)? {
        42 => (at(4, 4)?, 2, 12, 4),
        43 => (at(8, 8)?, 8, 20, 8),
        _ => return None,
    };
    let ifd = usize::try_from(ifd).ok()?;
    let n = at(ifd, count_len)?;
    for i in 0..n.min(4096) as usize {
        let e = ifd + count_len + i * entry_len;
        let tag = at(e, 2)? as u16;
        if at(e + 4, value_count_len)? == 0 {
            return Some(tag);
        }
    }
    None
}

fn read_tiff(
    bytes: &[u8],
    path: &Path,
    not_image: &dyn Fn(String) -> SceneError,
    at: &Location,
) -> Result<Raster, SceneError> {
    use tiff::decoder::{Decoder, DecodingResult};
    if let Some(tag) = empty_tiff_tag(bytes) {
        return Err(not_image(format!("TIFF tag {tag} has no values")));
    }
    let mut dec = Decoder::new(Cursor::new(bytes)).map_err(|e| not_image(e.to_string()))?;
    let (w, h) = dec.dimensions().map_err(|e| not_image(e.to_string()))?;
    check_dims(w, h, at, path)?;
    match dec.colortype().map_err(|e| not_image(e.to_string()))? {
        tiff::ColorType::Gray(_) => {}
        other => return Err(not_image(format!("a {other:?} TIFF, not a single band"))),
    }
    let nodata = dec
        .get_tag_ascii_string(tiff::tags::Tag::GdalNodata)
        .ok()
        .and_then(|s| s.trim_matches(char::from(0)).trim().parse::<f64>().ok());
    let image = dec.read_image().map_err(|e| not_image(e.to_string()))?;
    let norm = |v: Vec<f32>| (v, false);
    let (mut values, metres) = match image {
        DecodingResult::U8(v) => norm(v.into_iter().map(|x| x as f32 / 255.0).collect()),
        DecodingResult::U16(v) => norm(v.into_iter().map(|x| x as f32 / 65535.0).collect()),
        DecodingResult::I16(v) => (v.into_iter().map(|x| x as f32).collect(), true),
        DecodingResult::F32(v) => (v, true),
        DecodingResult::F64(v) => (v.into_iter().map(|x| x as f32).collect(), true),
        _ => return Err(not_image("unsupported sample type (use u16 or f32)".into())),
    };
    if values.len() != w as usize * h as usize {
        return Err(not_image("multi-sample pixels".into()));
    }
    if metres {
        // Missing data (NaN, ±inf, the GDAL nodata value) becomes the lowest valid height.
        let invalid = |v: f32| !v.is_finite() || nodata.is_some_and(|n| v as f64 == n);
        let lowest = values
            .iter()
            .copied()
            .filter(|&v| !invalid(v))
            .fold(f32::INFINITY, f32::min);
        if !lowest.is_finite() {
            return Err(not_image("no valid height samples".into()));
        }
        if let Some(i) = values
            .iter()
            .position(|&v| !invalid(v) && v.abs() > MAX_ELEVATION_M)
        {
            return Err(SceneError::new(
                ErrorKind::InvalidValue,
                Location::file(path),
                format!(
                    "sample at column {}, row {} is {} m, beyond ±{MAX_ELEVATION_M} m",
                    i % w as usize,
                    i / w as usize,
                    crate::error::num(values[i])
                ),
                "mark missing data with the GDAL nodata tag, or convert the samples to metres",
            ));
        }
        for v in &mut values {
            if invalid(*v) {
                *v = lowest;
            }
        }
    }
    Ok(Raster {
        width: w,
        height: h,
        values,
        metres,
    })
}

impl Raster {
    /// A terrain of extent `size` from this raster: normalised samples map to `height_m`
    /// ([min, max]); absolute (metre) samples are kept as they are without `height_m`, or
    /// stretched from their own range onto it. `Err` when normalised samples lack `height_m`.
    pub(crate) fn into_terrain(
        self,
        size: [f32; 2],
        height_m: Option<[f32; 2]>,
    ) -> Result<Terrain, ()> {
        let mut heights = self.values;
        match (self.metres, height_m) {
            (false, None) => return Err(()),
            (false, Some([lo, hi])) => heights.iter_mut().for_each(|v| *v = lo + *v * (hi - lo)),
            (true, None) => {}
            (true, Some([lo, hi])) => {
                let (a, b) = heights
                    .iter()
                    .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| {
                        (a.min(v), b.max(v))
                    });
                let s = if b > a { (hi - lo) / (b - a) } else { 0.0 };
                heights.iter_mut().for_each(|v| *v = lo + (*v - a) * s);
            }
        }
        // A single row or column is widened to the 2-sample minimum.
        let (w, h) = (self.width as usize, self.height as usize);
        let (w2, h2) = (w.max(2), h.max(2));
        if (w2, h2) != (w, h) {
            let mut grid = Vec::with_capacity(w2 * h2);
            for r in 0..h2 {
                for c in 0..w2 {
                    grid.push(heights[r.min(h - 1) * w + c.min(w - 1)]);
                }
            }
            heights = grid;
        }
        Ok(Terrain {
            size,
            resolution: [w2 as u32, h2 as u32],
            heights,
        })
    }
}
