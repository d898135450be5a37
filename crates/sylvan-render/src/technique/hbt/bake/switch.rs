//! The mesh switch measured per plant (#15 "level choices that hold on any plant"): at bake
//! time, how far the plant's billboard and its meshes each are from the reference at a set of
//! projected sizes — in ꟻLIP, the fidelity metric of the whole project — and so where the
//! meshes start to be closer. The reference is the plant rasterised with 4×4 samples per
//! pixel; the meshes as drawn are one sample per pixel; the billboard is the `tile`-texel
//! image (4×4 samples per texel) resampled to the size (a magnified texel interpolated, a
//! minified one averaged). Each is the plant's premultiplied albedo over a dark ground
//! ([`GROUND`]): silhouettes, holes and the blur of a magnified billboard all count; shading
//! is the BTF's own and is not part of this comparison.

use crate::RenderError;
use crate::bake::image::srgb8;
use crate::bake::{BakeRequest, PlantBaker};
use glam::Vec3;
use sylvan_gpu::Gpu;
use sylvan_plant::Plant;

/// Projected sizes measured (pixels across the view frame).
pub const SIZES: [u32; 9] = [16, 24, 32, 48, 64, 96, 128, 192, 256];

/// View directions measured (from the plant towards the eye): the side, three-quarters up,
/// and steeply from above.
pub const VIEWS: [[f32; 3]; 4] = [
    [1.0, 0.05, 0.0],
    [0.0, 0.05, 1.0],
    [-0.7, 0.5, 0.5],
    [0.3, 0.9, -0.3],
];

/// Linear albedo of what the plant is composited over (a dark ground).
pub const GROUND: f32 = 0.2;

/// ꟻLIP against the reference per measured size, mean over the views.
#[derive(Debug, Clone, PartialEq)]
pub struct SwitchCurve {
    /// The sizes (pixels across the frame).
    pub sizes: Vec<u32>,
    /// The billboard's mean ꟻLIP per size.
    pub billboard: Vec<f32>,
    /// The one-sample meshes' mean ꟻLIP per size.
    pub meshes: Vec<f32>,
    /// Texels across the billboard's frame.
    pub tile: u32,
}

impl SwitchCurve {
    /// The pixels per billboard texel at which the meshes become closer to the reference than
    /// the billboard (linear between the measured sizes where the curves cross); the largest
    /// size measured when they never do.
    pub fn crossing_texel_pixels(&self) -> f32 {
        let d: Vec<f32> = self
            .billboard
            .iter()
            .zip(&self.meshes)
            .map(|(b, m)| b - m)
            .collect();
        let at = |i: usize| self.sizes[i] as f32 / self.tile as f32;
        if d[0] > 0.0 {
            return at(0);
        }
        for i in 1..d.len() {
            if d[i] > 0.0 {
                let t = -d[i - 1] / (d[i] - d[i - 1]);
                return at(i - 1) + t * (at(i) - at(i - 1));
            }
        }
        at(d.len() - 1)
    }
}

/// Measures `plant`'s curve for a billboard of `tile` texels framed as `frame(dir)` frames it.
pub fn measure(
    gpu: &Gpu,
    plant: &Plant,
    tile: u32,
    frame: impl Fn(Vec3) -> crate::bake::views::PlaneFrame,
) -> Result<SwitchCurve, RenderError> {
    let requests: Vec<BakeRequest> = VIEWS
        .iter()
        .map(|&d| BakeRequest::whole(plant, frame(Vec3::from(d).normalize())))
        .collect();
    let billboards = PlantBaker::new(gpu, plant, tile, 4)?.bake(gpu, &requests, |_| {})?;
    let flip = |a: &image::RgbImage, b: &image::RgbImage| {
        sylvan_eval::flip(a, b)
            .map(|f| f.mean)
            .map_err(|e| RenderError::Option(format!("measuring the mesh switch: {e}")))
    };
    let (mut bb, mut mesh) = (Vec::new(), Vec::new());
    for &size in &SIZES {
        let reference = PlantBaker::new(gpu, plant, size, 4)?.bake(gpu, &requests, |_| {})?;
        let one = PlantBaker::new(gpu, plant, size, 1)?.bake(gpu, &requests, |_| {})?;
        let (mut eb, mut em) = (0.0, 0.0);
        for ((r, o), b) in reference.iter().zip(&one).zip(&billboards) {
            let r = over_ground(&r.color, size);
            let b = over_ground(&resample(&b.color, tile, size), size);
            eb += flip(&r, &b)?;
            em += flip(&r, &over_ground(&o.color, size))?;
        }
        bb.push(eb / VIEWS.len() as f32);
        mesh.push(em / VIEWS.len() as f32);
    }
    Ok(SwitchCurve {
        sizes: SIZES.to_vec(),
        billboard: bb,
        meshes: mesh,
        tile,
    })
}

