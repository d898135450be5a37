//! MNP01 §3.1/§6.1: baking the tree's BTF — a lit, self-shadowed billboard per (view sample,
//! light sample) and two ambient billboards per view sample — and §4.1's reconstruction
//! weights.

use super::HbtBakeParams;
use super::visibility;
use crate::RenderError;
use crate::bake::codec::{DecodeError, Decoder, Encoder};
use crate::bake::image::TileImage;
use crate::bake::views::PlaneFrame;
use crate::bake::{BakeRequest, PlantBaker};
use crate::directions::{DirectionLut, DirectionSet};
use crate::technique::geometry::LEAF_TRANSLUCENCY;
use glam::{Affine3A, Mat4, Vec3};
use sylvan_gpu::Gpu;
use sylvan_plant::{Instancing, Mesh, Plant};

/// Bumped whenever the payload below or the lighting baked into it changes.
pub const FORMAT_VERSION: u32 = 4;
/// Largest visibility cube-map face side accepted.
pub const MAX_CUBE_RESOLUTION: u32 = 64;

/// Colour of light transmitted through a leaf, relative to its albedo (as the geometry).
const TRANSMISSION_TINT: Vec3 = Vec3::new(1.1, 1.25, 0.55);
/// Self-shadow PCF kernel: (2·R + 1)² taps of the light's depth map.
const PCF_RADIUS: i32 = 2;
/// Self-shadow depth bias, in light-map texels.
const BIAS_TEXELS: f32 = 1.5;

/// One image as uploaded: its mip chain, each level `size² × 4` bytes of sRGB premultiplied
/// RGBA8 (level 0 is `tile²`).
pub type Mips = Vec<Vec<u8>>;

/// Marks [`ObjectBtf::object`] for the plant's *rest*: the root's own wood and the leaves it
/// places directly (everything the main branches leave out).
pub const REST_OBJECT: u32 = u32::MAX;

/// The BTF of one object of the level below the tree (MNP01 §3.2, §7: a main branch, or the
/// rest of the plant).
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectBtf {
    /// Index into `plant.instancing.objects`, or [`REST_OBJECT`].
    pub object: u32,
    /// Placements that draw it.
    pub uses: u32,
    /// The object's bounding box in its own frame.
    pub bbox_min: [f32; 3],
    /// Bounding box maximum.
    pub bbox_max: [f32; 3],
    /// As [`HbtBaked::direct`], over the branch direction sets.
    pub direct: Vec<Mips>,
    /// As [`HbtBaked::ambient`] (sky occlusion estimated inside the object only; the rest of
    /// the tree's is in the visibility cube-maps).
    pub ambient: Vec<Mips>,
}

/// Where the level below places one of its objects in the plant.
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    /// Index into [`HbtBaked::objects`].
    pub object: u32,
    /// Object frame → plant frame, column-major 3×4 (a similarity).
    pub transform: [f32; 12],
}

impl Placement {
    /// The transform as an affine map.
    pub fn affine(&self) -> Affine3A {
        let t = &self.transform;
        Affine3A::from_cols_array(t)
    }
}

/// MNP01 §7's third BTF level: the small branches of the main branches.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SmallLevel {
    /// Representative small branches, then each opening main branch's rest (marked
    /// [`REST_OBJECT`]), over the branch direction sets.
    pub objects: Vec<ObjectBtf>,
    /// Per object of [`HbtBaked::objects`]: the range of `placements` it opens into (empty: it
    /// does not open). Empty when the level was not baked.
    pub ranges: Vec<[u32; 2]>,
    /// Object frame → its main branch's frame.
    pub placements: Vec<Placement>,
    /// Per placement, per corner, a cube-map of the rest of its main branch (as
    /// [`HbtBaked::cubes`]).
    pub cubes: Vec<u8>,
}

impl SmallLevel {
    /// The placements main-branch object `object` opens into (none when it does not open).
    pub fn range(&self, object: usize) -> std::ops::Range<usize> {
        self.ranges
            .get(object)
            .map_or(0..0, |r| r[0] as usize..r[1] as usize)
    }
}

/// The baked BTFs of one plant: the top level of MNP01's hierarchy (the whole tree) and,
/// when baked with two levels, the level below — a few representative main branches and the
/// rest of the plant, their placements, and each placement's visibility cube-maps.
#[derive(Debug, Clone, PartialEq)]
pub struct HbtBaked {
    /// Billboard size in texels (both levels).
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
    /// View-direction set level of the objects below.
    pub branch_view_level: u32,
    /// Light-direction set level of the objects below.
    pub branch_light_level: u32,
    /// The level below (empty with one level).
    pub objects: Vec<ObjectBtf>,
    /// Their placements in the plant.
    pub placements: Vec<Placement>,
    /// Side of each visibility cube-map face.
    pub cube_resolution: u32,
    /// Per placement, per bounding-box corner ([`super::visibility::corner`]), a cube-map
    /// (`6 · cube_resolution²` opacities, 255 = opaque) of the rest of the tree seen from it
    /// (MNP01 §3.3 at the branch level).
    pub cubes: Vec<u8>,
    /// The small-branch level below the main branches (empty unless baked with
    /// [`super::HbtBakeParams::small_branches`]).
    pub small: SmallLevel,
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

