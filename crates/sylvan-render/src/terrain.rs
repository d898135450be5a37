//! The terrain mesh on the GPU and its main and shadow pipelines (`shaders/terrain.wgsl`).
//!
//! The grid's indices are stored chunk by chunk ([`CHUNK_QUADS`]² quads each, with their
//! bounds), and each pass draws only the chunks its frustum reaches (consecutive ones merged
//! into one draw): a camera near the ground of a wide terrain, or a cascade a few hundred metres
//! across, no longer pays for the whole grid in every pass.

use crate::frame::{FrameResources, Frustum};
use crate::pipeline::{self, PassKind, PipelineSpec};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::ops::Range;
use sylvan_gpu::Gpu;
use sylvan_scene::Terrain;
use wgpu::util::DeviceExt;

/// Most grid samples along one side that are drawn; larger heightmaps are resampled.
pub const MAX_DRAWN_SIDE: u32 = 1025;

/// Quads per side of a culling chunk.
pub const CHUNK_QUADS: u32 = 64;

/// A chunk of the grid: its index range and bounds.
struct Chunk {
    indices: Range<u32>,
    min: Vec3,
    max: Vec3,
}

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
    chunks: Vec<Chunk>,
    /// Per pass (0 the camera, 1 + c cascade c): the index ranges to draw.
    visible: Vec<Vec<Range<u32>>>,
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
        let mut chunks = Vec::new();
        for r0 in (0..rows - 1).step_by(CHUNK_QUADS as usize) {
            for c0 in (0..cols - 1).step_by(CHUNK_QUADS as usize) {
                let start = idx.len() as u32;
                let (mut min, mut max) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
                for r in r0..(r0 + CHUNK_QUADS).min(rows - 1) {
                    for c in c0..(c0 + CHUNK_QUADS).min(cols - 1) {
                        let i = r * cols + c;
                        // Counter-clockwise seen from above (+Y).
                        let quad = [i, i + cols, i + 1, i + 1, i + cols, i + cols + 1];
                        for &v in &quad {
                            let p = Vec3::from(verts[v as usize].position);
                            (min, max) = (min.min(p), max.max(p));
                        }
                        idx.extend_from_slice(&quad);
                    }
                }
                chunks.push(Chunk {
                    indices: start..idx.len() as u32,
                    min,
                    max,
                });
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
                frame,
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
                frame,
                cull: None,
                depth_write: true,
                blend: None,
            },
        );
        let all: Vec<Range<u32>> = std::iter::once(0..idx.len() as u32).collect();
        Self {
            vertices,
            indices,
            chunks,
            visible: vec![all; 1 + crate::frame::CASCADES],
            main,
            shadow,
            field: field.map(|f| f.bind.clone()),
        }
    }

    /// GPU bytes.
    pub fn bytes(&self) -> u64 {
        self.vertices.size() + self.indices.size()
    }

    /// Picks, for each pass (0 the camera, 1 + c cascade c), the chunks its frustum reaches
    /// (`None`: a pass not drawn this frame).
    pub fn cull(&mut self, frustums: &[Option<Frustum>]) {
        for (visible, frustum) in self.visible.iter_mut().zip(frustums) {
            visible.clear();
            let Some(f) = frustum else { continue };
            for chunk in &self.chunks {
                if !f.intersects_box(chunk.min, chunk.max) {
                    continue;
                }
                match visible.last_mut() {
                    Some(last) if last.end == chunk.indices.start => last.end = chunk.indices.end,
                    _ => visible.push(chunk.indices.clone()),
                }
            }
        }
    }

    /// Triangles drawn in pass `which` (as [`TerrainPass::draw`] counts them).
    pub fn visible_triangles(&self, which: usize) -> u64 {
        self.visible
            .get(which)
            .map_or(0, |v| v.iter().map(|r| (r.end - r.start) as u64 / 3).sum())
    }

    /// Records the terrain's chunks visible in `pass` (0: a main pass, 1 + c: cascade c's
    /// shadow pass); returns draw calls and triangles.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, which: usize) -> (u32, u64) {
        let shadow = which > 0;
        let ranges = &self.visible[which.min(self.visible.len() - 1)];
        if ranges.is_empty() {
            return (0, 0);
        }
        pass.set_pipeline(if shadow { &self.shadow } else { &self.main });
        if let (false, Some(field)) = (shadow, &self.field) {
            pass.set_bind_group(1, field, &[]);
        }
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        let mut triangles = 0;
        for r in ranges {
            pass.draw_indexed(r.clone(), 0, 0..1);
            triangles += (r.end - r.start) as u64 / 3;
        }
        (ranges.len() as u32, triangles)
    }
}
