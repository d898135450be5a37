//! The GPU side of `hbt`: atlas upload, per-frame instance lists with the direction look-ups and
//! reconstruction weights (MNP01 §4.1), and the passes.

use super::bake::{self as hb, HbtBaked};
use super::scene::{PlacedTree, SceneVisibility, trilinear};
use super::visibility;
use super::{HbtBakeParams, HbtDrawParams, HbtProjection, HbtShadows};
use crate::RenderError;
use crate::directions::{DirectionLut, DirectionSet};
use crate::frame::{CASCADES, FrameResources};
use crate::instances::{GpuTreeInstance, Instances};
use crate::pipeline;
use crate::technique::common::{self, Growable, TileAtlas};
use crate::technique::geometry::{MeshPipelines, SpeciesMeshes};
use crate::technique::{DrawContext, DrawCounts, FrameInput, Technique};
use bytemuck::{Pod, Zeroable};
use glam::{Affine3A, Vec3};
use std::ops::Range;
use sylvan_gpu::{Gpu, layout};
use sylvan_plant::Plant;
use sylvan_scene::Terrain;
use wgpu::util::DeviceExt;

const PASSES: usize = 1 + CASCADES;

/// One image set (a tree's BTF, or an object's of the level below) as the shader sees it.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, PartialEq)]
struct GpuHbtSet {
    min: [f32; 4],
    max: [f32; 4],
    info: [u32; 4],
    counts: [u32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuSampleFrame {
    u: [f32; 4],
    v: [f32; 4],
    f: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuHbtAtlas {
    tiles: [u32; 4],
    params: [f32; 4],
}

/// One billboard (a tree, or one object of an opened tree) as the `hbt` shader sees it
/// (vertex locations 4–13, per instance).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug, PartialEq)]
struct GpuHbtInstance {
    /// Rows of the model → world affine map.
    m: [[f32; 4]; 3],
    /// The 3 view samples; w: image set.
    views: [u32; 4],
    /// The 3 light samples; w: hierarchy level (0 tree, 1 main branch, 2 small branch), for
    /// the technique debug view.
    lights: [u32; 4],
    /// Pair weights `w[3·view + light]`; the last 3 unused.
    weights: [f32; 12],
    /// Sun transmittance at the 8 box corners (x: corners 0–3, y: 4–7, unorm8), then the sky
    /// transmittance (z, w): the visibility cube-maps' levels combined (MNP01 §4.2).
    vis: [u32; 4],
    /// Tint seed, presence, uniform scale, world bounding radius.
    extra: [f32; 4],
}

impl GpuHbtInstance {
    const LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<GpuHbtInstance>() as u64,
        step_mode: wgpu::VertexStepMode::Instance,
        attributes: &wgpu::vertex_attr_array![
            4 => Float32x4, 5 => Float32x4, 6 => Float32x4, 7 => Uint32x4, 8 => Uint32x4,
            9 => Float32x4, 10 => Float32x4, 11 => Float32x4, 12 => Uint32x4, 13 => Float32x4
        ],
    };
}

/// An object placed in its parent (a main branch in the tree, a small branch in its main
/// branch), ready for the per-frame loop.
struct Placed {
    set: u32,
    to_parent: Affine3A,
    /// Linear part of parent → object (directions).
    from_parent: glam::Mat3A,
    scale: f32,
    /// Object box centre (object space) and radius in the parent's units.
    centre: Vec3,
    radius: f32,
    /// Its corners in [0, 1]³ of the parent's box (to interpolate the parent's visibility).
    corners_in_parent: [Vec3; 8],
    /// Sky transmittance at each corner from the rest of the parent.
    sky: [f32; 8],
}

impl Placed {
    /// `placement` of an object of image set `set` and box `bbox`, inside a parent of box
    /// `parent`; `cube(k)` is its cube-map at corner `k` (directions `dirs`).
    fn new<'c>(
        set: u32,
        placement: &hb::Placement,
        bbox: (Vec3, Vec3),
        parent: (Vec3, Vec3),
        cube: impl Fn(usize) -> &'c [u8],
        dirs: &[Vec3],
    ) -> Self {
        let (min, max) = bbox;
        let to_parent = placement.affine();
        let scale = to_parent.matrix3.x_axis.length();
        Placed {
            set,
            to_parent,
            from_parent: to_parent.matrix3.inverse(),
            scale,
            centre: (min + max) * 0.5,
            radius: (max - min).length() * 0.5 * scale,
            corners_in_parent: std::array::from_fn(|k| {
                let c = to_parent.transform_point3(visibility::corner(min, max, k));
                (c - parent.0) / (parent.1 - parent.0).max(Vec3::splat(1e-6))
            }),
            sky: std::array::from_fn(|k| visibility::sky_transmittance(cube(k), dirs)),
        }
    }
}

impl Placed {
    /// Sun and sky transmittance at its 8 corners: its own cube-maps (`cubes`, the rest of its
    /// parent, laid out in the parent's frame; the sun from them only when `sun` — the sun in
    /// the parent's frame — is given) times the
    /// parent's transmittance `parent` interpolated at its corners (MNP01 §4.2: levels
    /// combine as 1 − Π(1 − opacity)).
    fn visibility<'c>(
        &self,
        parent: ([f32; 8], [f32; 8]),
        cubes: impl Fn(usize) -> &'c [u8],
        res: usize,
        sun: Option<Vec3>,
    ) -> ([f32; 8], [f32; 8]) {
        let mut out = ([1.0; 8], [1.0; 8]);
        for k in 0..visibility::CORNERS {
            let q = self.corners_in_parent[k];
            let own = sun.map_or(1.0, |d| 1.0 - visibility::lookup(cubes(k), res, d));
            out.0[k] = own * trilinear(parent.0, q);
            out.1[k] = self.sky[k] * trilinear(parent.1, q);
        }
        out
    }
}

