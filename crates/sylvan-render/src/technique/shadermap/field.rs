//! The forest field on the terrain: the tables on the GPU and the field's parameters, bound as
//! the terrain's group 1 (`field.wgsl`), and the `shadermap` technique that owns it.

use super::gpu::{GpuTables, tables_wgsl};
use super::tables::ShaderMapTables;
use crate::RenderError;
use crate::technique::zfield::ZFieldDrawParams;
use crate::technique::{DrawContext, DrawCounts, FrameInput, Technique};
use bytemuck::{Pod, Zeroable};
use sylvan_gpu::Gpu;
use wgpu::util::DeviceExt;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuFieldParams {
    density: [f32; 4],
    tree_albedo: [f32; 4],
    light: [f32; 4],
}

/// The field's GPU resources: group 1 of the terrain's forest pipeline.
pub struct ForestField {
    /// The group's layout (binding 0 the field, 1–4 the tables).
    pub layout: wgpu::BindGroupLayout,
    /// The group.
    pub bind: wgpu::BindGroup,
    /// GPU bytes.
    pub bytes: u64,
}

impl ForestField {
    /// Uploads `tables` for a forest of `density` trees per m², the trees lit as `zfield`
    /// lights them (`draw`: `sun_scale`, `sky_scale`, `a1`, `a2`).
    pub fn new(
        gpu: &Gpu,
        tables: &ShaderMapTables,
        density: f32,
        draw: &ZFieldDrawParams,
    ) -> Result<Self, RenderError> {
        let t = GpuTables::upload(gpu, tables)?;
        let device = &gpu.device;
        let all = wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE;
        let f3 = wgpu::TextureSampleType::Float { filterable: true };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadermap_field"),
            entries: &[
                sylvan_gpu::layout::uniform(0, all),
                sylvan_gpu::layout::uniform(1, all),
                sylvan_gpu::layout::texture(2, all, f3, wgpu::TextureViewDimension::D3),
                sylvan_gpu::layout::texture(3, all, f3, wgpu::TextureViewDimension::D2),
                sylvan_gpu::layout::sampler(4, all, wgpu::SamplerBindingType::Filtering),
            ],
        });
        let [r, g, b] = tables.tree_albedo;
        let params = GpuFieldParams {
            density: [density.max(0.0), 0.0, 0.0, 0.0],
            tree_albedo: [r, g, b, 0.0],
            light: [draw.sun_scale, draw.sky_scale, draw.a1, draw.a2],
        };
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("shadermap_field_params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shadermap_field"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: t.info.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&t.gt),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(&t.dec),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::Sampler(&t.sampler),
                },
            ],
        });
        Ok(Self {
            layout,
            bind,
            bytes: t.bytes + buffer.size(),
        })
    }
}

/// The terrain shader with the field: `terrain.wgsl`, the tables (group 1, bindings 1–4) and
/// `field.wgsl` (`fs_terrain_forest`).
pub(crate) fn terrain_source() -> String {
    crate::pipeline::with_frame(&format!(
        "{}\n{}\n{}",
        include_str!("../../shaders/terrain.wgsl"),
        tables_wgsl(1, 1),
        include_str!("field.wgsl")
    ))
}

/// Technique `shadermap` drawn alone: no tree is drawn, the terrain carries the whole forest
/// as BN12's far field.
pub struct ShaderMap {
    pub(crate) field: ForestField,
}

impl Technique for ShaderMap {
    fn name(&self) -> &'static str {
        super::ENTRY.name
    }

    fn prepare_frame(
        &mut self,
        _: &Gpu,
        _: &mut wgpu::CommandEncoder,
        _: &FrameInput<'_>,
    ) -> Result<(), RenderError> {
        Ok(())
    }

    fn draw(&self, _: &mut wgpu::RenderPass<'_>, _: &DrawContext<'_>) -> DrawCounts {
        DrawCounts::default()
    }

    fn bytes(&self) -> u64 {
        self.field.bytes
    }

    fn field(&self) -> Option<&ForestField> {
        Some(&self.field)
    }

    /// Nothing to cull: no tree is drawn.
    fn list_requests(&self) -> Vec<crate::world::ListRequest> {
        Vec::new()
    }
}