    /// Bytes of one visibility cube-map.
    pub fn cube_bytes(&self) -> usize {
        visibility::FACES * (self.cube_resolution * self.cube_resolution) as usize
    }

    /// The cube-map of `placement` at bounding-box corner `corner`.
    pub fn cube(&self, placement: usize, corner: usize) -> &[u8] {
        cube_of(&self.cubes, self.cube_resolution, placement, corner)
    }

    /// Side of one tree-level texel, in plant units (the image frames the box's largest side).
    pub fn tree_texel(&self) -> f32 {
        (Vec3::from(self.bbox_max) - Vec3::from(self.bbox_min)).max_element() / self.tile as f32
    }

    /// Side of one texel of the largest placed main branch of the level below, in plant units:
    /// the meshes open when it would be magnified (`levels` = 3). The rest object spans the
    /// trunk, as tall as the tree, and does not count unless it is all there is; without a
    /// level below, the tree's texel.
    pub fn mesh_texel(&self) -> f32 {
        let only_rest = self.objects.len() == 1;
        (0..self.placements.len())
            .filter_map(|i| self.placement_texel(i, only_rest))
            .reduce(f32::max)
            .unwrap_or_else(|| self.tree_texel())
    }

    /// Side of one texel of the lowest BTF level of placement `index`, in plant units: its
    /// own, or where it opens into small branches their largest (its rest, as long as it, does
    /// not count). `None` for the rest object unless `with_rest`.
    pub fn placement_texel(&self, index: usize, with_rest: bool) -> Option<f32> {
        let texel = |o: &ObjectBtf, pl: &Placement| {
            (Vec3::from(o.bbox_max) - Vec3::from(o.bbox_min)).max_element()
                * pl.affine().matrix3.x_axis.length()
                / self.tile as f32
        };
        let pl = self.placements.get(index)?;
        let o = self.objects.get(pl.object as usize)?;
        if o.object == REST_OBJECT && !with_rest {
            return None;
        }
        let small = self.small.range(pl.object as usize);
        if small.is_empty() {
            return Some(texel(o, pl));
        }
        let scale = pl.affine().matrix3.x_axis.length();
        self.small.placements[small]
            .iter()
            .filter_map(|sp| {
                let so = &self.small.objects[sp.object as usize];
                (so.object != REST_OBJECT).then(|| texel(so, sp) * scale)
            })
            .reduce(f32::max)
    }

    /// Bytes of image data (all mips), tree level then the levels below.
    pub fn image_bytes(&self) -> (u64, u64) {
        let sum = |sets: &mut dyn Iterator<Item = &Mips>| -> u64 {
            sets.flatten().map(|l| l.len() as u64).sum()
        };
        let objects = sum(&mut self
            .objects
            .iter()
            .chain(&self.small.objects)
            .flat_map(|o| o.direct.iter().chain(&o.ambient)));
        (sum(&mut self.direct.iter().chain(&self.ambient)), objects)
    }

    /// The payload written to the cache.
    pub fn encode(&self) -> Vec<u8> {
        let mut e = Encoder::default();
        e.u32s(&[
            self.tile,
            self.view_level,
            self.light_level,
            self.branch_view_level,
            self.branch_light_level,
            self.cube_resolution,
        ]);
        e.f32s(&self.bbox_min);
        e.f32s(&self.bbox_max);
        encode_images(&mut e, &self.direct, &self.ambient);
        encode_level(&mut e, &self.objects, &self.placements, &self.cubes);
        let s = &self.small;
        encode_level(&mut e, &s.objects, &s.placements, &s.cubes);
        e.u32s(s.ranges.as_flattened());
        e.buf
    }