/// Premultiplied linear RGBA (`n`², row 0 at the top) over [`GROUND`], sRGB-encoded.
fn over_ground(px: &[[f32; 4]], n: u32) -> image::RgbImage {
    let bytes = px
        .iter()
        .flat_map(|c| [0, 1, 2].map(|k| srgb8(c[k] + GROUND * (1.0 - c[3]))))
        .collect();
    image::RgbImage::from_raw(n, n, bytes).expect("n² pixels")
}

/// `src` (`n`², premultiplied) drawn at `m`² as a textured quad is: 4×4 bilinear taps per
/// output pixel (a magnified texel is interpolated, a minified one averaged, as the mip chain
/// would).
fn resample(src: &[[f32; 4]], n: u32, m: u32) -> Vec<[f32; 4]> {
    let (n, m) = (n as usize, m as usize);
    let at = |x: isize, y: isize| {
        let x = x.clamp(0, n as isize - 1) as usize;
        let y = y.clamp(0, n as isize - 1) as usize;
        glam::Vec4::from(src[y * n + x])
    };
    let bilinear = |u: f32, v: f32| {
        let (x, y) = (u * n as f32 - 0.5, v * n as f32 - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as isize, y0 as isize);
        let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx;
        let bottom = at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    };
    let taps = 4;
    (0..m * m)
        .map(|i| {
            let (px, py) = ((i % m) as f32, (i / m) as f32);
            let mut sum = glam::Vec4::ZERO;
            for k in 0..taps * taps {
                let u = (px + ((k % taps) as f32 + 0.5) / taps as f32) / m as f32;
                let v = (py + ((k / taps) as f32 + 0.5) / taps as f32) / m as f32;
                sum += bilinear(u, v);
            }
            (sum / (taps * taps) as f32).to_array()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resampling_keeps_a_constant_and_a_step_average() {
        let flat = vec![[0.5; 4]; 16];
        for m in [2, 4, 8, 16] {
            assert!(
                resample(&flat, 4, m)
                    .iter()
                    .all(|x| x.iter().all(|&c| (c - 0.5).abs() < 1e-6))
            );
        }
        let step: Vec<[f32; 4]> = (0..64)
            .map(|i| [if i % 8 < 4 { 1.0 } else { 0.0 }; 4])
            .collect();
        let mean = |v: &[[f32; 4]]| v.iter().map(|c| c[3]).sum::<f32>() / v.len() as f32;
        for m in [4, 8, 16, 32] {
            assert!((mean(&resample(&step, 8, m)) - 0.5).abs() < 0.02, "{m}");
        }
    }

    #[test]
    fn the_ground_shows_where_nothing_covers() {
        let red = over_ground(&[[1.0, 0.0, 0.0, 1.0]], 1);
        assert_eq!(red.as_raw(), &[255, 0, 0]);
        // 0.2 linear is sRGB 124.
        let empty = over_ground(&[[0.0; 4]; 4], 2);
        assert!(empty.as_raw().iter().all(|&c| c == 124));
    }

    #[test]
    fn the_crossing_interpolates_between_sizes() {
        let c = SwitchCurve {
            sizes: vec![32, 64, 128],
            billboard: vec![0.1, 0.2, 0.4],
            meshes: vec![0.3, 0.3, 0.2],
            tile: 32,
        };
        // Differences −0.2, −0.1, +0.2: between 2 and 4 px per texel, a third of the way.
        assert!((c.crossing_texel_pixels() - (2.0 + 2.0 / 3.0)).abs() < 1e-5);
        let never = SwitchCurve {
            meshes: vec![0.5; 3],
            ..c.clone()
        };
        assert_eq!(never.crossing_texel_pixels(), 4.0);
    }
}
