//! Preparing `hbt`: [`Hbt::new`] uploads every species' BTF levels (through [`SetSink`]) and
//! readies each distinct plant for the per-frame loop ([`PlantDraw`]: its levels' texel sizes,
//! placements with their visibility, meshes), and [`Hbt::place`] builds the scene's
//! visibility cube-maps (MNP01 §3.3's top level).

use super::gpu::{BillboardGpu, GpuHbtSet, SetSink};
use super::{Hbt, select};
use crate::RenderError;
use crate::directions::{DirectionLut, DirectionSet};
use crate::frame::FrameResources;
use crate::instances::Instances;
use crate::technique::common::Growable;
use crate::technique::geometry::{MeshPipelines, SpeciesMeshes};
use crate::technique::hbt::bake::{self as hb, HbtBaked};
use crate::technique::hbt::scene::{PlacedTree, SceneVisibility, trilinear};
use crate::technique::hbt::visibility;
use crate::technique::hbt::{HbtBakeParams, HbtDrawParams};
use glam::{Affine3A, Vec3};
use std::ops::Range;
use sylvan_gpu::Gpu;
use sylvan_plant::Plant;
use sylvan_scene::Terrain;

/// An object placed in its parent (a main branch in the tree, a small branch in its main
/// branch), ready for the per-frame loop.
pub(super) struct Placed {
    pub(super) set: u32,
    pub(super) to_parent: Affine3A,
    /// Linear part of parent → object (directions).
    pub(super) from_parent: glam::Mat3A,
    pub(super) scale: f32,
    /// Object box centre (object space) and radius in the parent's units.
    pub(super) centre: Vec3,
    pub(super) radius: f32,
    /// Its corners in [0, 1]³ of the parent's box (to interpolate the parent's visibility).
    pub(super) corners_in_parent: [Vec3; 8],
    /// Sky transmittance at each corner from the rest of the parent.
    pub(super) sky: [f32; 8],
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
    pub(super) fn visibility<'c>(
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
pub(super) struct PlacementDraw {
    pub(super) placed: Placed,
    /// Index of the placement in its plant's baked cube-maps.
    pub(super) index: usize,
    /// Texel side of its object per unit tree scale: it opens into its small branches when
    /// that would be magnified.
    pub(super) texel: f32,
    /// Its object's small-branch placements (indices into [`PlantDraw::small`]; empty: it
    /// does not open).
    pub(super) small: Range<usize>,
    /// Texel side of its lowest BTF level per unit tree scale (its own, or its small
    /// branches'): its meshes open when that would be magnified. `None` for the rest object
    /// and small parts ([`SMALL_PART_TRIANGLES`]), whose meshes open with the first branch's.
    pub(super) mesh_texel: Option<f32>,
}

/// With [`HbtDrawParams::mesh_per_branch`], a placement whose meshes have fewer triangles than
/// this opens into them with the rest (the first branch to open), not by its own texel: a
/// bracket of a few leaf cards costs more as a billboard than as its triangles. Measured on the
/// default view at 1280×720 (87 of the pine's 117 placements; every one of the prunus's and
/// the bush's, which then keep their own texels): ꟻLIP 0.0446 against 0.0488, frame
/// 1480 ms against 1716 ms (BENCHMARKS.md).
const SMALL_PART_TRIANGLES: usize = 64;

/// A distinct baked plant, ready to draw.
pub(super) struct PlantDraw {
    pub(super) tree_set: u32,
    pub(super) min: Vec3,
    pub(super) max: Vec3,
    pub(super) radius: f32,
    /// Tree-level texel size per unit scale (model metres).
    pub(super) texel: f32,
    /// Texel size of the level drawn just above the meshes (the largest main branch's, or the
    /// tree's without a level below), per unit scale: the meshes open when it is magnified.
    pub(super) mesh_texel: f32,
    /// The pixels per `mesh_texel` at which the meshes open: `mesh_texel_pixels`, or without a
    /// level below `open_texel_pixels` (the tree level is replaced where it would be magnified;
    /// the branches' earlier switch has no meaning for it); for a plant without main branches
    /// (with [`HbtDrawParams::measured_switch`]) the crossing measured at bake time.
    pub(super) mesh_pixels: f32,
    /// The plant's own meshes (MNP01 §4's polygonal bottom level; with `levels` = 3), indices
    /// grouped by placement when `parts` is not empty.
    pub(super) meshes: Option<SpeciesMeshes>,
    /// Per placement, its ranges of the wood and leaf indices (empty: the tree opens into its
    /// meshes as a whole, [`HbtDrawParams::mesh_per_branch`] off or no parts found).
    pub(super) parts: Vec<[Range<u32>; 2]>,
    pub(super) placements: Vec<PlacementDraw>,
    /// Index of its bake in `prepare`'s list (species with equal bakes share one entry).
    pub(super) source: usize,
    /// The tree level's ambient images (their alpha is the coverage the scene's cube-maps need).
    pub(super) ambient: Vec<hb::Mips>,
    /// The branch placements' cube-maps ([`HbtBaked::cubes`]) and their side.
    pub(super) cubes: Vec<u8>,
    /// MNP01 §7's small branches, by small placement ([`hb::SmallLevel::placements`]), and
    /// their cube-maps.
    pub(super) small: Vec<Placed>,
    pub(super) small_cubes: Vec<u8>,
    pub(super) cube_resolution: u32,
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
        let mut skipped = 0;
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
            let rest_only = b.objects.iter().all(|o| o.object == hb::REST_OBJECT);
            // A level below that costs more than the plant's meshes where the tree opens is
            // dominated (the meshes are nearer the reference and cheaper): the plant goes
            // from its billboard to its meshes at the measured crossing, as a plant without
            // main branches does (#15: levels chosen from what they cost).
            let switch_measured = params.measured_switch && params.levels >= 3;
            let triangles = plant.wood.triangle_count() + plant.leaves.triangle_count();
            let dominated = switch_measured
                && !rest_only
                && !params.mesh_per_branch
                && b.switch_curve().is_some()
                && select::LevelCosts::LAVAPIPE.below_costs_more(
                    b,
                    triangles,
                    params.open_texel_pixels,
                );
            let measured = switch_measured && (rest_only || dominated);
            skipped += usize::from(measured && dominated);
            // Then its level below is never drawn: not uploaded either.
            let tree_set = out.add(&views, lights.len(), (min, max), &b.direct, &b.ambient);
            let mut placements = Vec::new();
            let mut small = Vec::new();
            if params.levels >= 2 && !measured {
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
            // A plant without main branches (its level below is its rest alone: an imported
            // mesh) has nothing between its tree billboard and its meshes; they open where
            // they were measured to get closer to the reference than the billboard (#15).
            let (texel, mesh_texel) = match measured {
                true => (b.tree_texel(), b.tree_texel()),
                false => (b.tree_texel(), b.mesh_texel()),
            };
            let mesh_pixels = match b.switch_curve().filter(|_| measured) {
                // Without its level below, a plant's meshes open no later than they did below
                // it (the billboard is coarser than the level it replaces): the earlier of the
                // crossing and the branch switch, in tree texels.
                Some(c) if dominated => c
                    .crossing_texel_pixels()
                    .min(b.tree_texel() / b.mesh_texel() * params.mesh_texel_pixels),
                Some(c) => c.crossing_texel_pixels(),
                None => select::mesh_pixels(params, !placements.is_empty()),
            };
            // Branch by branch: the plant's meshes with each placement's triangles together.
            let split = match &mesh_pipes {
                Some(_) if params.mesh_per_branch && !placements.is_empty() => {
                    crate::technique::hbt::parts::placement_meshes(plant, placements.len()).ok()
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
                mesh_pixels,
                meshes,
                parts: split.map_or_else(Vec::new, |s| s.parts),
                placements,
                source: index,
                ambient: b.ambient.clone(),
                cubes: if measured {
                    Vec::new()
                } else {
                    b.cubes.clone()
                },
                cube_resolution: b.cube_resolution,
                small,
                small_cubes: if measured {
                    Vec::new()
                } else {
                    b.small.cubes.clone()
                },
            });
        }
        let billboards = BillboardGpu::new(gpu, frame, tile, &tiles, &sets, &frames, params)?;
        let static_bytes = billboards.bytes
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
            pipeline: billboards.pipeline,
            shadow_pipeline: billboards.shadow_pipeline,
            bind: billboards.bind,
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
            gpu_frame: None,
            opened: 0,
            meshed: 0,
            branches_opened: 0,
            branches_meshed: 0,
            levels_below_skipped: skipped,
        })
    }

    /// MNP01 §3.3's top level: builds every placed tree's visibility cube-maps against the
    /// other trees and `terrain` (with
    /// [`HbtShadows::CubeMaps`](crate::technique::hbt::HbtShadows::CubeMaps); otherwise
    /// nothing).
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
