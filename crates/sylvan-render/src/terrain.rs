//! The terrain mesh on the GPU and its main and shadow pipelines (`shaders/terrain.wgsl`).

use crate::frame::FrameResources;
use crate::pipeline::{self, PassKind, PipelineSpec};
use bytemuck::{Pod, Zeroable};
use sylvan_gpu::Gpu;
use sylvan_scene::Terrain;
use wgpu::util::DeviceExt;

/// Most grid samples along one side that are drawn; larger heightmaps are resampled.
pub const MAX_DRAWN_SIDE: u32 = 1025;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuTerrainVertex {
    position: [f32; 3],
    normal: [f32; 3],
}

/// The terrain grid uploaded once, and its pipelines.
pub struct TerrainPass {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
    main: wgpu::RenderPipeline,
    shadow: wgpu::RenderPipeline,
    /// The forest field's group 1 (BN12's shader-map), when the technique has one.
    field: Option<wgpu::BindGroup>,
}

impl TerrainPass {
    /// Uploads `terrain` (resampled to at most [`MAX_DRAWN_SIDE`] per side); with `field` the
    /// main pipeline shades it as forest (`fs_terrain_forest`).
    pub fn new(
        gpu: &Gpu,
        frame: &FrameResources,
        terrain: &Terrain,
        field: Option<&crate::technique::shadermap::field::ForestField>,
    ) -> Self {
        let cols = terrain.resolution[0].clamp(2, MAX_DRAWN_SIDE);
        let rows = terrain.resolution[1].clamp(2, MAX_DRAWN_SIDE);
        let mut verts = Vec::with_capacity((cols * rows) as usize);
        for r in 0..rows {
            for c in 0..cols {
                let x = terrain.size[0] * c as f32 / (cols - 1) as f32;
                let z = terrain.size[1] * r as f32 / (rows - 1) as f32;
                verts.push(GpuTerrainVertex {
                    position: [x, terrain.height_at(x, z), z],
                    normal: terrain.normal_at(x, z).to_array(),
                });
            }
        }
        let mut idx = Vec::with_capacity(((cols - 1) * (rows - 1) * 6) as usize);
        for r in 0..rows - 1 {
            for c in 0..cols - 1 {
                let i = r * cols + c;
                // Counter-clockwise seen from above (+Y).
                idx.extend_from_slice(&[i, i + cols, i + 1, i + 1, i + cols, i + cols + 1]);
            }
        }
        let vertices = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("terrain_vertices"),
                contents: bytemuck::cast_slice(&verts),
                usage: wgpu::BufferUsages::VERTEX,
            });
        let indices = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("terrain_indices"),
                contents: bytemuck::cast_slice(&idx),
                usage: wgpu::BufferUsages::INDEX,
            });
        let source = match field {
            Some(_) => crate::technique::shadermap::field::terrain_source(),
            None => pipeline::with_frame(include_str!("shaders/terrain.wgsl")),
        };
        let module = sylvan_gpu::shader(gpu, "terrain", &source);
        let main_layouts: Vec<&wgpu::BindGroupLayout> = match field {
            Some(f) => vec![&frame.main_layout, &f.layout],
            None => vec![&frame.main_layout],
        };
        let layout = wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<GpuTerrainVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3],
        };
        let buffers = [Some(layout)];
        let main = pipeline::build(
            gpu,
            &PipelineSpec {
                label: "terrain_pipeline",
                layouts: &main_layouts,
                module: &module,
                vs: "vs_terrain",
                fs: Some(if field.is_some() {
                    "fs_terrain_forest"
                } else {
                    "fs_terrain"
                }),
                buffers: &buffers,
                pass: PassKind::Main,
                target: &frame.target,
                cull: Some(wgpu::Face::Back),
                depth_write: true,
                blend: None,
            },
        );
        let shadow = pipeline::build(
            gpu,
            &PipelineSpec {
                label: "terrain_shadow_pipeline",
                layouts: &[&frame.shadow_layout],
                module: &module,
                vs: "vs_terrain_shadow",
                fs: None,
                buffers: &buffers,
                pass: PassKind::Shadow,
                target: &frame.target,
                cull: None,
                depth_write: true,
                blend: None,
            },
        );
        Self {
            vertices,
            indices,
            index_count: idx.len() as u32,
            main,
            shadow,
            field: field.map(|f| f.bind.clone()),
        }
    }

    /// Triangles drawn per pass.
    pub fn triangles(&self) -> u64 {
        self.index_count as u64 / 3
    }

    /// GPU bytes.
    pub fn bytes(&self) -> u64 {
        self.vertices.size() + self.indices.size()
    }

    /// Records the terrain into a main (`shadow = false`) or shadow pass; returns draw calls.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, shadow: bool) -> u32 {
        pass.set_pipeline(if shadow { &self.shadow } else { &self.main });
        if let (false, Some(field)) = (shadow, &self.field) {
            pass.set_bind_group(1, field, &[]);
        }
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..self.index_count, 0, 0..1);
        1
    }
}