/// One placement of the level below the tree, ready for the per-frame loop.
struct PlacementDraw {
    placed: Placed,
    /// Index of the placement in its plant's baked cube-maps.
    index: usize,
    /// Texel side of its object per unit tree scale: it opens into its small branches when
    /// that would be magnified.
    texel: f32,
    /// Its object's small-branch placements (indices into [`PlantDraw::small`]; empty: it
    /// does not open).
    small: Range<usize>,
    /// Texel side of its lowest BTF level per unit tree scale (its own, or its small
    /// branches'): its meshes open when that would be magnified. `None` for the rest object
    /// and small parts ([`SMALL_PART_TRIANGLES`]), whose meshes open with the first branch's.
    mesh_texel: Option<f32>,
}

/// With [`HbtDrawParams::mesh_per_branch`], a placement whose meshes have fewer triangles than
/// this opens into them with the rest (the first branch to open), not by its own texel: a
/// bracket of a few leaf cards costs more as a billboard than as its triangles. Measured on the
/// default view at 1280×720 (87 of the pine's 117 placements; every one of the prunus's and
/// the bush's, which then keep their own texels): ꟻLIP 0.0446 against 0.0488, frame
/// 1480 ms against 1716 ms (BENCHMARKS.md).
const SMALL_PART_TRIANGLES: usize = 64;

/// [`MeshDraw::part`] of a whole tree's meshes.
const WHOLE: u32 = u32::MAX;

/// One instanced draw of a plant's meshes: the whole tree or one placement's part.
struct MeshDraw {
    /// Index into [`Hbt::plants`].
    plant: usize,
    /// A placement index into [`PlantDraw::parts`], or [`WHOLE`].
    part: u32,
    /// Its records in the mesh instance buffer.
    instances: Range<u32>,
}

/// A distinct baked plant, ready to draw.
struct PlantDraw {
    tree_set: u32,
    min: Vec3,
    max: Vec3,
    radius: f32,
    /// Tree-level texel size per unit scale (model metres).
    texel: f32,
    /// Texel size of the level drawn just above the meshes (the largest main branch's, or the
    /// tree's without a level below), per unit scale: the meshes open when it is magnified.
    mesh_texel: f32,
    /// The pixels per `mesh_texel` at which the meshes open: `mesh_texel_pixels`, or without a
    /// level below `open_texel_pixels` (the tree level is replaced where it would be magnified;
    /// the branches' earlier switch has no meaning for it).
    mesh_pixels: f32,
    /// The plant's own meshes (MNP01 §4's polygonal bottom level; with `levels` = 3), indices
    /// grouped by placement when `parts` is not empty.
    meshes: Option<SpeciesMeshes>,
    /// Per placement, its ranges of the wood and leaf indices (empty: the tree opens into its
    /// meshes as a whole, [`HbtDrawParams::mesh_per_branch`] off or no parts found).
    parts: Vec<[Range<u32>; 2]>,
    placements: Vec<PlacementDraw>,
    /// Index of its bake in `prepare`'s list (species with equal bakes share one entry).
    source: usize,
    /// The tree level's ambient images (their alpha is the coverage the scene's cube-maps need).
    ambient: Vec<hb::Mips>,
    /// The branch placements' cube-maps ([`HbtBaked::cubes`]) and their side.
    cubes: Vec<u8>,
    /// MNP01 §7's small branches, by small placement ([`hb::SmallLevel::placements`]), and
    /// their cube-maps.
    small: Vec<Placed>,
    small_cubes: Vec<u8>,
    cube_resolution: u32,
}

/// The prepared MNP01 technique.
pub struct Hbt {
    draw: HbtDrawParams,
    /// The baked tile size and cube-map resolution (the scene's cube-maps use them).
    tile: u32,
    cube_resolution: u32,
    /// MNP01 §4.1's direction → 3 samples tables of the tree level (same results as
    /// `DirectionSet::nearest3`, ~3× faster on the CPU) and of the level below.
    views: DirectionLut,
    lights: DirectionLut,
    branch_views: DirectionLut,
    branch_lights: DirectionLut,
    plants: Vec<PlantDraw>,
    /// Species → index into `plants`.
    species_plant: Vec<usize>,
    /// The top level's cube-maps (after [`Hbt::place`]).
    scene: Option<SceneVisibility>,
    pipeline: wgpu::RenderPipeline,
    shadow_pipeline: wgpu::RenderPipeline,
    bind: wgpu::BindGroup,
    /// The mesh pipelines (with `levels` = 3).
    mesh_pipes: Option<MeshPipelines>,
    static_bytes: u64,
    // Per frame (reused; nothing is allocated once the vectors have grown).
    instances: Growable,
    staging: Vec<GpuHbtInstance>,
    sort: Vec<(f32, GpuHbtInstance)>,
    ranges: [Range<u32>; PASSES],
    /// Trees and placements drawn as meshes: their records (presence set), drawn by
    /// `mesh_draws[pass]`.
    mesh_instances: Growable,
    mesh_staging: Vec<GpuTreeInstance>,
    mesh_sort: Vec<(u32, u32, GpuTreeInstance)>,
    mesh_draws: [Vec<MeshDraw>; PASSES],
    /// Per placement of the tree at hand, its share drawn as meshes.
    part_mesh: Vec<f32>,
    opened: u32,
    meshed: u32,
    branches_opened: u32,
    branches_meshed: u32,
}

impl Hbt {
    /// Instance-buffer re-allocations so far.
    pub fn reallocations(&self) -> u32 {
        self.instances.reallocations
    }

