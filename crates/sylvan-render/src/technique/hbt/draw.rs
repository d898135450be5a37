//! The GPU side of `hbt`, per frame: each culled tree's levels ([`select`]), direction
//! look-ups and reconstruction weights (MNP01 §4.1) and visibility into sorted instance lists
//! ([`Hbt::update`]), and the passes ([`Hbt::record`]: the meshes, then the billboards). The
//! parts: [`prepare`] (building [`Hbt`]), [`gpu`] (the shader's records, the atlas and the
//! pipelines), [`select`] (the GPU-free level selection), [`gpu_frame`] (the GPU-driven frame:
//! the same selection and look-ups in compute passes over the world's culled lists, the
//! default; the CPU loop above serves `--cpu-driven`).

mod gpu;
mod gpu_frame;
pub(crate) use gpu_frame::select_source;
mod prepare;
mod select;

pub use select::LevelCosts;

use super::bake as hb;
use super::scene::{PlacedTree, SceneVisibility};
use super::{HbtDrawParams, HbtProjection, HbtShadows};
use crate::RenderError;
use crate::directions::DirectionLut;
use crate::frame::CASCADES;
use crate::instances::GpuTreeInstance;
use crate::technique::common::Growable;
use crate::technique::geometry::MeshPipelines;
use crate::technique::{DrawContext, DrawCounts, FrameInput, Technique};
use glam::Vec3;
use gpu::{GpuHbtInstance, billboard, caster};
use prepare::PlantDraw;
use std::ops::Range;
use sylvan_gpu::Gpu;

const PASSES: usize = 1 + CASCADES;

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
    /// The GPU-driven frame (made at the first frame fed by the world's cull).
    gpu_frame: Option<gpu_frame::HbtGpuFrame>,
    opened: u32,
    meshed: u32,
    branches_opened: u32,
    branches_meshed: u32,
    /// Plants whose level below was skipped as dearer than their meshes
    /// ([`select::LevelCosts`]).
    levels_below_skipped: usize,
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
}

/// World direction → model space of a tree rotated by (cos, sin) about Y.
fn to_model_dir(d: Vec3, c: f32, s: f32) -> Vec3 {
    Vec3::new(c * d.x - s * d.z, d.y, s * d.x + c * d.z)
}

fn unit8(v: [u8; 8]) -> [f32; 8] {
    v.map(|x| x as f32 / 255.0)
}

