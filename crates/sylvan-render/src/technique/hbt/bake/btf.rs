//! MNP01 §3.1/§6.1: the BTF bake of one object — per view sample a supersampled G-buffer, per
//! light sample a depth map, each view lit under every light with self-shadowing (PCF in the
//! light's depth map) and under the sky (two ambient images), box-filtered to the tile and
//! mip-mapped — plus the view frame shared by bake and draw and §4.1's reconstruction weights.

use super::Mips;
use crate::RenderError;
use crate::bake::image::TileImage;
use crate::bake::views::PlaneFrame;
use crate::bake::{BakeRequest, PlantBaker};
use crate::directions::DirectionSet;
use crate::technique::geometry::LEAF_TRANSLUCENCY;
use crate::technique::hbt::HbtBakeParams;
use glam::Vec3;
use sylvan_gpu::Gpu;
use sylvan_plant::Plant;

/// Colour of light transmitted through a leaf, relative to its albedo (as the geometry).
const TRANSMISSION_TINT: Vec3 = Vec3::new(1.1, 1.25, 0.55);
/// Self-shadow PCF kernel: (2·R + 1)² taps of the light's depth map.
const PCF_RADIUS: i32 = 2;
/// Self-shadow depth bias, in light-map texels.
const BIAS_TEXELS: f32 = 1.5;

/// The orthographic frame of view sample `dir` (unit, from the tree towards the eye): the
/// plant's box framed tightly along `dir`, widened so the outermost texel ring of a
/// `tile`-texel image stays empty (no bleeding between atlas neighbours). Shared by the bake
/// and the draw, so a texel is drawn where it was seen.
pub fn view_frame(dir: Vec3, min: Vec3, max: Vec3, tile: u32) -> PlaneFrame {
    let mut f = PlaneFrame::for_box(dir, min, max);
    let widen = tile as f32 / (tile as f32 - 2.0).max(1.0);
    f.half.x *= widen;
    f.half.y *= widen;
    f
}

pub use crate::directions::pair_weights as reconstruction_weights;

/// The reference's crown self-occlusion for the sky term (`crown_occlusion` in `frame.wgsl`).
fn crown_occlusion(p: Vec3, min: Vec3, max: Vec3) -> f32 {
    let centre = (min + max) * 0.5;
    let half = ((max - min) * 0.5).max(Vec3::splat(1e-3));
    let q = (p - centre) / half;
    let radial = (q.x * q.x + q.z * q.z).sqrt().clamp(0.0, 1.0);
    let height = ((p.y - min.y) / (2.0 * half.y)).clamp(0.0, 1.0);
    (0.35 + 0.45 * radial + 0.3 * height).clamp(0.0, 1.0)
}

/// One light sample's depth map of the tree (depth 0 nearest the light; `INFINITY` where
/// nothing was hit).
struct LightMap {
    frame: PlaneFrame,
    n: usize,
    depth: Vec<f32>,
    bias: f32,
}

impl LightMap {
    fn new(frame: PlaneFrame, image: &TileImage) -> Self {
        let n = image.size as usize;
        let depth = image
            .color
            .iter()
            .zip(&image.normal_depth)
            .map(|(c, nd)| if c[3] > 0.5 { nd[3] } else { f32::INFINITY })
            .collect();
        let texel = 2.0 * frame.half.x.max(frame.half.y) / n as f32;
        Self {
            frame,
            n,
            depth,
            bias: BIAS_TEXELS * texel / (2.0 * frame.half.z),
        }
    }

    /// Fraction of the light reaching `p` (model space), PCF over the depth map.
    fn visibility(&self, p: Vec3) -> f32 {
        let f = &self.frame;
        let q = p - f.centre;
        let n = self.n as f32;
        let s = (q.dot(f.u) / f.half.x * 0.5 + 0.5) * n;
        let t = (0.5 - q.dot(f.v) / f.half.y * 0.5) * n;
        let z = (f.half.z - q.dot(f.f)) / (2.0 * f.half.z) - self.bias;
        let (x0, y0) = (s.floor() as i32, t.floor() as i32);
        let mut lit = 0;
        let mut taps = 0;
        for dy in -PCF_RADIUS..=PCF_RADIUS {
            for dx in -PCF_RADIUS..=PCF_RADIUS {
                let (x, y) = (x0 + dx, y0 + dy);
                taps += 1;
                if x < 0 || y < 0 || x >= self.n as i32 || y >= self.n as i32 {
                    lit += 1;
                    continue;
                }
                if self.depth[y as usize * self.n + x as usize] >= z {
                    lit += 1;
                }
            }
        }
        lit as f32 / taps as f32
    }
}

