//! MNP01 §6.1: a level's BTF (the tree's, or a main branch's) rendered from the level below
//! "with the runtime algorithm", so that the two levels shade alike.
//!
//! For each tree view sample, every placement of the level below is drawn as the runtime draws
//! it — a billboard facing the (orthographic) camera through the object's box centre, its 3 view
//! × 3 light samples looked up in the object's frame and weighted by
//! [`reconstruction_weights`], sun visibility from the placement's cube-maps (the rest of the
//! tree) interpolated trilinearly across its box, sky visibility likewise — and composited back
//! to front, premultiplied. One image per (view, light) pair, plus the sky- and ground-facing
//! ambient images, then box-filtered to the tile and mip-mapped like a geometry bake.
//!
//! This runs on the CPU (the runtime's WGSL, restated): the bake needs the sun-only and
//! ambient-only terms separately, which the runtime shader never outputs. The bake composes at
//! 2× supersampling at most: the images it draws from are already filtered.

use super::bake::{
    Mips, ObjectBtf, Placement, downsample, per_view_images, reconstruction_weights, view_frame,
};
use super::scene::trilinear;
use super::visibility;
use crate::bake::views::PlaneFrame;
use crate::directions::{DirectionError, DirectionLut, DirectionSet};
use glam::{Affine3A, Mat3A, Vec3};

/// sRGB byte → linear, for decoding the stored images.
fn srgb_table() -> [f32; 256] {
    std::array::from_fn(|i| {
        let s = i as f32 / 255.0;
        if s <= 0.04045 {
            s / 12.92
        } else {
            ((s + 0.055) / 1.055).powf(2.4)
        }
    })
}

/// One placement of the level below, ready to draw.
struct Placed<'a> {
    object: &'a ObjectBtf,
    frames: &'a [PlaneFrame],
    from_plant: Affine3A,
    /// Linear part of plant → object, for directions.
    dir_to_object: Mat3A,
    /// Box centre in the plant frame.
    centre: Vec3,
    corners: [Vec3; 8],
    min: Vec3,
    size: Vec3,
    /// Uniform scale object → plant.
    scale: f32,
    /// Opacity cube-maps of the rest of the tree at the 8 corners.
    cubes: [&'a [u8]; 8],
    /// Sky transmittance at the 8 corners.
    sky: [f32; 8],
}

/// A mip level of one stored image, decoded on the fly.
struct Image<'a> {
    bytes: &'a [u8],
    size: usize,
}

impl Image<'_> {
    /// Premultiplied linear RGBA, bilinear at `uv` (texel centres at (i + 0.5) / size).
    fn sample(&self, lin: &[f32; 256], uv: (f32, f32)) -> [f32; 4] {
        let n = self.size as f32;
        let x = (uv.0 * n - 0.5).clamp(0.0, n - 1.0);
        let y = (uv.1 * n - 0.5).clamp(0.0, n - 1.0);
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.size - 1), (y0 + 1).min(self.size - 1));
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let mut out = [0.0; 4];
        for (i, j, w) in [
            (x0, y0, (1.0 - fx) * (1.0 - fy)),
            (x1, y0, fx * (1.0 - fy)),
            (x0, y1, (1.0 - fx) * fy),
            (x1, y1, fx * fy),
        ] {
            let t = &self.bytes[(j * self.size + i) * 4..][..4];
            out[0] += w * lin[t[0] as usize];
            out[1] += w * lin[t[1] as usize];
            out[2] += w * lin[t[2] as usize];
            out[3] += w * t[3] as f32 / 255.0;
        }
        out
    }
}

fn level(mips: &Mips, level: usize, tile: usize) -> Image<'_> {
    let l = level.min(mips.len() - 1);
    Image {
        bytes: &mips[l],
        size: (tile >> l).max(1),
    }
}

/// Premultiplied "over": `src` in front of `dst`.
fn over(dst: &mut [f32; 4], src: [f32; 4]) {
    let k = 1.0 - src[3].clamp(0.0, 1.0);
    for c in 0..4 {
        dst[c] = src[c] + dst[c] * k;
    }
}

/// What [`tree_level`] needs of the bake.
pub(super) struct LevelBelow<'a> {
    pub objects: &'a [ObjectBtf],
    pub placements: &'a [Placement],
    /// [`super::HbtBaked::cubes`] and their side.
    pub cubes: &'a [u8],
    pub cube_resolution: u32,
    pub branch_views: &'a DirectionSet,
    pub branch_lights: &'a DirectionSet,
}