    /// Reads a payload back, checking every count and size against the header.
    pub fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        let bad = |m: String| DecodeError(m);
        let mut d = Decoder::new(bytes);
        let head = d.u32s()?;
        let [
            tile,
            view_level,
            light_level,
            branch_view_level,
            branch_light_level,
            cube_resolution,
        ] = head[..]
        else {
            return Err(bad("header is not 6 integers".into()));
        };
        if !tile.is_power_of_two() || !(1..=crate::bake::MAX_TILE).contains(&tile) {
            return Err(bad(format!("tile {tile} is not a power of two up to 1024")));
        }
        let max = crate::directions::MAX_LEVEL;
        for (a, b) in [
            (view_level, light_level),
            (branch_view_level, branch_light_level),
        ] {
            if a > max || b > max {
                return Err(bad(format!("direction levels {a}/{b} (0–{max} allowed)")));
            }
        }
        if !(1..=MAX_CUBE_RESOLUTION).contains(&cube_resolution) {
            return Err(bad(format!("cube-map resolution {cube_resolution}")));
        }
        let bbox_min = arr3(d.f32s()?)?;
        let bbox_max = arr3(d.f32s()?)?;
        let counts = crate::directions::SAMPLE_COUNTS;
        let (views, lights) = (counts[view_level as usize], counts[light_level as usize]);
        let (direct, ambient) = decode_images(&mut d, tile, views, lights)?;
        let (bviews, blights) = (
            counts[branch_view_level as usize],
            counts[branch_light_level as usize],
        );
        let (objects, placements, cubes) =
            decode_level(&mut d, tile, bviews, blights, cube_resolution)?;
        let (sobjects, splacements, scubes) =
            decode_level(&mut d, tile, bviews, blights, cube_resolution)?;
        let flat = d.u32s()?;
        if !(flat.is_empty() || flat.len() == 2 * objects.len()) {
            return Err(bad(format!(
                "{} small-level range bounds for {} objects",
                flat.len(),
                objects.len()
            )));
        }
        let ranges: Vec<[u32; 2]> = flat.chunks_exact(2).map(|r| [r[0], r[1]]).collect();
        if let Some(r) = ranges
            .iter()
            .find(|r| r[0] > r[1] || r[1] as usize > splacements.len())
        {
            return Err(bad(format!(
                "small-level range {}..{} of {} placements",
                r[0],
                r[1],
                splacements.len()
            )));
        }
        let small = SmallLevel {
            objects: sobjects,
            ranges,
            placements: splacements,
            cubes: scubes,
        };
        d.finish()?;
        Ok(Self {
            tile,
            view_level,
            light_level,
            bbox_min,
            bbox_max,
            direct,
            ambient,
            branch_view_level,
            branch_light_level,
            objects,
            placements,
            cube_resolution,
            cubes,
            small,
        })
    }
}

/// Writes one level below the tree: its objects, placements and cube-maps.
fn encode_level(e: &mut Encoder, objects: &[ObjectBtf], placements: &[Placement], cubes: &[u8]) {
    e.u64(objects.len() as u64);
    for o in objects {
        e.u32s(&[o.object, o.uses]);
        e.f32s(&o.bbox_min);
        e.f32s(&o.bbox_max);
        encode_images(e, &o.direct, &o.ambient);
    }
    e.u64(placements.len() as u64);
    for p in placements {
        e.u32(p.object);
        e.f32s(&p.transform);
    }
    e.bytes(cubes);
}

/// A bounding-box corner as stored.
fn arr3(v: Vec<f32>) -> Result<[f32; 3], DecodeError> {
    v.try_into()
        .map_err(|_| DecodeError("bounding box corner is not 3 floats".into()))
}

/// A level below the tree as stored: objects, placements, cube-maps.
type LevelPayload = (Vec<ObjectBtf>, Vec<Placement>, Vec<u8>);

/// One level as [`encode_level`] wrote it, every count and size checked.
fn decode_level(
    d: &mut Decoder<'_>,
    tile: u32,
    views: usize,
    lights: usize,
    cube_resolution: u32,
) -> Result<LevelPayload, DecodeError> {
    let bad = |m: String| DecodeError(m);
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
        let (direct, ambient) = decode_images(d, tile, views, lights)?;
        objects.push(ObjectBtf {
            object,
            uses,
            bbox_min,
            bbox_max,
            direct,
            ambient,
        });
    }
    let nplacements = d.u64()?;
    if nplacements > d.remaining() as u64 / 56 {
        return Err(bad(format!(
            "{nplacements} placements in {} bytes",
            d.remaining()
        )));
    }
    let mut placements = Vec::with_capacity(nplacements as usize);
    for i in 0..nplacements {
        let object = d.u32()?;
        let transform: [f32; 12] = d
            .f32s()?
            .try_into()
            .map_err(|_| bad(format!("placement {i}: transform is not 12 floats")))?;
        if object as u64 >= nobjects || transform.iter().any(|x| !x.is_finite()) {
            return Err(bad(format!("placement {i}: bad object or transform")));
        }
        placements.push(Placement { object, transform });
    }
    let cubes = d.bytes()?.to_vec();
    let per =
        visibility::CORNERS * visibility::FACES * (cube_resolution * cube_resolution) as usize;
    if cubes.len() != placements.len() * per {
        return Err(bad(format!(
            "{} cube-map bytes for {} placements",
            cubes.len(),
            placements.len()
        )));
    }
    Ok((objects, placements, cubes))
}