    /// Trees drawn opened into a level below the tree — branches or meshes — in the last frame
    /// (fully or in transition).
    pub fn opened(&self) -> u32 {
        self.opened
    }

    /// Trees drawn (fully or in transition) as their meshes in the last frame's camera pass.
    pub fn meshed(&self) -> u32 {
        self.meshed
    }

    /// Main branches drawn (fully or in transition) as their small branches in the last
    /// frame's camera pass.
    pub fn branches_opened(&self) -> u32 {
        self.branches_opened
    }

    /// Placements of opened trees (main branches and rests) drawn, fully or in transition, as
    /// their meshes in the last frame's camera pass (not counting trees drawn as meshes as a
    /// whole).
    pub fn branches_meshed(&self) -> u32 {
        self.branches_meshed
    }

    /// Bytes of the visibility structure: the scene's cube-maps (CPU) and the plants' branch
    /// level cube-maps.
    pub fn visibility_bytes(&self) -> u64 {
        self.scene.as_ref().map_or(0, SceneVisibility::bytes)
            + self
                .plants
                .iter()
                .map(|p| (p.cubes.len() + p.small_cubes.len()) as u64)
                .sum::<u64>()
    }

    /// Milliseconds the last [`Hbt::place`] took to build the scene's cube-maps.
    pub fn visibility_build_ms(&self) -> f64 {
        self.scene.as_ref().map_or(0.0, |s| s.build_ms)
    }

    /// MNP01 §3.3's top level: builds every placed tree's visibility cube-maps against the
    /// other trees and `terrain` (with [`HbtShadows::CubeMaps`]; otherwise nothing).
    pub fn place(&mut self, instances: &Instances, terrain: Option<&Terrain>) {
        let trees: Vec<PlacedTree> = instances
            .placed_trees()
            .filter(|(s, _)| *s < self.species_plant.len())
            .map(|(s, r)| PlacedTree::from_record(s, r.base_scale, r.rot))
            .collect();
        let covers: Vec<_> = self
            .species_plant
            .iter()
            .map(|&p| {
                let b = &self.plants[p];
                hb::coverage(&self.views, &b.ambient, b.min, b.max, self.tile)
            })
            .collect();
        self.scene = Some(SceneVisibility::build(
            &trees,
            &covers,
            terrain,
            self.cube_resolution as usize,
        ));
    }
}

/// Where prepared image sets go: their shader records, sample frames and atlas tiles.
struct SetSink<'s, 'a> {
    sets: &'s mut Vec<GpuHbtSet>,
    frames: &'s mut Vec<GpuSampleFrame>,
    tiles: &'s mut Vec<&'a [Vec<u8>]>,
    tile: u32,
}

impl<'a> SetSink<'_, 'a> {
    /// Adds one image set (views `dirs`, `lights` light samples, framing `bbox`); returns its
    /// index.
    fn add(
        &mut self,
        dirs: &DirectionSet,
        lights: usize,
        bbox: (Vec3, Vec3),
        direct: &'a [Vec<Vec<u8>>],
        ambient: &'a [Vec<Vec<u8>>],
    ) -> u32 {
        let (min, max) = bbox;
        let first_frame = self.frames.len() as u32;
        for &d in dirs.directions() {
            let f = hb::view_frame(d, min, max, self.tile);
            self.frames.push(GpuSampleFrame {
                u: f.u.extend(f.half.x).to_array(),
                v: f.v.extend(f.half.y).to_array(),
                f: f.f.extend(f.half.z).to_array(),
            });
        }
        let first_tile = self.tiles.len() as u32;
        self.tiles.extend(direct.iter().map(|m| m.as_slice()));
        self.tiles.extend(ambient.iter().map(|m| m.as_slice()));
        let (nv, nl) = (dirs.len() as u32, lights as u32);
        self.sets.push(GpuHbtSet {
            min: min.extend((max - min).length() * 0.5).to_array(),
            max: max.extend(0.0).to_array(),
            info: [first_tile, nl, first_tile + nv * nl, first_frame],
            counts: [nv, 0, 0, 0],
        });
        self.sets.len() as u32 - 1
    }
}

/// World direction → model space of a tree rotated by (cos, sin) about Y.
fn to_model_dir(d: Vec3, c: f32, s: f32) -> Vec3 {
    Vec3::new(c * d.x - s * d.z, d.y, s * d.x + c * d.z)
}

fn pack_unorm(v: [f32; 4]) -> u32 {
    v.iter().enumerate().fold(0u32, |acc, (k, x)| {
        acc | (((x.clamp(0.0, 1.0) * 255.0).round() as u32) << (8 * k))
    })
}

fn pack8(v: [f32; 8]) -> [u32; 2] {
    [
        pack_unorm([v[0], v[1], v[2], v[3]]),
        pack_unorm([v[4], v[5], v[6], v[7]]),
    ]
}