/// An object's `direct[view · lights + light]` and `ambient` (sky-facing images, then
/// ground-facing) for its box `min..max` (the tree, or a main branch in its own frame),
/// rendered from the level below (placed in that frame) at `tile · ss` texels
/// per side and filtered down to `tile`. Fails only if the level below's direction tables
/// cannot be built.
#[allow(clippy::too_many_arguments)]
pub(super) fn from_level_below(
    below: &LevelBelow<'_>,
    views: &DirectionSet,
    lights: &DirectionSet,
    (min, max): (Vec3, Vec3),
    tile: u32,
    ss: u32,
    min_weight: f32,
) -> Result<(Vec<Mips>, Vec<Mips>), DirectionError> {
    let lin = srgb_table();
    let bviews = DirectionLut::new(below.branch_views, DirectionLut::DEFAULT_RESOLUTION)?;
    let blights = DirectionLut::new(below.branch_lights, DirectionLut::DEFAULT_RESOLUTION)?;
    let frames: Vec<Vec<PlaneFrame>> = below
        .objects
        .iter()
        .map(|o| {
            let (omin, omax) = (Vec3::from(o.bbox_min), Vec3::from(o.bbox_max));
            below
                .branch_views
                .directions()
                .iter()
                .map(|&d| view_frame(d, omin, omax, tile))
                .collect()
        })
        .collect();
    let res = below.cube_resolution as usize;
    let dirs = visibility::directions(res);
    let cube_len = visibility::FACES * res * res;
    let placed: Vec<Placed> = below
        .placements
        .iter()
        .enumerate()
        .map(|(index, pl)| {
            let object = &below.objects[pl.object as usize];
            let (omin, omax) = (Vec3::from(object.bbox_min), Vec3::from(object.bbox_max));
            let to_plant = pl.affine();
            let cubes: [&[u8]; 8] = std::array::from_fn(|k| {
                let start = (index * visibility::CORNERS + k) * cube_len;
                &below.cubes[start..start + cube_len]
            });
            Placed {
                object,
                frames: &frames[pl.object as usize],
                from_plant: to_plant.inverse(),
                dir_to_object: to_plant.matrix3.inverse(),
                centre: to_plant.transform_point3((omin + omax) * 0.5),
                corners: std::array::from_fn(|k| {
                    to_plant.transform_point3(visibility::corner(omin, omax, k))
                }),
                min: omin,
                size: (omax - omin).max(Vec3::splat(1e-6)),
                scale: to_plant.matrix3.x_axis.length(),
                cubes,
                sky: cubes.map(|c| visibility::sky_transmittance(c, &dirs)),
            }
        })
        .collect();
    let view_dirs = views.directions();
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(view_dirs.len());
    let per = view_dirs.len().div_ceil(threads);
    let ctx = Ctx {
        placed: &placed,
        lights,
        bviews: &bviews,
        blights: &blights,
        lin: &lin,
        nl_below: below.branch_lights.len(),
        nv_below: below.branch_views.len(),
        tile: tile as usize,
        ss: ss as usize,
        min_weight,
        res,
        bbox: (min, max),
    };
    let lit: Vec<(Vec<Mips>, Mips, Mips)> = std::thread::scope(|scope| {
        let handles: Vec<_> = view_dirs
            .chunks(per)
            .map(|chunk| {
                let ctx = &ctx;
                scope.spawn(move || chunk.iter().map(|&d| ctx.view(d)).collect::<Vec<_>>())
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("composing thread panicked"))
            .collect()
    });
    Ok(per_view_images(lit, lights.len()))
}

struct Ctx<'a> {
    placed: &'a [Placed<'a>],
    lights: &'a DirectionSet,
    bviews: &'a DirectionLut,
    blights: &'a DirectionLut,
    lin: &'a [f32; 256],
    nl_below: usize,
    nv_below: usize,
    tile: usize,
    ss: usize,
    min_weight: f32,
    res: usize,
    bbox: (Vec3, Vec3),
}