/// The cube-map of `placement` at `corner` in a placement-major run of cube-maps of side `res`
/// ([`HbtBaked::cubes`]).
pub fn cube_of(cubes: &[u8], res: u32, placement: usize, corner: usize) -> &[u8] {
    let n = visibility::FACES * (res * res) as usize;
    let at = (placement * visibility::CORNERS + corner) * n;
    &cubes[at..at + n]
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
pub(super) fn downsample(hi: &[[f32; 4]], n: usize, ss: usize) -> Mips {
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
    p: &HbtBakeParams,
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
    Ok(per_view_images(lit, nl))
}

/// Per view sample (direct images in light order, sky-facing, ground-facing ambient image) →
/// the BTF's `direct[view · lights + light]` and `ambient` (sky-facing images, then
/// ground-facing).
pub(super) fn per_view_images(
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
    split_object(plant, object, &|_| false, "").1
}

/// Expands base object `object` of `plant` into a plant of its own, except the non-leaf
/// instances `stop` selects (anywhere below it): those are returned as (object, transform into
/// `object`'s frame) and left out. `label` names the remainder (empty: `object N`).
fn split_object(
    plant: &Plant,
    object: u32,
    stop: &dyn Fn(u32) -> bool,
    label: &str,
) -> (Vec<(u32, Mat4)>, Plant) {
    struct Walk<'a> {
        inst: &'a Instancing,
        stop: &'a dyn Fn(u32) -> bool,
        wood: Mesh,
        leaves: Mesh,
        stopped: Vec<(u32, Mat4)>,
    }
    fn expand(w: &mut Walk<'_>, o: u32, m: &Mat4, depth: u32) {
        let Some(obj) = w.inst.objects.get(o as usize) else {
            return;
        };
        if depth > 256 {
            return;
        }
        w.wood.append_transformed(&obj.wood, m);
        w.leaves.append_transformed(&obj.leaves, m);
        for i in &obj.instances {
            let leaf = w
                .inst
                .objects
                .get(i.object as usize)
                .is_some_and(|c| c.level == 0);
            let t = *m * i.transform;
            if !leaf && (w.stop)(i.object) {
                w.stopped.push((i.object, t));
            } else {
                expand(w, i.object, &t, depth + 1);
            }
        }
    }
    let mut w = Walk {
        inst: &plant.instancing,
        stop,
        wood: Mesh::default(),
        leaves: Mesh::default(),
        stopped: Vec::new(),
    };
    expand(&mut w, object, &Mat4::IDENTITY, 0);
    let (mut min, mut max) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in w.wood.positions.iter().chain(&w.leaves.positions) {
        min = min.min(Vec3::from(*p));
        max = max.max(Vec3::from(*p));
    }
    if min.x > max.x {
        (min, max) = (Vec3::ZERO, Vec3::ZERO);
    }
    let what = if label.is_empty() {
        format!("object {object}")
    } else {
        label.to_string()
    };
    let out = Plant {
        name: format!("{} {what}", plant.name),
        leaf_count: w.leaves.indices.len() / 6,
        wood: w.wood,
        leaves: w.leaves,
        leaf_texture: plant.leaf_texture.clone(),
        bbox_min: min.to_array(),
        bbox_max: max.to_array(),
        hierarchy: Default::default(),
        instancing: Default::default(),
        internodes: 0,
    };
    (w.stopped, out)
}

/// Mean vertex position of a plant's wood and leaves (its frame's origin when empty).
fn centroid(p: &Plant) -> Vec3 {
    let all = p.wood.positions.iter().chain(&p.leaves.positions);
    let n = p.wood.positions.len() + p.leaves.positions.len();
    all.map(|&v| Vec3::from(v)).sum::<Vec3>() / n.max(1) as f32
}

/// Bounding-box diagonal of a plant (or expanded object).
fn diagonal(p: &Plant) -> f32 {
    (Vec3::from(p.bbox_max) - Vec3::from(p.bbox_min)).length()
}

/// How one object is drawn by its representative: (object, representative index, map from the
/// representative's frame to the object's).
type Fit = (u32, usize, Mat4);

/// What an object of the level above is split into: the objects cut off below it (with
/// transforms into its frame), its rest, and how many times it is placed.
struct Parent {
    children: Vec<(u32, Mat4)>,
    rest: Plant,
    uses: u32,
}

