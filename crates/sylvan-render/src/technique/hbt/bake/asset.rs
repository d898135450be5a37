//! The `hbt` asset: [`HbtBaked`] — the tree's BTF, the levels below it (their objects, placements
//! and visibility cube-maps) — and its codec (encode, and a decode that checks every count and
//! size).

use crate::bake::codec::{DecodeError, Decoder, Encoder};
use crate::technique::hbt::visibility;
use glam::{Affine3A, Vec3};

/// Bumped whenever the payload below or the lighting baked into it changes.
pub const FORMAT_VERSION: u32 = 7;
/// Largest visibility cube-map face side accepted.
pub const MAX_CUBE_RESOLUTION: u32 = 64;

/// Half-sides of the facing quad `hbt.wgsl` (`hbt_vertex`) draws for a box of half-extents `h`
/// seen along the unit direction `f` (model frame): the box's frame
/// ([`PlaneFrame::for_box`](crate::bake::views::PlaneFrame::for_box), the same image axes),
/// 10 % wider.
fn facing_quad_half(h: Vec3, f: Vec3) -> (f32, f32) {
    let half = crate::bake::views::PlaneFrame::for_box(f, -h, h).half;
    (half.x * 1.1, half.y * 1.1)
}

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
    /// Per placement, per bounding-box corner ([`crate::technique::hbt::visibility::corner`]), a cube-map
    /// (`6 · cube_resolution²` opacities, 255 = opaque) of the rest of the tree seen from it
    /// (MNP01 §3.3 at the branch level).
    pub cubes: Vec<u8>,
    /// The small-branch level below the main branches (empty unless baked with
    /// [`crate::technique::hbt::HbtBakeParams::small_branches`]).
    pub small: SmallLevel,
    /// The tree billboard's and the one-sample meshes' ꟻLIP against the reference at each of
    /// [`super::switch::SIZES`] ([`super::switch::measure`]): where the meshes open on a plant
    /// without main branches, or whose level below costs more than its meshes (empty in a
    /// decoded asset that was not measured: the thresholds apply).
    pub switch_error: [Vec<f32>; 2],
}

impl HbtBaked {
    /// View samples.
    pub fn views(&self) -> usize {
        crate::directions::SAMPLE_COUNTS[self.view_level as usize]
    }

    /// The measured mesh switch ([`HbtBaked::switch_error`]) as a curve; `None` where it was
    /// not measured (the thresholds apply).
    pub fn switch_curve(&self) -> Option<super::switch::SwitchCurve> {
        (!self.switch_error[0].is_empty()).then(|| super::switch::SwitchCurve {
            sizes: super::switch::SIZES.to_vec(),
            billboard: self.switch_error[0].clone(),
            meshes: self.switch_error[1].clone(),
            tile: self.tile,
        })
    }

    /// The level below's fill against the tree billboard's: the mean, over the switch's view
    /// directions ([`super::switch::VIEWS`]), of the area of every placement's facing quad (its
    /// object's box projected along the view, as `hbt.wgsl` draws it) over the area of the tree's
    /// quad — how many BTF fragments the opened tree shades per fragment of the closed one
    /// (#15: what the level costs). 0 without a level below.
    pub fn branch_fill(&self) -> f32 {
        let tree = (Vec3::from(self.bbox_max) - Vec3::from(self.bbox_min)) * 0.5;
        let views = super::switch::VIEWS.map(|d| Vec3::from(d).normalize());
        let mut sum = 0.0;
        for f in views {
            let (hu, hv) = facing_quad_half(tree, f);
            let mut below = 0.0;
            for pl in &self.placements {
                let Some(o) = self.objects.get(pl.object as usize) else {
                    continue;
                };
                let m = pl.affine().matrix3;
                let scale = m.x_axis.length();
                let dir = (m.transpose() * f).normalize_or_zero();
                let h = (Vec3::from(o.bbox_max) - Vec3::from(o.bbox_min)) * 0.5;
                let (u, v) = facing_quad_half(h, dir);
                below += u * v * scale * scale;
            }
            sum += below / (hu * hv).max(1e-12);
        }
        sum / views.len() as f32
    }

    /// Pixels the tree's facing quad covers where one of its texels covers `texel_px` pixels
    /// (mean over [`super::switch::VIEWS`]; the texel as `hbt.wgsl` sizes it, the quad's larger
    /// half-side over half the tile).
    pub fn tree_pixels(&self, texel_px: f32) -> f32 {
        let tree = (Vec3::from(self.bbox_max) - Vec3::from(self.bbox_min)) * 0.5;
        let views = super::switch::VIEWS.map(|d| Vec3::from(d).normalize());
        let tile = self.tile as f32;
        let px: f32 = views
            .iter()
            .map(|&f| {
                let (hu, hv) = facing_quad_half(tree, f);
                let texel = 2.0 * hu.max(hv) / 1.1 / tile;
                4.0 * hu * hv / (texel * texel).max(1e-12)
            })
            .sum();
        px / views.len() as f32 * texel_px * texel_px
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

impl crate::bake::codec::Codec for HbtBaked {
    /// The payload written to the cache.
    fn encode(&self) -> Vec<u8> {
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
        e.f32s(&self.switch_error[0]);
        e.f32s(&self.switch_error[1]);
        e.buf
    }

    /// Reads a payload back, checking every count and size against the header.
    fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
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
        let switch_error = [d.f32s()?, d.f32s()?];
        let n = super::switch::SIZES.len();
        let len = switch_error[0].len();
        if (len != 0 && len != n)
            || switch_error[1].len() != len
            || switch_error
                .iter()
                .flatten()
                .any(|x| !(x.is_finite() && *x >= 0.0))
        {
            return Err(bad(format!(
                "switch errors: {} and {} values, none or {n} finite ones each expected",
                switch_error[0].len(),
                switch_error[1].len()
            )));
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
            branch_view_level,
            branch_light_level,
            objects,
            placements,
            cube_resolution,
            cubes,
            small,
            switch_error,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::codec::Codec;

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
            switch_error: [vec![0.1; super::super::switch::SIZES.len()], vec![0.2; 9]],
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
