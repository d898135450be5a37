//! The GPU side of `zfield`: the three atlases (albedo, normal, z-field) and the grid's view
//! frames uploaded once, the per-frame instance list (CPU-driven frames only), and the passes.

use super::bake::ZFieldBaked;
use super::{ZFieldBakeParams, ZFieldDrawParams};
use crate::RenderError;
use crate::directions::HemiGrid;
use crate::frame::{CASCADES, FrameResources};
use crate::instances::GpuTreeInstance;
use crate::pipeline::{self, PassKind, PipelineSpec};
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
struct GpuZSpecies {
    centre_radius: [f32; 4],
    bbox_min: [f32; 4],
    bbox_max: [f32; 4],
    info: [u32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuZView {
    u: [f32; 4],
    v: [f32; 4],
    f: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuZParams {
    tiles: [u32; 4],
    atlas: [f32; 4],
    sun: [f32; 4],
    sky: [f32; 4],
    extra: [f32; 4],
    more: [f32; 4],
}

/// The prepared z-field technique.
pub struct ZField {
    pipeline: wgpu::RenderPipeline,
    shadow_pipeline: wgpu::RenderPipeline,
    bind: wgpu::BindGroup,
    /// The forest field's group 2 (BN12 §7: lighting towards its means, the fade into it),
    /// when the chain ends in one.
    field: Option<wgpu::BindGroup>,
    static_bytes: u64,
    /// Per species: the model-space centre of its frames (the back-to-front sort of `blend`).
    centres: Vec<Vec3>,
    blend: bool,
    // Per frame, CPU-driven frames only (reused; nothing is allocated once grown).
    instances: Growable,
    staging: Vec<GpuTreeInstance>,
    sort: Vec<(f32, GpuTreeInstance)>,
    ranges: [Range<u32>; PASSES],
}

/// The grid's view frames (image axes; shared by every species, whose frames differ only by
/// centre and radius).
fn view_frames(grid: HemiGrid) -> Vec<GpuZView> {
    grid.directions()
        .into_iter()
        .map(|d| {
            let f = crate::bake::views::PlaneFrame::for_sphere(d, Vec3::ZERO, 1.0);
            GpuZView {
                u: f.u.extend(0.0).to_array(),
                v: f.v.extend(0.0).to_array(),
                f: f.f.extend(0.0).to_array(),
            }
        })
        .collect()
}

/// `zfield`'s bind group 1 (`bindings.wgsl`): every species' atlases, the grid's view frames
/// and the parameters, uploaded once. Shared by the technique's passes and by the passes that
/// measure z-field forest patches (`shadermap`'s tables).
pub(crate) struct ZFieldBindings {
    /// The group's layout.
    pub(crate) layout: wgpu::BindGroupLayout,
    /// The group.
    pub(crate) bind: wgpu::BindGroup,
    /// GPU bytes of the atlases and buffers.
    pub(crate) bytes: u64,
}

impl ZFieldBindings {
    /// Uploads every species' views into the atlases. `density` is the tree density Λ_h of
    /// eq. 9 (trees per m²).
    pub(crate) fn upload(
        gpu: &Gpu,
        plants: &[Plant],
        baked: &[ZFieldBaked],
        bake: &ZFieldBakeParams,
        draw: &ZFieldDrawParams,
        density: f32,
    ) -> Result<Self, RenderError> {
        let (order, tile) = (bake.order, bake.tile);
        let grid = HemiGrid::new(order)
            .ok_or_else(|| RenderError::Option(format!("zfield order {order}")))?;
        if baked.len() != plants.len() {
            return Err(RenderError::Plant(format!(
                "{} zfield bakes for {} plants",
                baked.len(),
                plants.len()
            )));
        }
        let mut species = Vec::with_capacity(plants.len());
        let (mut color, mut normal, mut zfield) = (Vec::new(), Vec::new(), Vec::new());
        for (plant, b) in plants.iter().zip(baked) {
            if b.order != order || b.tile != tile || b.views.len() != grid.len() {
                return Err(RenderError::Plant(format!(
                    "{}: zfield bake has order {} tile {}, the parameters order {order} tile {tile} — re-bake",
                    plant.name, b.order, b.tile
                )));
            }
            species.push(GpuZSpecies {
                centre_radius: Vec3::from(b.centre).extend(b.radius).to_array(),
                bbox_min: Vec3::from(plant.bbox_min).extend(0.0).to_array(),
                bbox_max: Vec3::from(plant.bbox_max).extend(0.0).to_array(),
                info: [color.len() as u32, 0, 0, 0],
            });
            for v in &b.views {
                color.push(v.levels.iter().map(|l| l.color.clone()).collect::<Vec<_>>());
                normal.push(
                    v.levels
                        .iter()
                        .map(|l| l.normal.clone())
                        .collect::<Vec<_>>(),
                );
                zfield.push(v.zfield.clone());
            }
        }
        let upload = |label, format, data: &[Vec<Vec<u8>>]| {
            let refs: Vec<&[Vec<u8>]> = data.iter().map(Vec::as_slice).collect();
            TileAtlas::upload(gpu, label, format, tile, &refs)
        };
        let color = upload(
            "zfield_atlas_color",
            wgpu::TextureFormat::Rgba8UnormSrgb,
            &color,
        )?;
        let normal = upload(
            "zfield_atlas_normal",
            wgpu::TextureFormat::Rgba8Unorm,
            &normal,
        )?;
        let zfield = upload(
            "zfield_atlas_zfield",
            wgpu::TextureFormat::Rgba8Unorm,
            &zfield,
        )?;
        let params = GpuZParams {
            tiles: [tile, color.per_row, color.per_layer, order],
            atlas: [
                1.0 / color.per_row as f32,
                1.0 / color.rows as f32,
                LEAF_TRANSLUCENCY,
                if draw.opacity_scaled_tau { 1.0 } else { 0.0 },
            ],
            sun: [draw.tau, draw.sun_scale, draw.a1, draw.a2],
            sky: [
                draw.sky_scale,
                density,
                draw.normal_weight,
                if draw.per_tree_masks { 1.0 } else { 0.0 },
            ],
            extra: [
                draw.lod_bias,
                f32::from(u8::from(draw.density_per_ha > 0.0)),
                // Soft casters: a tree's light entry point leaves its own crown out of the
                // cascades' translucent sums (it is in them only when it casts there).
                f32::from(u8::from(draw.shadow_opacity)),
                f32::from(u8::from(draw.tight_casters)),
            ],
            more: [draw.sky_normal_weight, 0.0, 0.0, 0.0],
        };
        let device = &gpu.device;
        let storage = |label, contents: &[u8]| common::storage_buffer(gpu, label, contents);
        let species_buffer = storage("zfield_species", bytemuck::cast_slice(&species));
        let view_buffer = storage("zfield_views", bytemuck::cast_slice(&view_frames(grid)));
        let params_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("zfield_params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let sampler = common::trilinear_sampler(gpu, "zfield_sampler");
        // Compute too: `shadermap`'s table measurement evaluates z-field light rays in a
        // compute pass with this group.
        let all = wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE;
        let atlas = |binding| {
            layout::texture(
                binding,
                all,
                wgpu::TextureSampleType::Float { filterable: true },
                wgpu::TextureViewDimension::D2Array,
            )
        };
        let bind_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("zfield_layout"),
            entries: &[
                layout::storage(0, all),
                layout::storage(1, all),
                atlas(2),
                atlas(3),
                atlas(4),
                layout::sampler(5, all, wgpu::SamplerBindingType::Filtering),
                layout::uniform(6, all),
            ],
        });
        let (cv, nv, zv) = (color.view(), normal.view(), zfield.view());
        let bind = common::bind_group(
            gpu,
            "zfield_bind",
            &bind_layout,
            &[
                species_buffer.as_entire_binding(),
                view_buffer.as_entire_binding(),
                wgpu::BindingResource::TextureView(&cv),
                wgpu::BindingResource::TextureView(&nv),
                wgpu::BindingResource::TextureView(&zv),
                wgpu::BindingResource::Sampler(&sampler),
                params_buffer.as_entire_binding(),
            ],
        );
        let static_bytes = color.bytes
            + normal.bytes
            + zfield.bytes
            + species_buffer.size()
            + view_buffer.size()
            + params_buffer.size();
        Ok(Self {
            layout: bind_layout,
            bind,
            bytes: static_bytes,
        })
    }
}

impl ZField {
    /// Uploads every species' views into the atlases and builds the pipelines.
    /// `density` is the tree density Λ_h of eq. 9 (trees per m²); with `field` (the forest
    /// field the chain ends in) the trees converge to its lighting and fade into it.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        gpu: &Gpu,
        frame: &FrameResources,
        plants: &[Plant],
        baked: &[ZFieldBaked],
        bake: &ZFieldBakeParams,
        draw: &ZFieldDrawParams,
        density: f32,
        field: Option<&crate::technique::shadermap::field::ForestField>,
    ) -> Result<Self, RenderError> {
        if draw.shadow_opacity && !frame.translucent() {
            return Err(RenderError::Option(
                "zfield.shadow_opacity: this frame was made without the cascades' translucent layer (the renderer makes it when a zfield band casts soft shadows) — set zfield.shadow_opacity=false".into(),
            ));
        }
        let ZFieldBindings {
            layout: bind_layout,
            bind,
            bytes: static_bytes,
        } = ZFieldBindings::upload(gpu, plants, baked, bake, draw, density)?;
        let source = super::shader_source_for(field.is_some());
        let module = sylvan_gpu::shader(gpu, "zfield", &source);
        let mut main_layouts = vec![&frame.main_layout, &bind_layout];
        main_layouts.extend(field.map(|f| &f.layout));
        let buffers = [None, Some(GpuTreeInstance::LAYOUT)];
        let build = |label, vs, fs, pass, layouts: &[&wgpu::BindGroupLayout], blend| {
            pipeline::build(
                gpu,
                &PipelineSpec {
                    label,
                    layouts,
                    module: &module,
                    vs,
                    fs: Some(fs),
                    buffers: &buffers,
                    pass,
                    frame,
                    cull: None,
                    depth_write: true,
                    blend,
                },
            )
        };
        // Opaque with per-tree coverage masks and p_v's depth: no sort, no blending; or
        // (`blend`) premultiplied over, sorted back to front, p_v's depth still written.
        let pipeline = if draw.blend {
            build(
                "zfield_blend",
                "vs_zfield",
                "fs_zfield_blend",
                PassKind::Main,
                &main_layouts,
                Some(common::PREMULTIPLIED_OVER),
            )
        } else {
            build(
                "zfield",
                "vs_zfield",
                "fs_zfield",
                PassKind::Main,
                &main_layouts,
                None,
            )
        };
        // The casters fade into the field as the trees do (group 2 there too).
        let mut shadow_layouts = vec![&frame.shadow_layout, &bind_layout];
        shadow_layouts.extend(field.map(|f| &f.layout));
        // Opaque above α ½, or translucent into the cascades' accumulating layer.
        let (shadow_fs, shadow_pass) = match draw.shadow_opacity {
            true => ("fs_zfield_shadow_soft", PassKind::ShadowTranslucent),
            false => ("fs_zfield_shadow", PassKind::Shadow),
        };
        let shadow_pipeline = build(
            "zfield_shadow",
            "vs_zfield_shadow",
            shadow_fs,
            shadow_pass,
            &shadow_layouts,
            None,
        );
        Ok(Self {
            pipeline,
            shadow_pipeline,
            bind,
            field: field.map(|f| f.bind.clone()),
            static_bytes,
            centres: baked.iter().map(|b| Vec3::from(b.centre)).collect(),
            blend: draw.blend,
            sort: Vec::new(),
            instances: Growable::new(gpu, "zfield_instances", 1 << 16),
            staging: Vec::new(),
            ranges: std::array::from_fn(|_| 0..0),
        })
    }
}

impl Technique for ZField {
    fn name(&self) -> &'static str {
        super::ENTRY.name
    }

