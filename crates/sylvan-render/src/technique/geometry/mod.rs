//! Technique `geometry`: the full-geometry reference every image-based technique is measured
//! against. Not from a paper; it is the ground truth.
//!
//! Per species: one wood mesh (opaque, back-face culled) and one leaf mesh (alpha-tested with
//! the plant's leaf texture, two-sided, front Lambert + back diffuse transmission), instanced
//! over the culled trees: two draw calls per species per pass, no per-frame allocation.
//! Shadow casters use the same meshes with depth-only pipelines (leaves alpha-tested).
//!
//! Inputs: [`Plant`]s (one per species). Limits: a species' meshes must fit the device's
//! max buffer size (checked in `prepare`).

use super::{DrawContext, DrawCounts, Representation};
use crate::RenderError;
use crate::frame::FrameResources;
use crate::instances::GpuTreeInstance;
use crate::pipeline::{self, PassKind, PipelineSpec};
use crate::texture::{self, Level};
use bytemuck::{Pod, Zeroable};
use sylvan_gpu::{Gpu, layout};
use sylvan_plant::{Mesh, Plant};
use wgpu::util::DeviceExt;

/// Leaf translucency: fraction of sunlight transmitted diffusely through a leaf.
pub const LEAF_TRANSLUCENCY: f32 = 0.35;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuPlantVertex {
    position: [f32; 3],
    normal: [f32; 3],
    uv: [f32; 2],
    color: [f32; 3],
}

impl GpuPlantVertex {
    const LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<GpuPlantVertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2, 3 => Float32x3],
    };
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuSpecies {
    bbox_min: [f32; 4],
    bbox_max: [f32; 4],
}

/// A mesh on the GPU.
struct GpuMesh {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
}

impl GpuMesh {
    fn new(gpu: &Gpu, label: &str, mesh: &Mesh) -> Result<Option<Self>, RenderError> {
        if mesh.indices.is_empty() {
            return Ok(None);
        }
        let n = mesh.positions.len();
        if mesh.normals.len() != n || mesh.uvs.len() != n || mesh.colors.len() != n {
            return Err(RenderError::Plant(format!(
                "{label}: per-vertex arrays differ in length"
            )));
        }
        if let Some(&bad) = mesh.indices.iter().find(|&&i| i as usize >= n) {
            return Err(RenderError::Plant(format!(
                "{label}: index {bad} out of range ({n} vertices)"
            )));
        }
        let verts: Vec<GpuPlantVertex> = (0..n)
            .map(|i| GpuPlantVertex {
                position: mesh.positions[i],
                normal: mesh.normals[i],
                uv: mesh.uvs[i],
                color: mesh.colors[i],
            })
            .collect();
        let bytes = std::mem::size_of_val(verts.as_slice()) as u64;
        let limit = gpu.device.limits().max_buffer_size;
        if bytes > limit {
            return Err(RenderError::Gpu(sylvan_gpu::GpuError::Limit {
                what: format!("{label} vertex buffer"),
                needed: bytes,
                limit,
                fix: "use a simpler plant".into(),
            }));
        }
        let vertices = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::cast_slice(&verts),
                usage: wgpu::BufferUsages::VERTEX,
            });
        let indices = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::cast_slice(&mesh.indices),
                usage: wgpu::BufferUsages::INDEX,
            });
        Ok(Some(Self {
            vertices,
            indices,
            index_count: mesh.indices.len() as u32,
        }))
    }

    fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        ctx: &DrawContext<'_>,
        species: usize,
    ) -> DrawCounts {
        let range = ctx.ranges[species].clone();
        if range.is_empty() {
            return DrawCounts::default();
        }
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_vertex_buffer(1, ctx.instances.buffer().slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        let n = range.end - range.start;
        pass.draw_indexed(0..self.index_count, 0, range);
        DrawCounts {
            draw_calls: 1,
            triangles: self.index_count as u64 / 3 * n as u64,
        }
    }

    fn bytes(&self) -> u64 {
        self.vertices.size() + self.indices.size()
    }
}

struct SpeciesMeshes {
    wood: Option<GpuMesh>,
    leaves: Option<GpuMesh>,
    material: wgpu::BindGroup,
    texture_bytes: u64,
}

/// The prepared reference technique.
pub struct Geometry {
    species: Vec<SpeciesMeshes>,
    wood: wgpu::RenderPipeline,
    leaf: wgpu::RenderPipeline,
    wood_shadow: wgpu::RenderPipeline,
    leaf_shadow: wgpu::RenderPipeline,
}

impl Representation for Geometry {
    const NAME: &'static str = "geometry";