/// Representatives of many distinct objects (MNP01 builds each level from a few instanced
/// base objects; an L-system tree has as many distinct ones as its parameters vary): the
/// `distinct` (object, placements, object as a plant) are sorted by size and cut into at most
/// `max_objects` groups of equal placement count; each group is drawn with its most used
/// member (largest on ties), scaled by the ratio of bounding-box diagonals about the object's
/// base and turned about it so that its centroid points where the member's does (objects of one
/// group often differ only by the turn at their bracket: a bough left or right of its branch, a
/// main branch pitched more or less). Returns the representatives (object, plant) and, per
/// object id of `distinct`, its representative's index and the map from the representative's
/// frame to the member's.
fn representatives(
    mut distinct: Vec<(u32, u32, Plant)>,
    max_objects: usize,
) -> (Vec<(u32, Plant)>, Vec<Fit>) {
    distinct.sort_by(|a, b| diagonal(&a.2).total_cmp(&diagonal(&b.2)));
    let total: u32 = distinct.iter().map(|d| d.1).sum();
    let groups = max_objects.max(1).min(distinct.len().max(1));
    // group[i]: the group of distinct[i] (equal shares of the placements, in size order).
    let mut group = Vec::with_capacity(distinct.len());
    let mut seen = 0u32;
    for d in &distinct {
        let g = ((seen as u64 * groups as u64) / total.max(1) as u64) as usize;
        group.push(g.min(groups - 1));
        seen += d.1;
    }
    let mut reps: Vec<(u32, Plant)> = Vec::new();
    let mut rep_of_group = vec![usize::MAX; groups];
    for (g, rep) in rep_of_group.iter_mut().enumerate() {
        let best = (0..distinct.len())
            .filter(|&i| group[i] == g)
            .max_by_key(|&i| (distinct[i].1, i));
        if let Some(i) = best {
            *rep = reps.len();
            reps.push((distinct[i].0, distinct[i].2.clone()));
        }
    }
    let centroids: Vec<Vec3> = reps.iter().map(|r| centroid(&r.1)).collect();
    let of = distinct
        .iter()
        .zip(&group)
        .filter_map(|(d, &g)| {
            let r = rep_of_group[g];
            (r != usize::MAX).then(|| {
                let scale = diagonal(&d.2) / diagonal(&reps[r].1).max(1e-6);
                let (from, to) = (centroids[r], centroid(&d.2));
                let turn = if from.length() > 1e-4 && to.length() > 1e-4 {
                    glam::Quat::from_rotation_arc(from.normalize(), to.normalize())
                } else {
                    glam::Quat::IDENTITY
                };
                (
                    d.0,
                    r,
                    Mat4::from_scale_rotation_translation(Vec3::splat(scale), turn, Vec3::ZERO),
                )
            })
        })
        .collect();
    (reps, of)
}

/// The level below the tree as drawn: at most `max_objects` representative main branches plus
/// the plant's rest, and where each is placed.
pub struct BranchLevel {
    /// (instancing object or [`REST_OBJECT`], the object as a plant, placements using it).
    pub objects: Vec<(u32, Plant, u32)>,
    /// (index into `objects`, object frame → parent frame).
    pub placements: Vec<(u32, Mat4)>,
    /// Per object of the level above (the small-branch level only; empty for the main
    /// branches): the range of `placements` it opens into (empty when it does not open).
    pub ranges: Vec<[u32; 2]>,
}

/// Chooses the level below the tree (MNP01 §3.2, §7): the distinct objects the root instances
/// directly (leaves excluded) — the main branches — as at most `max_objects` representatives
/// ([`representatives`]), and the root's own wood with the leaves it places directly, one
/// more object, the *rest*, placed at the identity.
pub fn branch_level(plant: &Plant, max_objects: usize) -> BranchLevel {
    // Every branch instance of the root is cut off (deeper ones belong to them); the rest is
    // kept even alone (an imported mesh has nothing else).
    let (children, rest) = split_root(plant);
    let mut level = from_children(
        plant,
        &[Parent {
            children,
            rest,
            uses: 1,
        }],
        max_objects,
        true,
    );
    level.ranges.clear();
    level
}

/// The plant's root split as [`branch_level`] splits it: every branch instance of the root
/// (deeper ones belong to them) with its transform, and the rest.
pub(super) fn split_root(plant: &Plant) -> (Vec<(u32, Mat4)>, Plant) {
    split_object(plant, plant.instancing.root, &|_| true, "rest")
}

/// The common end of both levels: `parents` are, per object of the level above, the objects
/// it places (with transforms), its rest and how many times it is placed; the children are
/// grouped into representatives and each parent's placements follow, then its rest (only when
/// it has children, unless `lonely_rest`).
fn from_children(
    plant: &Plant,
    parents: &[Parent],
    max_objects: usize,
    lonely_rest: bool,
) -> BranchLevel {
    let mut distinct: Vec<(u32, u32, Plant)> = Vec::new();
    for Parent { children, uses, .. } in parents {
        for &(o, _) in children {
            match distinct.iter_mut().find(|d| d.0 == o) {
                Some(d) => d.1 += uses,
                None => distinct.push((o, *uses, object_plant(plant, o))),
            }
        }
    }
    let (reps, of) = representatives(distinct, max_objects);
    let mut objects: Vec<(u32, Plant, u32)> = reps.into_iter().map(|(o, p)| (o, p, 0)).collect();
    let mut placements = Vec::new();
    let mut ranges = Vec::with_capacity(parents.len());
    for Parent {
        children,
        rest,
        uses,
    } in parents
    {
        let start = placements.len() as u32;
        if lonely_rest || !children.is_empty() {
            for (o, t) in children {
                let Some(&(_, r, fit)) = of.iter().find(|x| x.0 == *o) else {
                    continue;
                };
                objects[r].2 += uses;
                placements.push((r as u32, *t * fit));
            }
            if !rest.wood.indices.is_empty() || !rest.leaves.indices.is_empty() {
                placements.push((objects.len() as u32, Mat4::IDENTITY));
                objects.push((REST_OBJECT, rest.clone(), *uses));
            }
        }
        ranges.push([start, placements.len() as u32]);
    }
    BranchLevel {
        objects,
        placements,
        ranges,
    }
}