/// A covered G-buffer sample of one view, ready to light.
struct Sample {
    /// Index in the supersampled image.
    index: usize,
    position: Vec3,
    normal: Vec3,
    albedo: Vec3,
}

/// The covered samples of a supersampled view G-buffer with their model-space positions.
fn samples(image: &TileImage, frame: &PlaneFrame) -> Vec<Sample> {
    let n = image.size as usize;
    let mut out = Vec::new();
    for (i, (c, nd)) in image.color.iter().zip(&image.normal_depth).enumerate() {
        if c[3] <= 0.5 {
            continue;
        }
        let (x, y) = (i % n, i / n);
        let s = (x as f32 + 0.5) / n as f32;
        let t = (y as f32 + 0.5) / n as f32;
        let position = frame.point(s, t) + frame.f * (frame.half.z * (1.0 - 2.0 * nd[3]));
        out.push(Sample {
            index: i,
            position,
            normal: Vec3::new(nd[0], nd[1], nd[2]).normalize_or(Vec3::Y),
            albedo: Vec3::new(c[0], c[1], c[2]) / c[3],
        });
    }
    out
}

/// Box-filters a supersampled premultiplied image (`n·ss` per side) to `n` and builds the
/// quantised mip chain.
pub(in crate::technique::hbt) fn downsample(hi: &[[f32; 4]], n: usize, ss: usize) -> Mips {
    let big = n * ss;
    let inv = 1.0 / (ss * ss) as f32;
    let mut color = vec![[0.0f32; 4]; n * n];
    for (y, row) in color.chunks_mut(n).enumerate() {
        for (x, out) in row.iter_mut().enumerate() {
            for sy in 0..ss {
                for sx in 0..ss {
                    let v = hi[(y * ss + sy) * big + x * ss + sx];
                    for k in 0..4 {
                        out[k] += v[k] * inv;
                    }
                }
            }
        }
    }
    let image = TileImage {
        size: n as u32,
        color,
        normal_depth: vec![[0.0, 0.0, 1.0, 0.5]; n * n],
    };
    image.levels().into_iter().map(|l| l.color).collect()
}

/// Lights one view under every light sample and the sky: its direct images (light order) and
/// its sky- and ground-facing ambient images.
fn light_view(
    image: &TileImage,
    frame: &PlaneFrame,
    lights: &[(Vec3, LightMap)],
    bbox: (Vec3, Vec3),
    tile: usize,
    ss: usize,
) -> (Vec<Mips>, Mips, Mips) {
    let samples = samples(image, frame);
    let hi_len = image.color.len();
    let mut hi = vec![[0.0f32; 4]; hi_len];
    let mut direct = Vec::with_capacity(lights.len());
    for (l, map) in lights {
        hi.fill([0.0; 4]);
        for s in &samples {
            let ndl = s.normal.dot(*l);
            let mut c = Vec3::ZERO;
            if ndl != 0.0 {
                let vis = map.visibility(s.position);
                let front = s.albedo * ndl.max(0.0);
                let back = s.albedo * TRANSMISSION_TINT * LEAF_TRANSLUCENCY * (-ndl).max(0.0);
                c = (front + back) * vis;
            }
            hi[s.index] = [c.x, c.y, c.z, 1.0];
        }
        direct.push(downsample(&hi, tile, ss));
    }
    let mut ambient = [Mips::new(), Mips::new()];
    for (part, out) in ambient.iter_mut().enumerate() {
        hi.fill([0.0; 4]);
        for s in &samples {
            let up = s.normal.y * 0.5 + 0.5;
            let facing = if part == 0 { up } else { 1.0 - up };
            let c = s.albedo * crown_occlusion(s.position, bbox.0, bbox.1) * facing;
            hi[s.index] = [c.x, c.y, c.z, 1.0];
        }
        *out = downsample(&hi, tile, ss);
    }
    let [sky, ground] = ambient;
    (direct, sky, ground)
}

