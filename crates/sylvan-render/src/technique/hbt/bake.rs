//! MNP01 §3.1/§6.1: baking the tree's BTF — a lit, self-shadowed billboard per (view sample,
//! light sample) and two ambient billboards per view sample — and §4.1's reconstruction
//! weights.

use super::HbtParams;
use crate::RenderError;
use crate::bake::codec::{DecodeError, Decoder, Encoder, Fnv64};
use crate::bake::image::TileImage;
use crate::bake::views::PlaneFrame;
use crate::bake::{BakeRequest, PlantBaker};
use crate::directions::DirectionSet;
use crate::technique::geometry::LEAF_TRANSLUCENCY;
use glam::{Mat4, Vec3};
use sylvan_gpu::Gpu;
use sylvan_plant::{Instancing, Mesh, Plant};

/// Bumped whenever the payload below or the lighting baked into it changes.
pub const FORMAT_VERSION: u32 = 2;

/// Colour of light transmitted through a leaf, relative to its albedo (as the geometry).
const TRANSMISSION_TINT: Vec3 = Vec3::new(1.1, 1.25, 0.55);
/// Self-shadow PCF kernel: (2·R + 1)² taps of the light's depth map.
const PCF_RADIUS: i32 = 2;
/// Self-shadow depth bias, in light-map texels.
const BIAS_TEXELS: f32 = 1.5;

/// One image as uploaded: its mip chain, each level `size² × 4` bytes of sRGB premultiplied
/// RGBA8 (level 0 is `tile²`).
pub type Mips = Vec<Vec<u8>>;

/// The BTF of one base object of the plant's instancing (MNP01 §3.2: a level below the tree).
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectBtf {
    /// Index into `plant.instancing.objects`.
    pub object: u32,
    /// Times the plant's root places it.
    pub uses: u32,
    /// The object's bounding box in its own frame.
    pub bbox_min: [f32; 3],
    /// Bounding box maximum.
    pub bbox_max: [f32; 3],
    /// As [`HbtBaked::direct`].
    pub direct: Vec<Mips>,
    /// As [`HbtBaked::ambient`] (sky occlusion estimated inside the object only).
    pub ambient: Vec<Mips>,
}

/// The baked BTFs of one plant: the top level of MNP01's hierarchy (the whole tree) and,
/// when baked with two levels, its main branches.
#[derive(Debug, Clone, PartialEq)]
pub struct HbtBaked {
    /// Billboard size in texels.
    pub tile: u32,
    /// View-direction set level.
    pub view_level: u32,
    /// Light-direction set level.
    pub light_level: u32,
    /// The plant's bounding box (model space), which every view frames.
    pub bbox_min: [f32; 3],
    /// Bounding box maximum.
    pub bbox_max: [f32; 3],
    /// `direct[view · lights + light]`: colour under a unit sun from that light sample, with
    /// self-shadowing; premultiplied, coverage in alpha.
    pub direct: Vec<Mips>,
    /// `ambient[view]` (sky-facing part) then `ambient[views + view]` (ground-facing part) of
    /// the hemispherical sky term, with sky occlusion, for unit sky and ground colours.
    pub ambient: Vec<Mips>,
    /// The level below (main branches; empty with one level). Baked, not drawn yet.
    pub objects: Vec<ObjectBtf>,
}

impl HbtBaked {
    /// View samples.
    pub fn views(&self) -> usize {
        crate::directions::SAMPLE_COUNTS[self.view_level as usize]
    }

    /// Light samples.
    pub fn lights(&self) -> usize {
        crate::directions::SAMPLE_COUNTS[self.light_level as usize]
    }

    /// Bytes of image data (all mips).
    pub fn image_bytes(&self) -> u64 {
        let objects = self
            .objects
            .iter()
            .flat_map(|o| o.direct.iter().chain(&o.ambient));
        self.direct
            .iter()
            .chain(&self.ambient)
            .chain(objects)
            .flatten()
            .map(|l| l.len() as u64)
            .sum()
    }

    /// The payload written to the cache.
    pub fn encode(&self) -> Vec<u8> {
        let mut e = Encoder::default();
        e.u32(self.tile);
        e.u32(self.view_level);
        e.u32(self.light_level);
        e.f32s(&self.bbox_min);
        e.f32s(&self.bbox_max);
        encode_images(&mut e, &self.direct, &self.ambient);
        e.u64(self.objects.len() as u64);
        for o in &self.objects {
            e.u32s(&[o.object, o.uses]);
            e.f32s(&o.bbox_min);
            e.f32s(&o.bbox_max);
            encode_images(&mut e, &o.direct, &o.ambient);
        }
        e.buf
    }