/// How much smaller than its main branch a small branch is: the small branches of a main
/// branch are the largest branch objects below it whose bounding-box diagonal is at most this
/// fraction of the main branch's (MNP01 §7: small branches grouped into main branches).
pub const SMALL_BRANCH_RATIO: f32 = 0.5;

/// MNP01 §7's third level: the small branches of each main-branch object of `main` (at most
/// `max_objects` representatives over the whole plant, [`representatives`]) placed in its
/// frame, then its rest (its own wood and the leaves and branch parts above the cut). A main
/// branch without small branches does not open (an empty range); nor does the plant's rest.
pub fn small_level(plant: &Plant, main: &BranchLevel, max_objects: usize) -> BranchLevel {
    let inst = &plant.instancing;
    let parents: Vec<Parent> = main
        .objects
        .iter()
        .map(|(o, p, uses)| {
            if *o == REST_OBJECT {
                return Parent {
                    children: Vec::new(),
                    rest: Plant::default(),
                    uses: 0,
                };
            }
            let cut = SMALL_BRANCH_RATIO * diagonal(p);
            // The size of every branch object below it, once.
            let mut sizes: Vec<(u32, f32)> = Vec::new();
            let mut stack = vec![*o];
            while let Some(x) = stack.pop() {
                for i in inst
                    .objects
                    .get(x as usize)
                    .map_or(&[][..], |b| &b.instances)
                {
                    let leaf = inst
                        .objects
                        .get(i.object as usize)
                        .is_none_or(|c| c.level == 0);
                    if !leaf && i.object != *o && !sizes.iter().any(|s| s.0 == i.object) {
                        sizes.push((i.object, diagonal(&object_plant(plant, i.object))));
                        stack.push(i.object);
                    }
                    if sizes.len() > 4096 {
                        break;
                    }
                }
            }
            let stop = |c: u32| sizes.iter().any(|s| s.0 == c && s.1 <= cut);
            let (children, rest) = split_object(plant, *o, &stop, &format!("object {o} rest"));
            Parent {
                children,
                rest,
                uses: *uses,
            }
        })
        .collect();
    from_children(plant, &parents, max_objects, false)
}

/// The coverage of an object's BTF for the visibility cube-maps: the alpha of its sky-facing
/// ambient images, one per view sample.
pub fn coverage<'a>(
    lut: &'a DirectionLut,
    ambient: &'a [Mips],
    min: Vec3,
    max: Vec3,
    tile: u32,
) -> visibility::Coverage<'a> {
    let views = lut.set().len();
    visibility::Coverage {
        lut,
        frames: lut
            .set()
            .directions()
            .iter()
            .map(|&d| view_frame(d, min, max, tile))
            .collect(),
        images: ambient[..views].iter().map(|m| m.as_slice()).collect(),
        tile,
        min,
        max,
    }
}

/// MNP01 §3.3 at the branch level: for each placement, the cube-maps at its box's 8 corners
/// of the rest of the tree (the other placements).
fn branch_cubes(
    objects: &[ObjectBtf],
    placements: &[Placement],
    lut: &DirectionLut,
    tile: u32,
    res: usize,
) -> Vec<u8> {
    let covers: Vec<visibility::Coverage> = objects
        .iter()
        .map(|o| {
            coverage(
                lut,
                &o.ambient,
                Vec3::from(o.bbox_min),
                Vec3::from(o.bbox_max),
                tile,
            )
        })
        .collect();
    let occluders: Vec<visibility::Occluder> = placements
        .iter()
        .map(|p| visibility::Occluder::new(&covers[p.object as usize], p.affine()))
        .collect();
    let layout = visibility::CubeLayout::new(res);
    let per = layout.dirs.len();
    let mut out = vec![0u8; placements.len() * visibility::CORNERS * per];
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = (placements.len().div_ceil(threads)).max(1) * visibility::CORNERS * per;
    std::thread::scope(|scope| {
        for (c, part) in out.chunks_mut(chunk).enumerate() {
            let (occluders, layout, covers) = (&occluders, &layout, &covers);
            scope.spawn(move || {
                let mut open = Vec::new();
                let first = c * chunk / (visibility::CORNERS * per);
                for (k, map) in part.chunks_mut(per).enumerate() {
                    let (p, corner) = (first + k / visibility::CORNERS, k % visibility::CORNERS);
                    let cov = &covers[placements[p].object as usize];
                    let at = occluders[p]
                        .to_frame
                        .transform_point3(visibility::corner(cov.min, cov.max, corner));
                    let others: Vec<&visibility::Occluder> = occluders
                        .iter()
                        .enumerate()
                        .filter(|&(q, _)| q != p)
                        .map(|(_, o)| o)
                        .collect();
                    visibility::render(at, &others, None, layout, &mut open, map);
                }
            });
        }
    });
    out
}

