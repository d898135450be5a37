//! The GPU side of `octahedral`: atlas and view upload, the per-frame instance list (camera
//! pass sorted back to front), and the passes.

use super::bake::{self as oct, OctahedralBaked};
use super::{OctahedralBakeParams, OctahedralDrawParams, SHADOW_OFFSET};
use crate::RenderError;
use crate::bake::image::TileLevel;
use crate::frame::{CASCADES, FrameResources};
use crate::instances::GpuTreeInstance;
use crate::technique::common::{self, Growable, TileAtlas};
use crate::technique::geometry::LEAF_TRANSLUCENCY;
use crate::technique::{DrawContext, DrawCounts, FrameInput, Technique};
use crate::world::{IndirectDraw, ListLayout};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::ops::Range;
use sylvan_gpu::{Gpu, layout};
use sylvan_plant::Plant;
use wgpu::util::DeviceExt;

const PASSES: usize = 1 + CASCADES;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuOctSpecies {
    centre_radius: [f32; 4],
    bbox_min: [f32; 4],
    bbox_max: [f32; 4],
    info: [u32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuOctView {
    u: [f32; 4],
    v: [f32; 4],
    f: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuOctAtlas {
    tiles: [u32; 4],
    params: [f32; 4],
    draw: [f32; 4],
}

/// The prepared hemi-octahedral impostor technique.
pub struct Octahedral {
    /// Per species: the model-space centre of its frames (for the back-to-front sort).
    centres: Vec<Vec3>,
    pipeline: wgpu::RenderPipeline,
    shadow_pipeline: wgpu::RenderPipeline,
    bind: wgpu::BindGroup,
    static_bytes: u64,
    // Per frame (reused; nothing is allocated once the vectors have grown).
    instances: Growable,
    /// Records as the GPU cull lists them: `rot.z` is species + tint seed.
    staging: Vec<GpuTreeInstance>,
    sort: Vec<(f32, GpuTreeInstance)>,
    ranges: [Range<u32>; PASSES],
}

/// The grid's view frames (image axes; shared by every species, whose frames differ only by
/// centre and radius).
fn views(grid: u32) -> Vec<GpuOctView> {
    (0..grid * grid)
        .map(|k| {
            let d = oct::grid_direction(grid, k % grid, k / grid);
            let f = crate::bake::views::PlaneFrame::for_sphere(d, Vec3::ZERO, 1.0);
            GpuOctView {
                u: f.u.extend(0.0).to_array(),
                v: f.v.extend(0.0).to_array(),
                f: f.f.extend(0.0).to_array(),
            }
        })
        .collect()
}

impl Octahedral {
    /// Uploads every species' views into one atlas and builds the pipelines.
    pub fn new(
        gpu: &Gpu,
        frame: &FrameResources,
        plants: &[Plant],
        baked: &[OctahedralBaked],
        bake: &OctahedralBakeParams,
        draw: &OctahedralDrawParams,
    ) -> Result<Self, RenderError> {
        let (grid, tile) = (bake.grid, bake.tile);
        if baked.len() != plants.len() {
            return Err(RenderError::Plant(format!(
                "{} octahedral bakes for {} plants",
                baked.len(),
                plants.len()
            )));
        }
        let mut species = Vec::with_capacity(plants.len());
        let mut tiles: Vec<&Vec<TileLevel>> = Vec::new();
        for (plant, b) in plants.iter().zip(baked) {
            if b.grid != grid || b.tile != tile {
                return Err(RenderError::Plant(format!(
                    "{}: octahedral bake has grid {} tile {}, the parameters grid {grid} tile {tile} — re-bake",
                    plant.name, b.grid, b.tile
                )));
            }
            species.push(GpuOctSpecies {
                centre_radius: Vec3::from(b.centre).extend(b.radius).to_array(),
                bbox_min: Vec3::from(plant.bbox_min).extend(0.0).to_array(),
                bbox_max: Vec3::from(plant.bbox_max).extend(0.0).to_array(),
                info: [tiles.len() as u32, 0, 0, 0],
            });
            tiles.extend(b.tiles.iter());
        }
        let upload = |label, format, data: Vec<Vec<Vec<u8>>>| {
            let refs: Vec<&[Vec<u8>]> = data.iter().map(Vec::as_slice).collect();
            TileAtlas::upload(gpu, label, format, tile, &refs)
        };
        let color = upload(
            "octahedral_atlas_color",
            wgpu::TextureFormat::Rgba8UnormSrgb,
            common::tile_chains(&tiles, |l| &l.color),
        )?;
        let normal = upload(
            "octahedral_atlas_normal",
            wgpu::TextureFormat::Rgba8Unorm,
            common::tile_chains(&tiles, |l| &l.normal),
        )?;
        let atlas = GpuOctAtlas {
            tiles: [tile, color.per_row, color.per_layer, grid],
            params: [
                LEAF_TRANSLUCENCY,
                1.0 / color.per_row as f32,
                1.0 / color.rows as f32,
                0.0,
            ],
            draw: [
                draw.parallax_steps as f32,
                draw.views as f32,
                SHADOW_OFFSET,
                f32::from(u8::from(draw.tight_casters)),
            ],
        };
        let device = &gpu.device;
        let storage = |label, contents: &[u8]| common::storage_buffer(gpu, label, contents);
        let species_buffer = storage("octahedral_species", bytemuck::cast_slice(&species));
        let view_buffer = storage("octahedral_views", bytemuck::cast_slice(&views(grid)));
        let atlas_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("octahedral_atlas"),
            contents: bytemuck::bytes_of(&atlas),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let sampler = common::trilinear_sampler(gpu, "octahedral_sampler");
        let vf = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let bind_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("octahedral_layout"),
            entries: &[
                layout::storage(0, vf),
                layout::storage(1, vf),
                layout::atlas(2),
                layout::atlas(3),
                layout::sampler(
                    4,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::SamplerBindingType::Filtering,
                ),
                layout::uniform(5, vf),
            ],
        });
        let (cv, nv) = (color.view(), normal.view());
        let bind = common::bind_group(
            gpu,
            "octahedral_bind",
            &bind_layout,
            &[
                species_buffer.as_entire_binding(),
                view_buffer.as_entire_binding(),
                wgpu::BindingResource::TextureView(&cv),
                wgpu::BindingResource::TextureView(&nv),
                wgpu::BindingResource::Sampler(&sampler),
                atlas_buffer.as_entire_binding(),
            ],
        );
        let module = sylvan_gpu::shader(gpu, "octahedral", &super::shader_source());
        let (pipeline, shadow_pipeline) = common::image_pipelines(
            gpu,
            frame,
            &module,
            "octahedral",
            &[None, Some(GpuTreeInstance::LAYOUT)],
            &bind_layout,
        );
        let static_bytes = color.bytes
            + normal.bytes
            + species_buffer.size()
            + view_buffer.size()
            + atlas_buffer.size();
        Ok(Self {
            centres: baked.iter().map(|b| Vec3::from(b.centre)).collect(),
            pipeline,
            shadow_pipeline,
            bind,
            static_bytes,
            instances: Growable::new(gpu, "octahedral_instances", 1 << 16),
            staging: Vec::new(),
            sort: Vec::new(),
            ranges: std::array::from_fn(|_| 0..0),
        })
    }
}

impl Technique for Octahedral {
    fn name(&self) -> &'static str {
        super::ENTRY.name
    }

    /// Per frame: every culled tree's quad, the camera pass sorted back to front, uploaded.
    fn prepare_frame(
        &mut self,
        gpu: &Gpu,
        _: &mut wgpu::CommandEncoder,
        input: &FrameInput<'_>,
    ) -> Result<(), RenderError> {
        common::mixed_lists(
            input,
            &self.centres,
            true,
            &mut self.sort,
            &mut self.staging,
            &mut self.ranges,
        );
        self.instances
            .write(gpu, bytemuck::cast_slice(&self.staging))
    }

    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts {
        let pipeline = match ctx.shadow_cascade() {
            None => &self.pipeline,
            Some(_) => &self.shadow_pipeline,
        };
        self.record(pass, ctx, pipeline)
    }

    fn bytes(&self) -> u64 {
        self.static_bytes + self.instances.buffer.size()
    }

    /// Six vertices per tree from each pass's one list.
    fn indirect_draws(&self) -> Vec<IndirectDraw> {
        vec![IndirectDraw::vertices(0, 6)]
    }

    /// One list of every species per pass, the camera's back to front.
    fn list_layout(&self) -> ListLayout {
        ListLayout {
            per_species: false,
            sort_camera: true,
        }
    }

    fn reallocations(&self) -> u32 {
        self.instances.reallocations
    }
}

impl Octahedral {
    /// One instanced draw of every tree of every species in this pass.
    fn record(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        ctx: &DrawContext<'_>,
        pipeline: &wgpu::RenderPipeline,
    ) -> DrawCounts {
        if let Some(culled) = ctx.culled.first() {
            let Some(instances) = culled.instances(ctx.pass, 0) else {
                return DrawCounts::default();
            };
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, ctx.frame_bind, &[]);
            pass.set_bind_group(1, &self.bind, &[]);
            pass.set_vertex_buffer(1, instances);
            let (args, offset) = culled.args(ctx.pass, 0);
            pass.draw_indirect(args, offset);
            return DrawCounts {
                draw_calls: 1,
                triangles: culled.listed(ctx.pass, 0) as u64 * 2,
            };
        }
        let r = self.ranges[ctx.pass].clone();
        if r.is_empty() {
            return DrawCounts::default();
        }
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, ctx.frame_bind, &[]);
        pass.set_bind_group(1, &self.bind, &[]);
        pass.set_vertex_buffer(1, self.instances.buffer.slice(..));
        let n = (r.end - r.start) as u64;
        pass.draw(0..6, r);
        DrawCounts {
            draw_calls: 1,
            triangles: n * 2,
        }
    }
}