/// The direct and ambient images of one object (a plant, or a base object wrapped as one):
/// `direct[view · lights + light]`, then `ambient` (sky-facing parts, then ground-facing).
/// `progress(done)` counts `2·views + lights` units.
pub(super) fn bake_btf(
    gpu: &Gpu,
    plant: &Plant,
    p: &HbtBakeParams,
    views: &DirectionSet,
    lights: &DirectionSet,
    progress: &mut dyn FnMut(usize),
) -> Result<(Vec<Mips>, Vec<Mips>), RenderError> {
    let (min, max) = (Vec3::from(plant.bbox_min), Vec3::from(plant.bbox_max));
    let whole = |frame: PlaneFrame| BakeRequest::whole(plant, frame);
    let (nv, nl) = (views.len(), lights.len());
    let view_frames: Vec<PlaneFrame> = views
        .directions()
        .iter()
        .map(|&d| view_frame(d, min, max, p.tile))
        .collect();
    let hi = p.tile * p.supersample;
    let gbuffers = PlantBaker::new(gpu, plant, hi, 1)?.bake(
        gpu,
        &view_frames.iter().map(|&f| whole(f)).collect::<Vec<_>>(),
        &mut *progress,
    )?;
    let light_frames: Vec<PlaneFrame> = lights
        .directions()
        .iter()
        .map(|&d| PlaneFrame::for_box(d, min, max))
        .collect();
    let depth_maps = PlantBaker::new(gpu, plant, p.shadow_resolution, 1)?.bake(
        gpu,
        &light_frames.iter().map(|&f| whole(f)).collect::<Vec<_>>(),
        |d| progress(nv + d),
    )?;
    let light_maps: Vec<(Vec3, LightMap)> = lights
        .directions()
        .iter()
        .zip(light_frames.into_iter().zip(&depth_maps))
        .map(|(&d, (f, img))| (d, LightMap::new(f, img)))
        .collect();
    // Light the views on every core (pure CPU work, independent per view).
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(nv);
    let per = nv.div_ceil(threads);
    let (tile, ss) = (p.tile as usize, p.supersample as usize);
    let lit: Vec<(Vec<Mips>, Mips, Mips)> = std::thread::scope(|scope| {
        let handles: Vec<_> = gbuffers
            .chunks(per)
            .zip(view_frames.chunks(per))
            .map(|(imgs, frames)| {
                let maps = &light_maps;
                scope.spawn(move || {
                    imgs.iter()
                        .zip(frames)
                        .map(|(img, f)| light_view(img, f, maps, (min, max), tile, ss))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("lighting thread panicked"))
            .collect()
    });
    progress(2 * nv + nl);
    Ok(per_view_images(lit, nl))
}

/// Per view sample (direct images in light order, sky-facing, ground-facing ambient image) →
/// the BTF's `direct[view · lights + light]` and `ambient` (sky-facing images, then
/// ground-facing).
pub(in crate::technique::hbt) fn per_view_images(
    lit: Vec<(Vec<Mips>, Mips, Mips)>,
    lights: usize,
) -> (Vec<Mips>, Vec<Mips>) {
    let nv = lit.len();
    let mut direct = Vec::with_capacity(nv * lights);
    let mut sky = Vec::with_capacity(2 * nv);
    let mut ground = Vec::with_capacity(nv);
    for (d, s, g) in lit {
        direct.extend(d);
        sky.push(s);
        ground.push(g);
    }
    sky.extend(ground);
    (direct, sky)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_one_and_drop_small_products() {
        let w = reconstruction_weights([0.6, 0.3, 0.1], [0.7, 0.2, 0.1], 0.05);
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        // 0.1 × 0.1, 0.3 × 0.1, … are dropped; 0.6 × 0.7 is kept and grows.
        assert_eq!(w[8], 0.0);
        assert_eq!(w[5], 0.0);
        assert!(w[0] > 0.42);
        // Every product dropped: the largest alone.
        let w = reconstruction_weights([0.34, 0.33, 0.33], [0.34, 0.33, 0.33], 0.2);
        assert_eq!(w[0], 1.0);
        // On a sample: that pair alone.
        let w = reconstruction_weights([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], 0.05);
        assert_eq!(w[1], 1.0);
    }

    #[test]
    fn view_frame_keeps_a_free_border() {
        let (min, max) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 6.0, 1.0));
        let f = view_frame(Vec3::X, min, max, 32);
        // The box spans 30 of the 32 texels.
        assert!((f.half.y * 30.0 / 32.0 - 3.0).abs() < 1e-4, "{:?}", f.half);
    }
}