impl Ctx<'_> {
    /// One tree view sample: its direct images (light order) and its two ambient images.
    fn view(&self, dir: Vec3) -> (Vec<Mips>, Mips, Mips) {
        let frame = view_frame(dir, self.bbox.0, self.bbox.1, self.tile as u32);
        let n = self.tile * self.ss;
        let lights = self.lights.directions();
        let mut direct = vec![vec![[0.0f32; 4]; n * n]; lights.len()];
        let mut sky = vec![[0.0f32; 4]; n * n];
        let mut ground = vec![[0.0f32; 4]; n * n];
        // Back to front: the camera looks from +f.
        let mut order: Vec<&Placed> = self.placed.iter().collect();
        order.sort_by(|a, b| frame.f.dot(a.centre).total_cmp(&frame.f.dot(b.centre)));
        let pixel = 2.0 * frame.half.x.max(frame.half.y) / n as f32;
        let uv_of = |p: Vec3| {
            let q = p - frame.centre;
            (
                q.dot(frame.u) / frame.half.x * 0.5 + 0.5,
                0.5 - q.dot(frame.v) / frame.half.y * 0.5,
            )
        };
        for pl in order {
            let o = pl.object;
            let (vk, vw) = self
                .bviews
                .lookup((pl.dir_to_object * dir).normalize_or(Vec3::Y));
            // Per light: its 9 pair weights, its 3 samples and the 8 corners' sun transmittance.
            let per_light: Vec<([f32; 9], [u32; 3], [f32; 8])> = lights
                .iter()
                .map(|&l| {
                    let (lk, lw) = self
                        .blights
                        .lookup((pl.dir_to_object * l).normalize_or(Vec3::Y));
                    let sun =
                        std::array::from_fn(|k| 1.0 - visibility::lookup(pl.cubes[k], self.res, l));
                    (reconstruction_weights(vw, lw, self.min_weight), lk, sun)
                })
                .collect();
            let ambient_w = reconstruction_weights(vw, [1.0, 0.0, 0.0], self.min_weight);
            // The pixels the box covers.
            let (mut lo, mut hi) = ((f32::MAX, f32::MAX), (f32::MIN, f32::MIN));
            for &c in &pl.corners {
                let (s, t) = uv_of(c);
                lo = (lo.0.min(s), lo.1.min(t));
                hi = (hi.0.max(s), hi.1.max(t));
            }
            let px = |x: f32| ((x * n as f32).floor().max(0.0) as usize).min(n);
            let (x0, x1) = (px(lo.0), (px(hi.0) + 1).min(n));
            let (y0, y1) = (px(lo.1), (px(hi.1) + 1).min(n));
            // The mip whose texel matches a pixel of this image (as the runtime's `lod`).
            let fr0 = &pl.frames[vk[0] as usize];
            let texel = 2.0 * fr0.half.x.max(fr0.half.y) * pl.scale / self.tile as f32;
            let mip = (pixel / texel.max(1e-9)).log2().round().max(0.0) as usize;
            let images = |view: u32, light: Option<u32>| match light {
                Some(l) => level(
                    &o.direct[view as usize * self.nl_below + l as usize],
                    mip,
                    self.tile,
                ),
                None => level(&o.ambient[view as usize], mip, self.tile),
            };
            for y in y0..y1 {
                for x in x0..x1 {
                    let p = frame.point((x as f32 + 0.5) / n as f32, (y as f32 + 0.5) / n as f32);
                    // The billboard faces the camera through the box centre.
                    let on_quad = p + frame.f * frame.f.dot(pl.centre - p);
                    let m = pl.from_plant.transform_point3(on_quad);
                    let q = ((m - pl.min) / pl.size).clamp(Vec3::ZERO, Vec3::ONE);
                    let mut uvs = [None; 3];
                    let mut cover = [0.0f32; 3];
                    for s in 0..3 {
                        let fr = &pl.frames[vk[s] as usize];
                        let d = m - fr.centre;
                        let uv = (
                            d.dot(fr.u) / fr.half.x * 0.5 + 0.5,
                            0.5 - d.dot(fr.v) / fr.half.y * 0.5,
                        );
                        if (0.0..=1.0).contains(&uv.0) && (0.0..=1.0).contains(&uv.1) {
                            uvs[s] = Some(uv);
                            cover[s] = images(vk[s], None).sample(self.lin, uv)[3];
                        }
                    }
                    if cover.iter().all(|&c| c < 0.002) {
                        continue;
                    }
                    let i = y * n + x;
                    // Ambient: view weights only.
                    let sky_vis = trilinear(pl.sky, q);
                    let (mut s_src, mut g_src) = ([0.0f32; 4], [0.0f32; 4]);
                    for s in 0..3 {
                        let (Some(uv), a) = (uvs[s], ambient_w[3 * s]) else {
                            continue;
                        };
                        if a <= 0.0 || cover[s] < 0.002 {
                            continue;
                        }
                        let up = images(vk[s], None).sample(self.lin, uv);
                        let down =
                            level(&o.ambient[self.nv_below + vk[s] as usize], mip, self.tile)
                                .sample(self.lin, uv);
                        for c in 0..3 {
                            s_src[c] += a * up[c] * sky_vis;
                            g_src[c] += a * down[c];
                        }
                        s_src[3] += a * up[3];
                        g_src[3] += a * up[3];
                    }
                    over(&mut sky[i], s_src);
                    over(&mut ground[i], g_src);
                    for (li, (w, lk, sun)) in per_light.iter().enumerate() {
                        let vis = trilinear(*sun, q);
                        let mut src = [0.0f32; 4];
                        for s in 0..3 {
                            let Some(uv) = uvs[s] else { continue };
                            if cover[s] < 0.002 {
                                continue;
                            }
                            for j in 0..3 {
                                let wk = w[3 * s + j];
                                if wk <= 0.0 {
                                    continue;
                                }
                                let t = images(vk[s], Some(lk[j])).sample(self.lin, uv);
                                for c in 0..3 {
                                    src[c] += wk * t[c] * vis;
                                }
                                src[3] += wk * t[3];
                            }
                        }
                        over(&mut direct[li][i], src);
                    }
                }
            }
        }
        (
            direct
                .iter()
                .map(|hi| downsample(hi, self.tile, self.ss))
                .collect(),
            downsample(&sky, self.tile, self.ss),
            downsample(&ground, self.tile, self.ss),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mip chain of `tile` with pseudo-random premultiplied texels (alpha ≥ 0.1).
    fn random_mips(tile: usize, seed: &mut u32) -> Mips {
        let mut next = || {
            *seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (*seed >> 24) as u8
        };
        let mut mips = Vec::new();
        let mut n = tile;
        loop {
            let mut level = Vec::with_capacity(n * n * 4);
            for k in 0..n * n {
                let a = next().max(26);
                let texel = [next().min(a), next().min(a), next().min(a), a];
                // The frame's free border (one texel at level 0) stays empty, as in a bake.
                let (x, y) = (k % n, k / n);
                let border = n == tile && (x == 0 || y == 0 || x == n - 1 || y == n - 1);
                level.extend(if border { [0; 4] } else { texel });
            }
            mips.push(level);
            if n == 1 {
                break;
            }
            n /= 2;
        }
        mips
    }

    /// One object placed as the whole plant, nothing occluding it: the composed tree level is
    /// the object's own BTF, view for view and light for light.
    #[test]
    fn one_object_placed_whole_composes_to_its_own_images() {
        let views = DirectionSet::new(0).unwrap();
        let lights = DirectionSet::new(0).unwrap();
        let tile = 8usize;
        let mut seed = 7;
        let (min, max) = (Vec3::new(-1.0, 0.0, -1.5), Vec3::new(1.0, 4.0, 1.5));
        let object = ObjectBtf {
            object: 0,
            uses: 1,
            bbox_min: min.to_array(),
            bbox_max: max.to_array(),
            direct: (0..views.len() * lights.len())
                .map(|_| random_mips(tile, &mut seed))
                .collect(),
            ambient: Vec::new(),
        };
        // Sky- and ground-facing images share their coverage, as in a bake.
        let mut object = object;
        let sky: Vec<Mips> = (0..views.len())
            .map(|_| random_mips(tile, &mut seed))
            .collect();
        object.ambient = sky.iter().chain(&sky).cloned().collect();
        let placement = Placement {
            object: 0,
            transform: Affine3A::IDENTITY.to_cols_array(),
        };
        let res = 2;
        let cubes = vec![0u8; visibility::CORNERS * visibility::FACES * res * res];
        let objects = [object];
        let below = LevelBelow {
            objects: &objects,
            placements: std::slice::from_ref(&placement),
            cubes: &cubes,
            cube_resolution: res as u32,
            branch_views: &views,
            branch_lights: &lights,
        };
        let (direct, ambient) =
            from_level_below(&below, &views, &lights, (min, max), tile as u32, 1, 0.05).unwrap();
        assert_eq!(direct.len(), objects[0].direct.len());
        assert_eq!(ambient.len(), objects[0].ambient.len());
        let worst = |a: &[Mips], b: &[Mips]| {
            a.iter()
                .zip(b)
                .flat_map(|(x, y)| x[0].iter().zip(&y[0]))
                .map(|(&p, &q)| (p as i32 - q as i32).abs())
                .max()
                .unwrap()
        };
        assert!(worst(&direct, &objects[0].direct) <= 1);
        assert!(worst(&ambient, &objects[0].ambient) <= 1);
    }
}