    fn prepare(gpu: &Gpu, frame: &FrameResources, plants: &[Plant]) -> Result<Self, RenderError> {
        let device = &gpu.device;
        let material_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("geometry_material_layout"),
            entries: &[
                layout::texture(
                    0,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::TextureSampleType::Float { filterable: true },
                    wgpu::TextureViewDimension::D2,
                ),
                layout::sampler(
                    1,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::SamplerBindingType::Filtering,
                ),
                layout::uniform(2, wgpu::ShaderStages::VERTEX_FRAGMENT),
            ],
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("leaf_sampler"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            // No anisotropy: on lavapipe/llvmpipe an anisotropic sampler made the alpha-tested
            // shadow pass ~1000× slower (measured: 150 s vs 0.1 s for two trees).
            ..Default::default()
        });
        let mut species = Vec::with_capacity(plants.len());
        for plant in plants {
            let tex = &plant.leaf_texture;
            if tex.width == 0
                || tex.height == 0
                || tex.rgba.len() != (tex.width * tex.height * 4) as usize
            {
                return Err(RenderError::Plant(format!(
                    "{}: leaf texture size does not match its data",
                    plant.name
                )));
            }
            gpu.check_texture_size("leaf texture", tex.width, tex.height)?;
            let levels = texture::cutout_mips(Level {
                width: tex.width,
                height: tex.height,
                rgba: tex.rgba.clone(),
            });
            let texture = texture::upload(gpu, "leaf_texture", &levels);
            let texture_bytes = levels.iter().map(|l| l.rgba.len() as u64).sum();
            let view = texture.create_view(&Default::default());
            let raw = GpuSpecies {
                bbox_min: [plant.bbox_min[0], plant.bbox_min[1], plant.bbox_min[2], 0.0],
                bbox_max: [
                    plant.bbox_max[0],
                    plant.bbox_max[1],
                    plant.bbox_max[2],
                    LEAF_TRANSLUCENCY,
                ],
            };
            let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("species_uniform"),
                contents: bytemuck::bytes_of(&raw),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let material = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("geometry_material"),
                layout: &material_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(&view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::Sampler(&sampler),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: uniform.as_entire_binding(),
                    },
                ],
            });
            species.push(SpeciesMeshes {
                wood: GpuMesh::new(gpu, &format!("{} wood", plant.name), &plant.wood)?,
                leaves: GpuMesh::new(gpu, &format!("{} leaves", plant.name), &plant.leaves)?,
                material,
                texture_bytes,
            });
        }
        let module = sylvan_gpu::shader(
            gpu,
            "geometry",
            &pipeline::with_frame(include_str!("geometry.wgsl")),
        );
        let buffers = [Some(GpuPlantVertex::LAYOUT), Some(GpuTreeInstance::LAYOUT)];
        let make = |label, pass, vs, fs, cull, layout: &wgpu::BindGroupLayout| {
            pipeline::build(
                gpu,
                &PipelineSpec {
                    label,
                    layouts: &[layout, &material_layout],
                    module: &module,
                    vs,
                    fs,
                    buffers: &buffers,
                    pass,
                    cull,
                    depth_write: true,
                },
            )
        };
        let back = Some(wgpu::Face::Back);
        Ok(Self {
            species,
            wood: make(
                "geometry_wood",
                PassKind::Main,
                "vs_plant",
                Some("fs_wood"),
                back,
                &frame.main_layout,
            ),
            leaf: make(
                "geometry_leaf",
                PassKind::Main,
                "vs_plant",
                Some("fs_leaf"),
                None,
                &frame.main_layout,
            ),
            wood_shadow: make(
                "geometry_wood_shadow",
                PassKind::Shadow,
                "vs_plant_shadow",
                None,
                None,
                &frame.shadow_layout,
            ),
            leaf_shadow: make(
                "geometry_leaf_shadow",
                PassKind::Shadow,
                "vs_plant_shadow",
                Some("fs_leaf_shadow"),
                None,
                &frame.shadow_layout,
            ),
        })
    }

    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts {
        self.record(pass, ctx, &self.wood, &self.leaf)
    }

    fn draw_shadow(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts {
        self.record(pass, ctx, &self.wood_shadow, &self.leaf_shadow)
    }

    fn bytes(&self) -> u64 {
        self.species
            .iter()
            .map(|s| {
                s.texture_bytes
                    + s.wood.as_ref().map_or(0, GpuMesh::bytes)
                    + s.leaves.as_ref().map_or(0, GpuMesh::bytes)
            })
            .sum()
    }
}

impl Geometry {
    fn record(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        ctx: &DrawContext<'_>,
        wood: &wgpu::RenderPipeline,
        leaf: &wgpu::RenderPipeline,
    ) -> DrawCounts {
        let mut counts = DrawCounts::default();
        pass.set_bind_group(0, ctx.frame_bind, &[]);
        for (pipeline, pick) in [(wood, 0), (leaf, 1)] {
            pass.set_pipeline(pipeline);
            for (i, s) in self.species.iter().enumerate() {
                let mesh = if pick == 0 { &s.wood } else { &s.leaves };
                if let Some(mesh) = mesh {
                    pass.set_bind_group(1, &s.material, &[]);
                    counts += mesh.draw(pass, ctx, i);
                }
            }
        }
        counts
    }
}
