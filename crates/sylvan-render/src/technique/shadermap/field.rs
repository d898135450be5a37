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
        // Binding 0 the field, 1–4 the tables.
        let mut entries = vec![sylvan_gpu::layout::uniform(
            0,
            wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE,
        )];
        entries.extend(GpuTables::entries(1));
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadermap_field"),
            entries: &entries,
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
        let mut resources = vec![buffer.as_entire_binding()];
        resources.extend(t.resources());
        let bind =
            crate::technique::common::bind_group(gpu, "shadermap_field", &layout, &resources);
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