impl Technique for Hbt {
    fn name(&self) -> &'static str {
        super::ENTRY.name
    }

    /// Per frame: each culled tree's levels, direction look-ups and visibility, sorted and
    /// uploaded.
    fn prepare_frame(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        input: &FrameInput<'_>,
    ) -> Result<(), RenderError> {
        if let Some(culled) = input.culled.first() {
            if self.gpu_frame.is_none() {
                let small = self.plants.iter().any(|p| !p.small.is_empty());
                if let Some(option) = gpu_frame::supports(&self.draw, small) {
                    return Err(RenderError::Option(format!(
                        "{option}: hbt's GPU-driven frame opens a tree as a whole, facing the eye, with sun shadows from the cascades — pass --cpu-driven to draw it on the CPU"
                    )));
                }
                self.gpu_frame = Some(gpu_frame::HbtGpuFrame::new(
                    gpu,
                    &self.plants,
                    &self.species_plant,
                    [
                        &self.views,
                        &self.lights,
                        &self.branch_views,
                        &self.branch_lights,
                    ],
                    &self.draw,
                )?);
            }
            let frame = self.gpu_frame.as_mut().expect("made above");
            return frame.record(gpu, encoder, culled, input, &self.draw);
        }
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
        let open = select::Switch::new(p.open_texel_pixels, p.band);
        let ppm = input.pixels_per_metre;
        let mut part_mesh = std::mem::take(&mut self.part_mesh);
        for pass in 0..PASSES {
            self.sort.clear();
            self.mesh_sort.clear();
            for (s, &pi) in self.species_plant.iter().enumerate() {
                let plant = &self.plants[pi];
                let records = input.instances.records(pass, s);
                let ids = input.instances.ids(pass, s);
                let lod = select::PlantLod {
                    texel: plant.texel,
                    mesh_texel: plant.mesh_texel,
                    radius: plant.radius,
                    placements: plant.placements.len(),
                    per_branch: !plant.parts.is_empty(),
                    open,
                    mesh: select::Switch::new(plant.mesh_pixels, p.band),
                };
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
                    // Branch by branch, each placement's own mesh switch (its lowest BTF texel at
                    // its distance); `select` evaluates them only when it opens by parts.
                    let parts = plant.placements.iter().map(|pl| {
                        pl.mesh_texel.map(|texel| {
                            let pp = &pl.placed;
                            let centre = (tree.to_world * pp.to_parent).transform_point3(pp.centre);
                            let d = (input.eye - centre).length().max(1e-3);
                            select::PartAt {
                                texel,
                                dist: d,
                                meshes_here: receives_in(pass, d, pp.radius * scale),
                            }
                        })
                    });
                    let at = select::TreeAt {
                        presence,
                        scale,
                        dist,
                        pixels_per_metre: ppm,
                        meshes: with_meshes,
                        meshes_here: receives_in(pass, dist, plant.radius * scale),
                        shadow: pass > 0,
                    };
                    let shares = select::select(&lod, &at, parts, &mut part_mesh);
                    let (whole, tree_bb, below) = (shares.meshes, shares.tree, shares.below);
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
                        let split = select::open_share(
                            open,
                            !pl.small.is_empty(),
                            select::texel_pixels(pl.texel, scale, ppm, eye_o.length().max(1e-3)),
                        );
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

    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts {
        self.record(pass, ctx, ctx.shadow_cascade().is_some())
    }

    /// `visibility_bytes` (CPU bytes of the cube-maps), `visibility_ms` (building the scene's),
    /// and this frame's `trees_opened`, `trees_meshed`, `branches_opened`, `branches_meshed`.
    fn stats(&self) -> Vec<(&'static str, f64)> {
        if let Some(f) = &self.gpu_frame {
            // The GPU-driven frame's counts, read back after the frame (or a frame late).
            let (opened, meshed) = f.opened_meshed();
            return vec![
                ("visibility_bytes", self.visibility_bytes() as f64),
                (
                    "plants_without_branch_level",
                    self.levels_below_skipped as f64,
                ),
                ("trees_opened", opened as f64),
                ("trees_meshed", meshed as f64),
                // Neither opens on the GPU-driven frame (no small branches, no per-branch
                // meshes).
                ("branches_opened", 0.0),
                ("branches_meshed", 0.0),
                ("billboards", f.billboards(0) as f64),
                ("records_dropped", f.dropped as f64),
                ("list_growths", f.reallocations as f64),
            ];
        }
        vec![
            ("visibility_bytes", self.visibility_bytes() as f64),
            ("visibility_ms", self.visibility_build_ms()),
            (
                "plants_without_branch_level",
                self.levels_below_skipped as f64,
            ),
            ("trees_opened", self.opened as f64),
            ("trees_meshed", self.meshed as f64),
            ("branches_opened", self.branches_opened as f64),
            ("branches_meshed", self.branches_meshed as f64),
        ]
    }

    fn bytes(&self) -> u64 {
        self.static_bytes
            + self.instances.buffer.size()
            + self.mesh_instances.buffer.size()
            + self
                .gpu_frame
                .as_ref()
                .map_or(0, gpu_frame::HbtGpuFrame::bytes)
    }

    fn reallocations(&self) -> u32 {
        self.instances.reallocations + self.gpu_frame.as_ref().map_or(0, |f| f.reallocations)
    }

    /// One draw per species drawing nothing: the selection reads each list's count from
    /// these arguments.
    fn indirect_draws(&self) -> Vec<crate::world::IndirectDraw> {
        (0..self.species_plant.len() as u32)
            .map(|s| crate::world::IndirectDraw::vertices(s, 0))
            .collect()
    }

    fn finish_frame(&mut self, gpu: &Gpu) -> Result<bool, RenderError> {
        match &mut self.gpu_frame {
            Some(f) => f.finish(gpu),
            None => Ok(false),
        }
    }

    fn own_triangles(&self, pass: usize) -> u64 {
        let Some(f) = &self.gpu_frame else { return 0 };
        let mut tris = f.billboards(pass) as u64 * 2;
        for (s, &pi) in self.species_plant.iter().enumerate() {
            let Some(m) = &self.plants[pi].meshes else {
                continue;
            };
            let per_tree = [&m.wood, &m.leaves]
                .iter()
                .map(|g| g.as_ref().map_or(0, |g| g.index_count as u64 / 3))
                .sum::<u64>();
            tris += f.meshes(pass, s) as u64 * per_tree;
        }
        tris
    }
}

impl Hbt {
    fn record(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        ctx: &DrawContext<'_>,
        shadow: bool,
    ) -> DrawCounts {
        if let (Some(_), Some(f)) = (ctx.culled.first(), &self.gpu_frame) {
            return self.record_indirect(pass, ctx, f, shadow);
        }
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

    /// The GPU-driven pass: the trees drawn as meshes, then the billboards, from the
    /// selection's lists, every draw indirect (the counts are the last frame's read back).
    fn record_indirect(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        ctx: &DrawContext<'_>,
        f: &gpu_frame::HbtGpuFrame,
        shadow: bool,
    ) -> DrawCounts {
        let mut counts = DrawCounts::default();
        let p = ctx.pass;
        pass.set_bind_group(0, ctx.frame_bind, &[]);
        if let Some(pipes) = &self.mesh_pipes {
            let (wood, leaf) = pipes.for_pass(shadow);
            for (pipeline, leaves) in [(wood, false), (leaf, true)] {
                pass.set_pipeline(pipeline);
                for (s, &pi) in self.species_plant.iter().enumerate() {
                    let Some(meshes) = &self.plants[pi].meshes else {
                        continue;
                    };
                    let Some(mesh) = (if leaves { &meshes.leaves } else { &meshes.wood }) else {
                        continue;
                    };
                    pass.set_bind_group(1, &meshes.material, &[]);
                    pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                    pass.set_vertex_buffer(1, f.out_mesh.slice(..));
                    pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                    let (args, offset) = f.mesh_args(p, s, leaves);
                    pass.draw_indexed_indirect(args, offset);
                    counts.draw_calls += 1;
                }
            }
        }
        pass.set_pipeline(if shadow {
            &self.shadow_pipeline
        } else {
            &self.pipeline
        });
        pass.set_bind_group(1, &self.bind, &[]);
        pass.set_vertex_buffer(1, f.out_bb.slice(..));
        let (args, offset) = f.billboard_args(p);
        pass.draw_indirect(args, offset);
        counts.draw_calls += 1;
        counts.triangles = self.own_triangles(p);
        counts
    }
}