fn unit8(v: [u8; 8]) -> [f32; 8] {
    v.map(|x| x as f32 / 255.0)
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    if e1 <= e0 {
        return if x >= e0 { 1.0 } else { 0.0 };
    }
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// One billboard record: `to_world` (a similarity), image set `set`, view and light look-ups
/// (model space), visibility and presence.
#[allow(clippy::too_many_arguments)]
fn billboard(
    to_world: &Affine3A,
    set: u32,
    views: ([u32; 3], [f32; 3]),
    lights: ([u32; 3], [f32; 3]),
    min_weight: f32,
    vis: ([f32; 8], [f32; 8]),
    tint: f32,
    presence: f32,
    scale: f32,
    radius: f32,
) -> GpuHbtInstance {
    let m = to_world.matrix3;
    let t = to_world.translation;
    let w = hb::reconstruction_weights(views.1, lights.1, min_weight);
    let mut weights = [0.0; 12];
    weights[..9].copy_from_slice(&w);
    let (sun, sky) = (pack8(vis.0), pack8(vis.1));
    GpuHbtInstance {
        m: [
            [m.x_axis.x, m.y_axis.x, m.z_axis.x, t.x],
            [m.x_axis.y, m.y_axis.y, m.z_axis.y, t.y],
            [m.x_axis.z, m.y_axis.z, m.z_axis.z, t.z],
        ],
        views: [views.0[0], views.0[1], views.0[2], set],
        lights: [lights.0[0], lights.0[1], lights.0[2], 0],
        weights,
        vis: [sun[0], sun[1], sky[0], sky[1]],
        extra: [tint, presence, scale, radius],
    }
}

/// One shadow-caster record: seen from the sun only coverage matters, so the nearest of the
/// view samples `views` (looked up from the sun, in the object's frame) alone — blending 3
/// samples' differing silhouettes thins the crown's coverage, and with it its shadow (on the
/// test grove, ground shadow coverage 0.070 blended vs 0.112 reference).
fn caster(
    to_world: &Affine3A,
    set: u32,
    views: ([u32; 3], [f32; 3]),
    tint: f32,
    presence: f32,
    scale: f32,
    radius: f32,
) -> GpuHbtInstance {
    let (v, vw) = views;
    let best = (0..3).max_by(|&a, &b| vw[a].total_cmp(&vw[b])).unwrap_or(0);
    let mut inst = billboard(
        to_world,
        set,
        (v, vw),
        ([0; 3], [1.0, 0.0, 0.0]),
        0.0,
        ([1.0; 8], [1.0; 8]),
        tint,
        presence,
        scale,
        radius,
    );
    inst.weights = [0.0; 12];
    inst.weights[3 * best] = 1.0;
    inst
}

impl Hbt {
    /// Uploads every species' BTF levels into one atlas and builds the pipelines.
    pub fn new(
        gpu: &Gpu,
        frame: &FrameResources,
        plants: &[Plant],
        baked: &[HbtBaked],
        bake: &HbtBakeParams,
        params: &HbtDrawParams,
    ) -> Result<Self, RenderError> {
        if baked.len() != plants.len() {
            return Err(RenderError::Plant(format!(
                "{} baked BTFs for {} plants",
                baked.len(),
                plants.len()
            )));
        }
        let option = |e: crate::directions::DirectionError| RenderError::Option(e.to_string());
        let views = DirectionSet::new(bake.view_level).map_err(option)?;
        let lights = DirectionSet::new(bake.light_level).map_err(option)?;
        let bviews = DirectionSet::new(bake.branch_view_level).map_err(option)?;
        let blights = DirectionSet::new(bake.branch_light_level).map_err(option)?;
        let tile = bake.tile;
        let mut sets: Vec<GpuHbtSet> = Vec::new();
        let mut frames = Vec::new();
        let mut tiles: Vec<&[Vec<u8>]> = Vec::new();
        let mut plant_draws: Vec<PlantDraw> = Vec::new();
        let mut species_plant = Vec::with_capacity(plants.len());
        let mesh_pipes = (params.levels >= 3).then(|| MeshPipelines::new(gpu, frame));
        for (plant, b) in plants.iter().zip(baked) {
            let matches = b.tile == tile
                && b.view_level == bake.view_level
                && b.light_level == bake.light_level
                // A plant without an instancing hierarchy has no level below: trees only.
                && (!bake.branches
                    || b.objects.is_empty()
                    || (b.branch_view_level == bake.branch_view_level
                        && b.branch_light_level == bake.branch_light_level
                        && b.cube_resolution == bake.cube_resolution));
            if !matches {
                return Err(RenderError::Plant(format!(
                    "{}: baked BTF does not match the parameters (tile {} vs {tile}, levels {}/{} vs {}/{}, {} objects below) — re-bake",
                    plant.name,
                    b.tile,
                    b.view_level,
                    b.light_level,
                    bake.view_level,
                    bake.light_level,
                    b.objects.len()
                )));
            }
            // Species sharing a plant share its images (the bake gives them equal assets).
            let index = species_plant.len();
            if let Some(same) = plant_draws.iter().position(|p| &baked[p.source] == b) {
                species_plant.push(same);
                continue;
            }
            let (min, max) = (Vec3::from(b.bbox_min), Vec3::from(b.bbox_max));
            let mut out = SetSink {
                sets: &mut sets,
                frames: &mut frames,
                tiles: &mut tiles,
                tile,
            };
            let tree_set = out.add(&views, lights.len(), (min, max), &b.direct, &b.ambient);
            let mut placements = Vec::new();
            let mut small = Vec::new();
            if params.levels >= 2 {
                let object_sets: Vec<u32> = b
                    .objects
                    .iter()
                    .map(|o| {
                        let bbox = (Vec3::from(o.bbox_min), Vec3::from(o.bbox_max));
                        out.add(&bviews, blights.len(), bbox, &o.direct, &o.ambient)
                    })
                    .collect();
                let small_sets: Vec<u32> = b
                    .small
                    .objects
                    .iter()
                    .map(|o| {
                        let bbox = (Vec3::from(o.bbox_min), Vec3::from(o.bbox_max));
                        out.add(&bviews, blights.len(), bbox, &o.direct, &o.ambient)
                    })
                    .collect();
                let dirs = visibility::directions(b.cube_resolution as usize);
                let bbox = |o: &hb::ObjectBtf| (Vec3::from(o.bbox_min), Vec3::from(o.bbox_max));
                // Each small placement in its main branch's object (the ranges list them).
                for (main, o) in b.objects.iter().enumerate() {
                    for index in b.small.range(main) {
                        let sp = &b.small.placements[index];
                        small.push(Placed::new(
                            small_sets[sp.object as usize],
                            sp,
                            bbox(&b.small.objects[sp.object as usize]),
                            bbox(o),
                            |k| hb::cube_of(&b.small.cubes, b.cube_resolution, index, k),
                            &dirs,
                        ));
                    }
                }
                for (index, pl) in b.placements.iter().enumerate() {
                    let o = &b.objects[pl.object as usize];
                    let placed = Placed::new(
                        object_sets[pl.object as usize],
                        pl,
                        bbox(o),
                        (min, max),
                        |k| b.cube(index, k),
                        &dirs,
                    );
                    let (omin, omax) = bbox(o);
                    placements.push(PlacementDraw {
                        texel: (omax - omin).max_element() * placed.scale / tile as f32,
                        placed,
                        index,
                        small: b.small.range(pl.object as usize),
                        mesh_texel: b.placement_texel(index, false),
                    });
                }
            }
            let (texel, mesh_texel) = (b.tree_texel(), b.mesh_texel());
            // Branch by branch: the plant's meshes with each placement's triangles together.
            let split = match &mesh_pipes {
                Some(_) if params.mesh_per_branch && !placements.is_empty() => {
                    super::parts::placement_meshes(plant, placements.len()).ok()
                }
                _ => None,
            };
            // Parts of fewer than SMALL_PART_TRIANGLES triangles mesh with the rest (unless
            // that leaves no branch to open by).
            if let Some(split) = &split {
                let small = |part: &[Range<u32>; 2]| {
                    (part[0].len() + part[1].len()) / 3 < SMALL_PART_TRIANGLES
                };
                let any_large = placements
                    .iter()
                    .zip(&split.parts)
                    .any(|(pl, part)| pl.mesh_texel.is_some() && !small(part));
                for (pl, part) in placements.iter_mut().zip(&split.parts) {
                    if any_large && small(part) {
                        pl.mesh_texel = None;
                    }
                }
            }
            let (wood, leaves) = split
                .as_ref()
                .map_or((&plant.wood, &plant.leaves), |s| (&s.wood, &s.leaves));
            let meshes = match &mesh_pipes {
                Some(pipes) => Some(SpeciesMeshes::new(gpu, pipes, plant, wood, leaves)?),
                None => None,
            };
            species_plant.push(plant_draws.len());
            plant_draws.push(PlantDraw {
                tree_set,
                min,
                max,
                radius: (max - min).length() * 0.5,
                texel,
                mesh_texel,
                mesh_pixels: if placements.is_empty() {
                    params.open_texel_pixels
                } else {
                    params.mesh_texel_pixels
                },
                meshes,
                parts: split.map_or_else(Vec::new, |s| s.parts),
                placements,
                source: index,
                ambient: b.ambient.clone(),
                cubes: b.cubes.clone(),
                cube_resolution: b.cube_resolution,
                small,
                small_cubes: b.small.cubes.clone(),
            });
        }
        let device = &gpu.device;
        let atlas = TileAtlas::upload(
            gpu,
            "hbt_atlas",
            wgpu::TextureFormat::Rgba8UnormSrgb,
            tile,
            &tiles,
        )?;
        let uniform = GpuHbtAtlas {
            tiles: [
                tile,
                atlas.per_row,
                atlas.per_layer,
                (params.projection == HbtProjection::Cross) as u32,
            ],
            params: [
                1.0 / atlas.per_row as f32,
                1.0 / atlas.rows as f32,
                (params.shadows == HbtShadows::Cascades) as u32 as f32,
                0.0,
            ],
        };
        let storage = |label, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let species_buffer = storage("hbt_sets", bytemuck::cast_slice(&sets));
        let frame_buffer = storage("hbt_frames", bytemuck::cast_slice(&frames));
        let atlas_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("hbt_atlas_params"),
            contents: bytemuck::bytes_of(&uniform),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let sampler = common::trilinear_sampler(gpu, "hbt_sampler");
        let vf = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let bind_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hbt_layout"),
            entries: &[
                layout::storage(0, vf),
                layout::storage(1, vf),
                layout::atlas(2),
                layout::sampler(
                    3,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::SamplerBindingType::Filtering,
                ),
                layout::uniform(4, vf),
            ],
        });
        let atlas_view = atlas.view();
        let bind = common::bind_group(
            gpu,
            "hbt_bind",
            &bind_layout,
            &[
                species_buffer.as_entire_binding(),
                frame_buffer.as_entire_binding(),
                wgpu::BindingResource::TextureView(&atlas_view),
                wgpu::BindingResource::Sampler(&sampler),
                atlas_buffer.as_entire_binding(),
            ],
        );
        let module =
            sylvan_gpu::shader(gpu, "hbt", &pipeline::with_frame(include_str!("hbt.wgsl")));
        let (main, shadow) = common::image_pipelines(
            gpu,
            frame,
            &module,
            "hbt",
            &[None, Some(GpuHbtInstance::LAYOUT)],
            &bind_layout,
        );
        let static_bytes = atlas.bytes
            + species_buffer.size()
            + frame_buffer.size()
            + atlas_buffer.size()
            + plant_draws
                .iter()
                .filter_map(|p| p.meshes.as_ref())
                .map(SpeciesMeshes::bytes)
                .sum::<u64>();
        Ok(Self {
            draw: params.clone(),
            tile: bake.tile,
            cube_resolution: bake.cube_resolution,
            views: DirectionLut::new(&views, DirectionLut::DEFAULT_RESOLUTION).map_err(option)?,
            lights: DirectionLut::new(&lights, DirectionLut::DEFAULT_RESOLUTION).map_err(option)?,
            branch_views: DirectionLut::new(&bviews, DirectionLut::DEFAULT_RESOLUTION)
                .map_err(option)?,
            branch_lights: DirectionLut::new(&blights, DirectionLut::DEFAULT_RESOLUTION)
                .map_err(option)?,
            plants: plant_draws,
            species_plant,
            scene: None,
            pipeline: main,
            shadow_pipeline: shadow,
            bind,
            mesh_pipes,
            static_bytes,
            instances: Growable::new(gpu, "hbt_instances", 1 << 16),
            staging: Vec::new(),
            sort: Vec::new(),
            ranges: std::array::from_fn(|_| 0..0),
            mesh_instances: Growable::new(gpu, "hbt_mesh_instances", 1 << 12),
            mesh_staging: Vec::new(),
            mesh_sort: Vec::new(),
            mesh_draws: std::array::from_fn(|_| Vec::new()),
            part_mesh: Vec::new(),
            opened: 0,
            meshed: 0,
            branches_opened: 0,
            branches_meshed: 0,
        })
    }

    /// Per frame: each culled tree's levels, direction look-ups and visibility, sorted and
    /// uploaded.
    pub fn update(&mut self, gpu: &Gpu, input: &FrameInput<'_>) -> Result<(), RenderError> {
        self.staging.clear();
        self.mesh_staging.clear();
        self.opened = 0;
        self.meshed = 0;
        self.branches_opened = 0;
        self.branches_meshed = 0;
        let with_meshes = self.draw.levels >= 3;
        let sun = input.sun_dir;
        let light = self
            .draw
            .fixed_light
            .map_or(sun, |l| Vec3::from(l).normalize());
        // Whether the sun's visibility comes from the cube-maps (not the cascades).
        let cube_sun = self.draw.shadows == HbtShadows::CubeMaps;
        if let Some(scene) = &mut self.scene
            && cube_sun
        {
            scene.set_sun(sun);
        }
        // A meshed tree casts as meshes into the cascades that shade its own leaves (which the
        // shader picks by eye distance); elsewhere its shadow is the tree level's (measured on
        // the default view at 1280×720: meshes into every cascade cost ~40 % more shadow time
        // for the same ꟻLIP; billboards into every cascade self-shadow the meshes wrongly).
        let far = input.cascade_far;
        let receives_in = |pass: usize, d: f32, r: f32| {
            pass == 0 || {
                let c = pass - 1;
                let near = if c == 0 { 0.0 } else { far[c - 1] };
                d + r >= near && d - r <= far[c]
            }
        };
        let p = &self.draw;
        let open_px = p.open_texel_pixels;
        let (lo_px, hi_px) = (open_px * (1.0 - p.band), open_px * (1.0 + p.band));
        let ppm = input.pixels_per_metre;
        let mut part_mesh = std::mem::take(&mut self.part_mesh);
        for pass in 0..PASSES {
            self.sort.clear();
            self.mesh_sort.clear();
            for (s, &pi) in self.species_plant.iter().enumerate() {
                let plant = &self.plants[pi];
                let records = input.instances.records(pass, s);
                let ids = input.instances.ids(pass, s);
                let (m_lo, m_hi) = (
                    plant.mesh_pixels * (1.0 - p.band),
                    plant.mesh_pixels * (1.0 + p.band),
                );
                let mesh_record = |part: u32, presence: f32, rec: &GpuTreeInstance| {
                    let mut r = *rec;
                    r.rot[3] = presence;
                    (pi as u32, part, r)
                };
                for (rec, &id) in records.iter().zip(ids) {
                    let (c, sn, scale) = (rec.rot[0], rec.rot[1], rec.base_scale[3]);
                    let tree = PlacedTree::from_record(s, rec.base_scale, rec.rot);
                    let world_centre = tree
                        .to_world
                        .transform_point3((plant.min + plant.max) * 0.5);
                    let eye = input.eye - world_centre;
                    let dist = eye.length().max(1e-3);
                    let presence = rec.rot[3];
                    // MNP01 §4: open the tree when its texels would be magnified.
                    let texel_px = plant.texel * scale * ppm / dist;
                    let open = if plant.placements.is_empty() {
                        0.0
                    } else {
                        smoothstep(lo_px, hi_px, texel_px)
                    };
                    // How the tree's presence is shared: its meshes as a whole, its tree
                    // billboard, and its opened objects (each a mesh part and a billboard by
                    // `part_mesh`). The polygonal level opens when the BTF level above it
                    // would be magnified, decided from the camera in every pass so that a tree
                    // casts what it shows; a pass casts meshes only into the cascades that
                    // shade them.
                    part_mesh.clear();
                    let (mut whole, mut tree_bb, mut below) = (0.0, 0.0, 0.0);
                    // Branch by branch, unless no branch could be near enough (its largest
                    // texel at the tree's nearest point).
                    let reach =
                        plant.mesh_texel * scale * ppm / (dist - plant.radius * scale).max(1e-3);
                    if with_meshes && !plant.parts.is_empty() && reach > m_lo {
                        // Branch by branch: each placement by its own lowest BTF texel and
                        // distance; the rest (trunk) with the first branch that opens.
                        let mut most = 0.0f32;
                        let mut least = 1.0f32;
                        for pl in &plant.placements {
                            let m = pl.mesh_texel.map(|t| {
                                let pp = &pl.placed;
                                let centre =
                                    (tree.to_world * pp.to_parent).transform_point3(pp.centre);
                                let d = (input.eye - centre).length().max(1e-3);
                                let m = smoothstep(m_lo, m_hi, t * scale * ppm / d);
                                most = most.max(m);
                                if receives_in(pass, d, pp.radius * scale) {
                                    m
                                } else {
                                    0.0
                                }
                            });
                            part_mesh.push(m.unwrap_or(-1.0));
                        }
                        let rest = if receives_in(pass, dist, plant.radius * scale) {
                            most
                        } else {
                            0.0
                        };
                        for m in part_mesh.iter_mut() {
                            if *m < 0.0 {
                                *m = rest;
                            }
                            least = least.min(*m);
                        }
                        let opened = open.max(most);
                        if least * opened >= 0.998 {
                            whole = presence;
                        } else {
                            tree_bb = (1.0 - opened) * presence;
                            below = opened * presence;
                        }
                    } else {
                        let mesh = if with_meshes && receives_in(pass, dist, plant.radius * scale) {
                            smoothstep(m_lo, m_hi, plant.mesh_texel * scale * ppm / dist)
                        } else {
                            0.0
                        };
                        whole = mesh * presence;
                        tree_bb = (1.0 - open) * (1.0 - mesh) * presence;
                        below = open * (1.0 - mesh) * presence;
                        part_mesh.resize(plant.placements.len(), 0.0);
                    }
                    // Trees opened into BTFs only cast at the tree level.
                    if pass > 0 && !part_mesh.iter().any(|&m| m > 0.0) {
                        tree_bb += below;
                        below = 0.0;
                    }
                    if whole > 0.002 {
                        self.mesh_sort.push(mesh_record(WHOLE, whole, rec));
                    }
                    if pass == 0 && (whole > 0.002 || below > 0.002) {
                        self.opened += 1;
                        if whole > 0.002 || part_mesh.iter().any(|&m| m * below > 0.002) {
                            self.meshed += 1;
                        }
                    }
                    if pass > 0 {
                        if tree_bb > 0.002 {
                            let inst = caster(
                                &tree.to_world,
                                plant.tree_set,
                                self.views.lookup(to_model_dir(sun, c, sn)),
                                rec.rot[2],
                                tree_bb,
                                scale,
                                plant.radius * scale,
                            );
                            self.sort.push((0.0, inst));
                        }
                        if below > 0.002 {
                            for (j, pl) in plant.placements.iter().enumerate() {
                                let m = part_mesh[j] * below;
                                if m > 0.002 {
                                    self.mesh_sort.push(mesh_record(j as u32, m, rec));
                                }
                                if below - m <= 0.002 {
                                    continue;
                                }
                                let pp = &pl.placed;
                                let sun_object = (pp.from_parent * to_model_dir(sun, c, sn))
                                    .normalize_or(Vec3::Y);
                                let inst = caster(
                                    &(tree.to_world * pp.to_parent),
                                    pp.set,
                                    self.branch_views.lookup(sun_object),
                                    rec.rot[2],
                                    below - m,
                                    scale * pp.scale,
                                    pp.radius * scale,
                                );
                                self.sort.push((0.0, inst));
                            }
                        }
                        continue;
                    }
                    let (mut tree_sun, tree_sky) = match &self.scene {
                        Some(sc) => (unit8(sc.sun(id as usize)), unit8(sc.sky(id as usize))),
                        None => ([1.0; 8], [1.0; 8]),
                    };
                    if !cube_sun {
                        tree_sun = [1.0; 8];
                    }
                    let light_model = to_model_dir(light, c, sn);
                    if tree_bb > 0.002 {
                        // MNP01 §4.1: 3 view × 3 light samples, products of barycentrics.
                        let inst = billboard(
                            &tree.to_world,
                            plant.tree_set,
                            self.views.lookup(to_model_dir(eye, c, sn)),
                            self.lights.lookup(light_model),
                            p.min_weight,
                            (tree_sun, tree_sky),
                            rec.rot[2],
                            tree_bb,
                            scale,
                            plant.radius * scale,
                        );
                        self.sort.push((eye.length_squared(), inst));
                    }
                    if below <= 0.002 {
                        continue;
                    }
                    let sun_model = to_model_dir(sun, c, sn);
                    let res = plant.cube_resolution as usize;
                    for (j, pl) in plant.placements.iter().enumerate() {
                        let meshed = part_mesh[j] * below;
                        if meshed > 0.002 {
                            self.mesh_sort.push(mesh_record(j as u32, meshed, rec));
                            self.branches_meshed += 1;
                        }
                        let here = below - meshed;
                        if here <= 0.002 {
                            continue;
                        }
                        let pp = &pl.placed;
                        let to_world = tree.to_world * pp.to_parent;
                        let centre = to_world.transform_point3(pp.centre);
                        let eye_o = input.eye - centre;
                        let in_object = |d: Vec3| (pp.from_parent * d).normalize_or(Vec3::Y);
                        let (sun_vis, sky_vis) = pp.visibility(
                            (tree_sun, tree_sky),
                            |k| hb::cube_of(&plant.cubes, plant.cube_resolution, pl.index, k),
                            res,
                            cube_sun.then_some(sun_model),
                        );
                        // MNP01 §4 one level down: the main branch opens into its small
                        // branches when its own texels would be magnified.
                        let split = if pl.small.is_empty() {
                            0.0
                        } else {
                            let px = pl.texel * scale * ppm / eye_o.length().max(1e-3);
                            smoothstep(lo_px, hi_px, px)
                        };
                        if (1.0 - split) * here > 0.002 {
                            let mut inst = billboard(
                                &to_world,
                                pp.set,
                                self.branch_views
                                    .lookup(in_object(to_model_dir(eye_o, c, sn))),
                                self.branch_lights.lookup(in_object(light_model)),
                                p.min_weight,
                                (sun_vis, sky_vis),
                                rec.rot[2],
                                (1.0 - split) * here,
                                scale * pp.scale,
                                pp.radius * scale,
                            );
                            inst.lights[3] = 1;
                            self.sort.push((eye_o.length_squared(), inst));
                        }
                        if split * here <= 0.002 {
                            continue;
                        }
                        self.branches_opened += 1;
                        for index in pl.small.clone() {
                            let sd = &plant.small[index];
                            let to_world = to_world * sd.to_parent;
                            let centre = to_world.transform_point3(sd.centre);
                            let eye_s = input.eye - centre;
                            let to_small = sd.from_parent * pp.from_parent;
                            let in_small = |d: Vec3| (to_small * d).normalize_or(Vec3::Y);
                            // The three levels combined.
                            let (s_sun, s_sky) = sd.visibility(
                                (sun_vis, sky_vis),
                                |k| {
                                    hb::cube_of(&plant.small_cubes, plant.cube_resolution, index, k)
                                },
                                res,
                                cube_sun.then(|| in_object(sun_model)),
                            );
                            let mut inst = billboard(
                                &to_world,
                                sd.set,
                                self.branch_views
                                    .lookup(in_small(to_model_dir(eye_s, c, sn))),
                                self.branch_lights.lookup(in_small(light_model)),
                                p.min_weight,
                                (s_sun, s_sky),
                                rec.rot[2],
                                split * here,
                                scale * pp.scale * sd.scale,
                                sd.radius * pp.scale * scale,
                            );
                            inst.lights[3] = 2;
                            self.sort.push((eye_s.length_squared(), inst));
                        }
                    }
                }
            }
            // The meshes grouped by plant and part: one instanced draw per group.
            self.mesh_sort.sort_by_key(|m| (m.0, m.1));
            self.mesh_draws[pass].clear();
            for (plant, part, rec) in self.mesh_sort.iter().copied() {
                let at = self.mesh_staging.len() as u32;
                self.mesh_staging.push(rec);
                match self.mesh_draws[pass].last_mut() {
                    Some(d) if d.plant == plant as usize && d.part == part => {
                        d.instances.end = at + 1
                    }
                    _ => self.mesh_draws[pass].push(MeshDraw {
                        plant: plant as usize,
                        part,
                        instances: at..at + 1,
                    }),
                }
            }
            if pass == 0 {
                // MNP01 §5: back to front (trees and the objects of opened trees together).
                self.sort.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
            }
            let start = self.staging.len() as u32;
            self.staging.extend(self.sort.iter().map(|x| x.1));
            self.ranges[pass] = start..self.staging.len() as u32;
        }
        self.part_mesh = part_mesh;
        self.mesh_instances
            .write(gpu, bytemuck::cast_slice(&self.mesh_staging))?;
        self.instances
            .write(gpu, bytemuck::cast_slice(&self.staging))
    }
}