    /// CPU-driven frames: every culled tree's quad, one list per pass of all species (the
    /// species in `rot.z`, as the GPU cull writes it). GPU-driven frames need nothing here.
    fn prepare_frame(
        &mut self,
        gpu: &Gpu,
        _: &mut wgpu::CommandEncoder,
        input: &FrameInput<'_>,
    ) -> Result<(), RenderError> {
        common::mixed_lists(
            input,
            &self.centres,
            self.blend,
            &mut self.sort,
            &mut self.staging,
            &mut self.ranges,
        );
        self.instances
            .write(gpu, bytemuck::cast_slice(&self.staging))
    }

    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts {
        let main = ctx.shadow_cascade().is_none();
        pass.set_pipeline(match main {
            true => &self.pipeline,
            false => &self.shadow_pipeline,
        });
        pass.set_bind_group(0, ctx.frame_bind, &[]);
        pass.set_bind_group(1, &self.bind, &[]);
        if let Some(field) = &self.field {
            pass.set_bind_group(2, field, &[]);
        }
        if let Some(culled) = ctx.culled.first() {
            let Some(instances) = culled.instances(ctx.pass, 0) else {
                return DrawCounts::default();
            };
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
        pass.set_vertex_buffer(1, self.instances.buffer.slice(..));
        let n = (r.end - r.start) as u64;
        pass.draw(0..6, r);
        DrawCounts {
            draw_calls: 1,
            triangles: n * 2,
        }
    }

    fn bytes(&self) -> u64 {
        self.static_bytes + self.instances.buffer.size()
    }

    /// Six vertices per tree from each pass's one list.
    fn indirect_draws(&self) -> Vec<IndirectDraw> {
        vec![IndirectDraw::vertices(0, 6)]
    }

    /// One list of every species per pass; with masks opaque, so unsorted; `blend` sorts the
    /// camera's back to front.
    fn list_layout(&self) -> ListLayout {
        ListLayout {
            per_species: false,
            sort_camera: self.blend,
        }
    }

    fn reallocations(&self) -> u32 {
        self.instances.reallocations
    }

    /// With a field, each tree fades into it by its own distance (`field_zfield.wgsl`).
    fn fades_to_field(&self) -> bool {
        self.field.is_some()
    }
}