    /// Reads a payload back, checking every count and size against the header.
    pub fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        let bad = |m: String| DecodeError(m);
        let mut d = Decoder::new(bytes);
        let tile = d.u32()?;
        let view_level = d.u32()?;
        let light_level = d.u32()?;
        if !tile.is_power_of_two() || !(1..=crate::bake::MAX_TILE).contains(&tile) {
            return Err(bad(format!("tile {tile} is not a power of two up to 1024")));
        }
        let max = crate::directions::MAX_LEVEL;
        if view_level > max || light_level > max {
            return Err(bad(format!(
                "direction levels {view_level}/{light_level} (0–{max} allowed)"
            )));
        }
        let arr3 = |v: Vec<f32>| -> Result<[f32; 3], DecodeError> {
            v.try_into()
                .map_err(|_| DecodeError("bounding box corner is not 3 floats".into()))
        };
        let bbox_min = arr3(d.f32s()?)?;
        let bbox_max = arr3(d.f32s()?)?;
        let counts = crate::directions::SAMPLE_COUNTS;
        let (views, lights) = (counts[view_level as usize], counts[light_level as usize]);
        let (direct, ambient) = decode_images(&mut d, tile, views, lights)?;
        let nobjects = d.u64()?;
        // Each object takes at least its header and images; a huge count fails here.
        if nobjects > d.remaining() as u64 / 64 {
            return Err(bad(format!(
                "{nobjects} objects in {} bytes",
                d.remaining()
            )));
        }
        let mut objects = Vec::with_capacity(nobjects as usize);
        for _ in 0..nobjects {
            let ids = d.u32s()?;
            let [object, uses] = ids[..] else {
                return Err(bad("object header is not 2 integers".into()));
            };
            let bbox_min = arr3(d.f32s()?)?;
            let bbox_max = arr3(d.f32s()?)?;
            let (direct, ambient) = decode_images(&mut d, tile, views, lights)?;
            objects.push(ObjectBtf {
                object,
                uses,
                bbox_min,
                bbox_max,
                direct,
                ambient,
            });
        }
        d.finish()?;
        Ok(Self {
            tile,
            view_level,
            light_level,
            bbox_min,
            bbox_max,
            direct,
            ambient,
            objects,
        })
    }
}

/// Writes one object's direct and ambient image sets.
fn encode_images(e: &mut Encoder, direct: &[Mips], ambient: &[Mips]) {
    for set in [direct, ambient] {
        e.u64(set.len() as u64);
        for mips in set {
            e.u64(mips.len() as u64);
            for level in mips {
                e.bytes(level);
            }
        }
    }
}

/// Reads one object's direct and ambient image sets, checking counts and sizes.
fn decode_images(
    d: &mut Decoder<'_>,
    tile: u32,
    views: usize,
    lights: usize,
) -> Result<(Vec<Mips>, Vec<Mips>), DecodeError> {
    let bad = |m: String| DecodeError(m);
    let mut sets = Vec::with_capacity(2);
    for (what, want) in [("direct", views * lights), ("ambient", 2 * views)] {
        let n = d.u64()?;
        if n != want as u64 {
            return Err(bad(format!("{n} {what} images, expected {want}")));
        }
        let mut set = Vec::with_capacity(want);
        for i in 0..want {
            let nlev = d.u64()?;
            if nlev != tile.ilog2() as u64 + 1 {
                return Err(bad(format!("{what} image {i}: {nlev} mip levels")));
            }
            let mut mips = Vec::with_capacity(nlev as usize);
            for m in 0..nlev as u32 {
                let level = d.bytes()?;
                let size = (tile >> m).max(1) as usize;
                if level.len() != size * size * 4 {
                    return Err(bad(format!("{what} image {i}: mip {m} has the wrong size")));
                }
                mips.push(level.to_vec());
            }
            set.push(mips);
        }
        sets.push(set);
    }
    let ambient = sets.pop().unwrap_or_default();
    let direct = sets.pop().unwrap_or_default();
    Ok((direct, ambient))
}

