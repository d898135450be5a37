//! MNP01 §3.1/§3.3/§6.1: baking one plant's `hbt` asset — the tree's BTF (a lit,
//! self-shadowed billboard per (view sample, light sample) and two ambient billboards per view
//! sample), the levels below it with their BTFs and visibility cube-maps — and §4.1's
//! reconstruction weights. This file is the entry ([`HbtBake`], its `bake`); the parts
//! (private modules):
//! - `asset`: the asset types ([`HbtBaked`], [`ObjectBtf`], [`Placement`], [`SmallLevel`])
//!   and their codec;
//! - `btf`: the BTF bake of one object (views, lights, self-shadowing, ambient), the view
//!   frames and the reconstruction weights;
//! - `branches`: the levels below the tree ([`branch_level`], [`small_level`]);
//! - `cubes`: the branch placements' visibility cube-maps.

mod asset;
mod branches;
mod btf;
mod cubes;
pub mod switch;

pub use asset::{
    FORMAT_VERSION, HbtBaked, MAX_CUBE_RESOLUTION, Mips, ObjectBtf, Placement, REST_OBJECT,
    SmallLevel, cube_of,
};
pub(super) use branches::split_root;
pub use branches::{
    BranchLevel, SMALL_BRANCH_RATIO, branch_level, main_branches, object_plant, small_level,
};
pub(super) use btf::{downsample, per_view_images};
pub use btf::{reconstruction_weights, view_frame};
pub use cubes::coverage;

use super::HbtBakeParams;
use super::visibility;
use crate::RenderError;
use crate::directions::{DirectionLut, DirectionSet};
use btf::bake_btf;
use cubes::branch_cubes;
use glam::{Affine3A, Vec3};
use sylvan_gpu::Gpu;
use sylvan_plant::Plant;

/// `hbt`'s offline half (MNP01 §3.1, §3.3, §6.1): one plant's BTF levels and cube-maps.
pub struct HbtBake;

impl crate::bake::Bake for HbtBake {
    const NAME: &'static str = "hbt";
    const FORMAT_VERSION: u32 = FORMAT_VERSION;
    type Params = HbtBakeParams;
    type Asset = HbtBaked;

    fn check(b: &HbtBaked, plant: &Plant) -> Result<(), String> {
        let objects = plant.instancing.objects.len();
        let bounds = |lo: &[f32; 3], hi: &[f32; 3]| {
            lo.iter().chain(hi).all(|c| c.is_finite()) && (0..3).all(|a| lo[a] <= hi[a])
        };
        if !bounds(&b.bbox_min, &b.bbox_max) {
            return Err(format!("tree bounds {:?}–{:?}", b.bbox_min, b.bbox_max));
        }
        for (k, o) in b.objects.iter().chain(&b.small.objects).enumerate() {
            if o.object != REST_OBJECT && o.object as usize >= objects {
                return Err(format!(
                    "object {k} is base object {} of {objects}",
                    o.object
                ));
            }
            if !bounds(&o.bbox_min, &o.bbox_max) {
                return Err(format!(
                    "object {k} bounds {:?}–{:?}",
                    o.bbox_min, o.bbox_max
                ));
            }
        }
        Ok(())
    }

    fn describe(b: &HbtBaked) -> crate::bake::AssetSummary {
        let (tree_bytes, branch_bytes) = b.image_bytes();
        let cube_bytes = (b.cubes.len() + b.small.cubes.len()) as u64;
        let images = b.direct.len()
            + b.ambient.len()
            + b.objects
                .iter()
                .chain(&b.small.objects)
                .map(|o| o.direct.len() + o.ambient.len())
                .sum::<usize>();
        let mut fields = serde_json::Map::new();
        let mut put = |k: &str, v: serde_json::Value| {
            fields.insert(k.into(), v);
        };
        put("views", b.views().into());
        put("lights", b.lights().into());
        put("branch_objects", b.objects.len().into());
        put("branch_placements", b.placements.len().into());
        put("branch_fill", (b.branch_fill() as f64).into());
        if let Some(c) = b.switch_curve() {
            put(
                "mesh_switch_texel_px",
                (c.crossing_texel_pixels() as f64).into(),
            );
        }
        put("small_objects", b.small.objects.len().into());
        put("small_placements", b.small.placements.len().into());
        put("tree_bytes", tree_bytes.into());
        put("branch_bytes", branch_bytes.into());
        put("cube_bytes", cube_bytes.into());
        crate::bake::AssetSummary {
            line: format!(
                "{} views × {} lights + {} ambient images of {}² for the tree ({:.1} MB), {} branch objects for {} placements ({:.1} MB, cube-maps {:.2} MB), {images} images in all",
                b.views(),
                b.lights(),
                b.ambient.len(),
                b.tile,
                tree_bytes as f64 / 1e6,
                b.objects.len(),
                b.placements.len(),
                branch_bytes as f64 / 1e6,
                cube_bytes as f64 / 1e6,
            ),
            image_bytes: tree_bytes + branch_bytes + cube_bytes,
            images,
            tile: b.tile,
            fields,
        }
    }

    /// Bakes `plant`'s BTF (the top level) and, with `p.branches`, the level below
    /// ([`branch_level`]): each object's BTF over the branch direction sets, and each placement's
    /// visibility cube-maps. `progress(done, total)` counts rasterised views, light maps and lit
    /// views.
    fn bake(
        gpu: &Gpu,
        plant: &Plant,
        p: &HbtBakeParams,
        progress: &mut dyn FnMut(usize, usize),
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
        // Where, at this tile size, the meshes get closer to the reference than the billboard
        // (#15: the mesh switch measured in ꟻLIP, not assumed): used by a plant without main
        // branches, and by one whose level below costs more than its meshes
        // (`select::LevelCosts`). 2–5 s a plant.
        let (lo, hi) = (Vec3::from(plant.bbox_min), Vec3::from(plant.bbox_max));
        let c = switch::measure(gpu, plant, p.tile, |d| view_frame(d, lo, hi, p.tile))?;
        let switch_error = [c.billboard, c.meshes];
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
            switch_error,
        })
    }
}