/// `hbt`'s offline half (MNP01 §3.1, §3.3, §6.1): one plant's BTF levels and cube-maps.
pub struct HbtBake;

impl crate::bake::Bake for HbtBake {
    const NAME: &'static str = "hbt";
    const FORMAT_VERSION: u32 = FORMAT_VERSION;
    type Params = HbtBakeParams;
    type Asset = HbtBaked;

    fn bake(
        gpu: &Gpu,
        plant: &Plant,
        params: &HbtBakeParams,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<HbtBaked, RenderError> {
        bake(gpu, plant, params, progress)
    }

    fn encode(asset: &HbtBaked) -> Vec<u8> {
        asset.encode()
    }

    fn decode(bytes: &[u8]) -> Result<HbtBaked, DecodeError> {
        HbtBaked::decode(bytes)
    }
}

/// Bakes `plant`'s BTF (the top level) and, with `p.branches`, the level below
/// ([`branch_level`]): each object's BTF over the branch direction sets, and each placement's
/// visibility cube-maps. `progress(done, total)` counts rasterised views, light maps and lit
/// views.
pub fn bake(
    gpu: &Gpu,
    plant: &Plant,
    p: &HbtBakeParams,
    mut progress: impl FnMut(usize, usize),
) -> Result<HbtBaked, RenderError> {
    let option = |e: crate::directions::DirectionError| RenderError::Option(e.to_string());
    let views = DirectionSet::new(p.view_level).map_err(option)?;
    let lights = DirectionSet::new(p.light_level).map_err(option)?;
    let bviews = DirectionSet::new(p.branch_view_level).map_err(option)?;
    let blights = DirectionSet::new(p.branch_light_level).map_err(option)?;
    let level = if p.branches {
        branch_level(plant, p.max_branch_objects as usize)
    } else {
        BranchLevel {
            objects: Vec::new(),
            placements: Vec::new(),
            ranges: Vec::new(),
        }
    };
    let small = if p.branches && p.small_branches {
        small_level(plant, &level, p.max_branch_objects as usize)
    } else {
        BranchLevel {
            objects: Vec::new(),
            placements: Vec::new(),
            ranges: Vec::new(),
        }
    };
    let top = 2 * views.len() + lights.len();
    let per_object = 2 * bviews.len() + blights.len();
    let total = top + per_object * (level.objects.len() + small.objects.len());
    // MNP01 §6.1: with `tree_from_branches` the tree level is rendered from the level below
    // once that is baked (below); otherwise from geometry, now.
    let compose = p.branches && p.tree_from_branches && !level.placements.is_empty();
    let (mut direct, mut ambient) = if compose {
        (Vec::new(), Vec::new())
    } else {
        bake_btf(gpu, plant, p, &views, &lights, &mut |d| progress(d, total))?
    };
    let mut objects = Vec::with_capacity(level.objects.len() + small.objects.len());
    for (k, (object, sub, uses)) in level.objects.iter().chain(&small.objects).enumerate() {
        let done = top + per_object * k;
        let (direct, ambient) = bake_btf(gpu, sub, p, &bviews, &blights, &mut |d| {
            progress(done + d, total)
        })?;
        objects.push(ObjectBtf {
            object: *object,
            uses: *uses,
            bbox_min: sub.bbox_min,
            bbox_max: sub.bbox_max,
            direct,
            ambient,
        });
    }
    let small_objects = objects.split_off(level.objects.len());
    let placed = |level: &BranchLevel| -> Vec<Placement> {
        level
            .placements
            .iter()
            .map(|(o, m)| Placement {
                object: *o,
                transform: Affine3A::from_mat4(*m).to_cols_array(),
            })
            .collect()
    };
    let placements = placed(&level);
    let small_placements = placed(&small);
    let lut = DirectionLut::new(&bviews, DirectionLut::DEFAULT_RESOLUTION).map_err(option)?;
    let res = p.cube_resolution as usize;
    // MNP01 §3.3 one level down: each small branch sees the rest of its own main branch.
    let mut small_cubes = Vec::new();
    for r in &small.ranges {
        let within = &small_placements[r[0] as usize..r[1] as usize];
        small_cubes.extend(branch_cubes(&small_objects, within, &lut, p.tile, res));
    }
    // MNP01 §6.1 one level down: a main branch with small branches rendered from them.
    if compose {
        let per = visibility::CORNERS * visibility::FACES * res * res;
        for (k, r) in small.ranges.iter().enumerate() {
            let (a, b) = (r[0] as usize, r[1] as usize);
            if a == b {
                continue;
            }
            let o = &objects[k];
            let (direct, ambient) = super::compose::from_level_below(
                &super::compose::LevelBelow {
                    objects: &small_objects,
                    placements: &small_placements[a..b],
                    cubes: &small_cubes[a * per..b * per],
                    cube_resolution: p.cube_resolution,
                    branch_views: &bviews,
                    branch_lights: &blights,
                },
                &bviews,
                &blights,
                (Vec3::from(o.bbox_min), Vec3::from(o.bbox_max)),
                p.tile,
                p.supersample.min(2),
                p.compose_min_weight,
            )
            .map_err(option)?;
            objects[k].direct = direct;
            objects[k].ambient = ambient;
        }
    }
    let cubes = branch_cubes(&objects, &placements, &lut, p.tile, res);
    if compose {
        (direct, ambient) = super::compose::from_level_below(
            &super::compose::LevelBelow {
                objects: &objects,
                placements: &placements,
                cubes: &cubes,
                cube_resolution: p.cube_resolution,
                branch_views: &bviews,
                branch_lights: &blights,
            },
            &views,
            &lights,
            (Vec3::from(plant.bbox_min), Vec3::from(plant.bbox_max)),
            p.tile,
            p.supersample.min(2),
            p.compose_min_weight,
        )
        .map_err(option)?;
        progress(total, total);
    }
    Ok(HbtBaked {
        tile: p.tile,
        view_level: p.view_level,
        light_level: p.light_level,
        bbox_min: plant.bbox_min,
        bbox_max: plant.bbox_max,
        direct,
        ambient,
        branch_view_level: p.branch_view_level,
        branch_light_level: p.branch_light_level,
        objects,
        placements,
        cube_resolution: p.cube_resolution,
        cubes,
        small: SmallLevel {
            objects: small_objects,
            ranges: small.ranges,
            placements: small_placements,
            cubes: small_cubes,
        },
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
            branch_view_level: 0,
            branch_light_level: 0,
            objects: vec![ObjectBtf {
                object: 3,
                uses: 2,
                bbox_min: [0.0; 3],
                bbox_max: [1.0; 3],
                direct: vec![mips(8); 36],
                ambient: vec![mips(8); 12],
            }],
            placements: vec![Placement {
                object: 0,
                transform: Affine3A::IDENTITY.to_cols_array(),
            }],
            cube_resolution: 2,
            cubes: vec![7; 8 * 6 * 4],
            small: SmallLevel::default(),
        };
        let object = |o: u32| ObjectBtf {
            object: o,
            uses: 1,
            bbox_min: [0.0; 3],
            bbox_max: [0.5; 3],
            direct: vec![mips(8); 36],
            ambient: vec![mips(8); 12],
        };
        let placed = |o: u32| Placement {
            object: o,
            transform: Affine3A::IDENTITY.to_cols_array(),
        };
        let with_small = HbtBaked {
            small: SmallLevel {
                objects: vec![object(5), object(REST_OBJECT)],
                ranges: vec![[0, 2]],
                placements: vec![placed(0), placed(1)],
                cubes: vec![9; 2 * 8 * 6 * 4],
            },
            ..b.clone()
        };
        let bytes = with_small.encode();
        assert_eq!(HbtBaked::decode(&bytes).unwrap(), with_small);
        for broken in [
            SmallLevel {
                ranges: vec![[0, 3]],
                ..with_small.small.clone()
            },
            SmallLevel {
                ranges: vec![[0, 2], [2, 2]],
                ..with_small.small.clone()
            },
            SmallLevel {
                cubes: vec![9; 8 * 6 * 4],
                ..with_small.small.clone()
            },
        ] {
            let wrong = HbtBaked {
                small: broken,
                ..b.clone()
            };
            assert!(HbtBaked::decode(&wrong.encode()).is_err());
        }
        let bytes = b.encode();
        assert_eq!(HbtBaked::decode(&bytes).unwrap(), b);
        assert!(HbtBaked::decode(&bytes[..bytes.len() - 1]).is_err());
        let mut wrong = b.clone();
        wrong.direct.pop();
        assert!(HbtBaked::decode(&wrong.encode()).is_err());
        let mut wrong = b.clone();
        wrong.objects[0].ambient.pop();
        assert!(HbtBaked::decode(&wrong.encode()).is_err());
        let mut wrong = b.clone();
        wrong.cubes.pop();
        assert!(HbtBaked::decode(&wrong.encode()).is_err());
        let mut wrong = b.clone();
        wrong.placements[0].object = 1;
        assert!(HbtBaked::decode(&wrong.encode()).is_err());
    }
}