/// The content hash of everything a bake depends on (not the draw-only parameters).
pub fn input_hash(plant: &Plant, p: &HbtParams) -> u64 {
    let mut h = Fnv64::default();
    h.field(b"hbt")
        .u32s(&[FORMAT_VERSION, crate::bake::cache::CONTAINER_VERSION])
        .u32s(&[
            p.view_level,
            p.light_level,
            p.tile,
            p.supersample,
            p.shadow_resolution,
            p.levels,
        ])
        .f32s(&[LEAF_TRANSLUCENCY]);
    for mesh in [&plant.wood, &plant.leaves] {
        h.f32s(bytemuck::cast_slice(&mesh.positions))
            .f32s(bytemuck::cast_slice(&mesh.normals))
            .f32s(bytemuck::cast_slice(&mesh.uvs))
            .f32s(bytemuck::cast_slice(&mesh.colors))
            .u32s(&mesh.indices);
    }
    let t = &plant.leaf_texture;
    h.u32s(&[t.width, t.height]).field(&t.rgba);
    h.f32s(&plant.bbox_min).f32s(&plant.bbox_max);
    h.finish()
}

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

/// MNP01 §4.1: the 9 pair weights `view_w[i] · light_w[j]` (row-major, view major) with those
/// below `min_weight` dropped and the rest renormalised to sum to 1. When every product is
/// below the threshold, the largest alone is kept.
pub fn reconstruction_weights(view_w: [f32; 3], light_w: [f32; 3], min_weight: f32) -> [f32; 9] {
    let mut w = [0.0f32; 9];
    let mut best = 0;
    for (k, out) in w.iter_mut().enumerate() {
        *out = view_w[k / 3].max(0.0) * light_w[k % 3].max(0.0);
    }
    for k in 1..9 {
        if w[k] > w[best] {
            best = k;
        }
    }
    let mut sum = 0.0;
    for x in &mut w {
        if *x < min_weight {
            *x = 0.0;
        }
        sum += *x;
    }
    if sum <= 0.0 {
        w = [0.0; 9];
        w[best] = 1.0;
        return w;
    }
    w.map(|x| x / sum)
}

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
fn downsample(hi: &[[f32; 4]], n: usize, ss: usize) -> Mips {
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
fn bake_btf(
    gpu: &Gpu,
    plant: &Plant,
    p: &HbtParams,
    views: &DirectionSet,
    lights: &DirectionSet,
    progress: &mut dyn FnMut(usize),
) -> Result<(Vec<Mips>, Vec<Mips>), RenderError> {
    let (min, max) = (Vec3::from(plant.bbox_min), Vec3::from(plant.bbox_max));
    let whole = |frame: PlaneFrame| BakeRequest {
        frame,
        side: 1.0,
        leaves: std::iter::once(0..plant.leaves.indices.len() as u32).collect(),
        wood: std::iter::once(0..plant.wood.indices.len() as u32).collect(),
    };
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
    let mut direct = Vec::with_capacity(nv * nl);
    let mut sky = Vec::with_capacity(2 * nv);
    let mut ground = Vec::with_capacity(nv);
    for (d, s, g) in lit {
        direct.extend(d);
        sky.push(s);
        ground.push(g);
    }
    sky.extend(ground);
    Ok((direct, sky))
}

/// The base objects one level below the plant (MNP01 §3.2, §7: the main branches): distinct
/// objects the root instances directly, leaves excluded, in order of first use, with how many
/// times the root places each.
pub fn main_branches(plant: &Plant) -> Vec<(u32, u32)> {
    let inst = &plant.instancing;
    let Some(root) = inst.objects.get(inst.root as usize) else {
        return Vec::new();
    };
    let mut out: Vec<(u32, u32)> = Vec::new();
    for i in &root.instances {
        let level = inst.objects.get(i.object as usize).map_or(0, |o| o.level);
        if level == 0 || i.object == inst.root {
            continue;
        }
        match out.iter_mut().find(|(o, _)| *o == i.object) {
            Some(e) => e.1 += 1,
            None => out.push((i.object, 1)),
        }
    }
    out
}

/// Base object `object` of `plant` expanded into a plant of its own (its frame, the plant's
/// leaf texture), ready for the baker.
pub fn object_plant(plant: &Plant, object: u32) -> Plant {
    fn expand(inst: &Instancing, o: u32, m: &Mat4, wood: &mut Mesh, leaves: &mut Mesh, depth: u32) {
        let Some(obj) = inst.objects.get(o as usize) else {
            return;
        };
        if depth > 256 {
            return;
        }
        wood.append_transformed(&obj.wood, m);
        leaves.append_transformed(&obj.leaves, m);
        for i in &obj.instances {
            expand(inst, i.object, &(*m * i.transform), wood, leaves, depth + 1);
        }
    }
    let (mut wood, mut leaves) = (Mesh::default(), Mesh::default());
    expand(
        &plant.instancing,
        object,
        &Mat4::IDENTITY,
        &mut wood,
        &mut leaves,
        0,
    );
    let (mut min, mut max) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in wood.positions.iter().chain(&leaves.positions) {
        min = min.min(Vec3::from(*p));
        max = max.max(Vec3::from(*p));
    }
    if min.x > max.x {
        (min, max) = (Vec3::ZERO, Vec3::ZERO);
    }
    Plant {
        name: format!("{} object {object}", plant.name),
        leaf_count: leaves.indices.len() / 6,
        wood,
        leaves,
        leaf_texture: plant.leaf_texture.clone(),
        bbox_min: min.to_array(),
        bbox_max: max.to_array(),
        hierarchy: Default::default(),
        instancing: Default::default(),
        internodes: 0,
    }
}

/// Bakes `plant`'s BTF (the top level) and, with `p.levels == 2`, the BTF of each main branch
/// base object ([`main_branches`]). `progress(done, total)` counts rasterised views, light
/// maps and lit views.
pub fn bake(
    gpu: &Gpu,
    plant: &Plant,
    p: &HbtParams,
    mut progress: impl FnMut(usize, usize),
) -> Result<HbtBaked, RenderError> {
    p.validate()?;
    let option = |e: crate::directions::DirectionError| RenderError::Option(e.to_string());
    let views = DirectionSet::new(p.view_level).map_err(option)?;
    let lights = DirectionSet::new(p.light_level).map_err(option)?;
    let branches = if p.levels >= 2 {
        main_branches(plant)
    } else {
        Vec::new()
    };
    let per_object = 2 * views.len() + lights.len();
    let total = per_object * (1 + branches.len());
    let (direct, ambient) = bake_btf(gpu, plant, p, &views, &lights, &mut |d| progress(d, total))?;
    let mut objects = Vec::with_capacity(branches.len());
    for (k, &(object, uses)) in branches.iter().enumerate() {
        let sub = object_plant(plant, object);
        let done = per_object * (1 + k);
        let (direct, ambient) = bake_btf(gpu, &sub, p, &views, &lights, &mut |d| {
            progress(done + d, total)
        })?;
        objects.push(ObjectBtf {
            object,
            uses,
            bbox_min: sub.bbox_min,
            bbox_max: sub.bbox_max,
            direct,
            ambient,
        });
    }
    Ok(HbtBaked {
        tile: p.tile,
        view_level: p.view_level,
        light_level: p.light_level,
        bbox_min: plant.bbox_min,
        bbox_max: plant.bbox_max,
        direct,
        ambient,
        objects,
    })
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

    #[test]
    fn payload_round_trips_and_rejects_truncation() {
        let mips = |t: u32| -> Mips {
            (0..=t.ilog2())
                .map(|m| vec![m as u8; ((t >> m) * (t >> m) * 4) as usize])
                .collect()
        };
        let b = HbtBaked {
            tile: 8,
            view_level: 0,
            light_level: 0,
            bbox_min: [0.0; 3],
            bbox_max: [1.0; 3],
            direct: vec![mips(8); 36],
            ambient: vec![mips(8); 12],
            objects: vec![ObjectBtf {
                object: 3,
                uses: 2,
                bbox_min: [0.0; 3],
                bbox_max: [1.0; 3],
                direct: vec![mips(8); 36],
                ambient: vec![mips(8); 12],
            }],
        };
        let bytes = b.encode();
        assert_eq!(HbtBaked::decode(&bytes).unwrap(), b);
        assert!(HbtBaked::decode(&bytes[..bytes.len() - 1]).is_err());
        let mut wrong = b.clone();
        wrong.direct.pop();
        assert!(HbtBaked::decode(&wrong.encode()).is_err());
        let mut wrong = b.clone();
        wrong.objects[0].ambient.pop();
        assert!(HbtBaked::decode(&wrong.encode()).is_err());
    }
}