impl Technique for Hbt {
    fn name(&self) -> &'static str {
        super::ENTRY.name
    }

    fn prepare_frame(
        &mut self,
        gpu: &Gpu,
        _: &mut wgpu::CommandEncoder,
        input: &FrameInput<'_>,
    ) -> Result<(), RenderError> {
        self.update(gpu, input)
    }

    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts {
        self.record(pass, ctx, ctx.shadow_cascade().is_some())
    }

    /// `visibility_bytes` (CPU bytes of the cube-maps), `visibility_ms` (building the scene's),
    /// and this frame's `trees_opened`, `trees_meshed`, `branches_opened`, `branches_meshed`.
    fn stats(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("visibility_bytes", self.visibility_bytes() as f64),
            ("visibility_ms", self.visibility_build_ms()),
            ("trees_opened", self.opened as f64),
            ("trees_meshed", self.meshed as f64),
            ("branches_opened", self.branches_opened as f64),
            ("branches_meshed", self.branches_meshed as f64),
        ]
    }

    fn bytes(&self) -> u64 {
        self.static_bytes + self.instances.buffer.size() + self.mesh_instances.buffer.size()
    }

    fn reallocations(&self) -> u32 {
        self.instances.reallocations
    }
}

impl Hbt {
    fn record(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        ctx: &DrawContext<'_>,
        shadow: bool,
    ) -> DrawCounts {
        pass.set_bind_group(0, ctx.frame_bind, &[]);
        // Opaque first: the trees drawn as meshes, then the billboards over them.
        let mut counts = DrawCounts::default();
        if let Some(pipes) = &self.mesh_pipes {
            let (wood, leaf) = pipes.for_pass(shadow);
            for (pipeline, kind) in [(wood, 0), (leaf, 1)] {
                pass.set_pipeline(pipeline);
                for d in &self.mesh_draws[ctx.pass] {
                    let plant = &self.plants[d.plant];
                    let Some(meshes) = &plant.meshes else {
                        continue;
                    };
                    let Some(mesh) = (if kind == 0 {
                        &meshes.wood
                    } else {
                        &meshes.leaves
                    }) else {
                        continue;
                    };
                    let indices = match plant.parts.get(d.part as usize) {
                        Some(part) => part[kind].clone(),
                        None => 0..mesh.index_count,
                    };
                    pass.set_bind_group(1, &meshes.material, &[]);
                    counts += mesh.draw_range(
                        pass,
                        indices,
                        &self.mesh_instances.buffer,
                        d.instances.clone(),
                    );
                }
            }
        }
        let r = self.ranges[ctx.pass].clone();
        if r.is_empty() {
            return counts;
        }
        let quads = if !shadow && self.draw.projection == HbtProjection::Cross {
            3
        } else {
            1
        };
        pass.set_pipeline(if shadow {
            &self.shadow_pipeline
        } else {
            &self.pipeline
        });
        pass.set_bind_group(1, &self.bind, &[]);
        pass.set_vertex_buffer(1, self.instances.buffer.slice(..));
        let n = (r.end - r.start) as u64;
        pass.draw(0..quads * 6, r);
        counts += DrawCounts {
            draw_calls: 1,
            triangles: n * quads as u64 * 2,
        };
        counts
    }
}
