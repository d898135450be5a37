//! Technique `geometry`: the full-geometry reference every image-based technique is measured
//! against. Not from a paper; it is the ground truth.
//!
//! Per species: one wood mesh (opaque, back-face culled) and one leaf mesh (alpha-tested with
//! the plant's leaf texture, two-sided: the front image or, seen from behind, the back image,
//! both lit with the tangent-space normal map of `shaders/leaf.wgsl`; front Lambert + back
//! diffuse transmission), instanced
//! over the culled trees: two draw calls per species per pass, no per-frame allocation.
//! Shadow casters use the same meshes with depth-only pipelines (leaves alpha-tested).
//!
//! Inputs: [`Plant`]s (one per species). Limits: a species' meshes must fit the device's
//! max buffer size (checked in `prepare`).

use super::params::{self, NoParams};
use super::registry::{Entry, Kind};
use super::{Built, DrawContext, DrawCounts, FrameInput, Technique};
use crate::RenderError;
use crate::frame::FrameResources;
use crate::instances::GpuTreeInstance;
use crate::pipeline::{self, PassKind, PipelineSpec};
use crate::texture;
use crate::world::IndirectDraw;
use bytemuck::{Pod, Zeroable};
use sylvan_gpu::{Gpu, layout};
use sylvan_plant::{Mesh, Plant};
use wgpu::util::DeviceExt;

/// Leaf translucency: fraction of sunlight transmitted diffusely through a leaf.
pub const LEAF_TRANSLUCENCY: f32 = 0.35;

/// A plant vertex as every plant shader reads it (locations 0–3).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct GpuPlantVertex {
    position: [f32; 3],
    normal: [f32; 3],
    uv: [f32; 2],
    color: [f32; 3],
}

impl GpuPlantVertex {
    pub(crate) const LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
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
pub(crate) struct GpuMesh {
    pub(crate) vertices: wgpu::Buffer,
    pub(crate) indices: wgpu::Buffer,
    pub(crate) index_count: u32,
}

impl GpuMesh {
    /// Uploads `mesh` (checked against the device's buffer limit); `None` when it is empty.
    pub(crate) fn new(gpu: &Gpu, label: &str, mesh: &Mesh) -> Result<Option<Self>, RenderError> {
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
        self.draw_range(
            pass,
            0..self.index_count,
            ctx.instances.buffer(),
            ctx.ranges[species].clone(),
        )
    }

    /// Draws the triangles `indices` (an index range) once per instance in `instances` of
    /// `instance_buffer` (vertex slot 1).
    pub(crate) fn draw_range(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        indices: std::ops::Range<u32>,
        instance_buffer: &wgpu::Buffer,
        instances: std::ops::Range<u32>,
    ) -> DrawCounts {
        if instances.is_empty() || indices.is_empty() {
            return DrawCounts::default();
        }
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_vertex_buffer(1, instance_buffer.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        let n = instances.end - instances.start;
        let tris = (indices.end - indices.start) as u64 / 3;
        pass.draw_indexed(indices, 0, instances);
        DrawCounts {
            draw_calls: 1,
            triangles: tris * n as u64,
        }
    }

    /// GPU bytes.
    pub(crate) fn bytes(&self) -> u64 {
        self.vertices.size() + self.indices.size()
    }
}

/// One species' meshes and material on the GPU.
pub(crate) struct SpeciesMeshes {
    pub(crate) wood: Option<GpuMesh>,
    pub(crate) leaves: Option<GpuMesh>,
    pub(crate) material: wgpu::BindGroup,
    texture_bytes: u64,
}

impl SpeciesMeshes {
    /// Uploads `wood` and `leaves` (the plant's own meshes, or re-ordered copies) with the
    /// plant's leaf texture as material.
    pub(crate) fn new(
        gpu: &Gpu,
        pipes: &MeshPipelines,
        plant: &Plant,
        wood: &Mesh,
        leaves: &Mesh,
    ) -> Result<Self, RenderError> {
        let device = &gpu.device;
        let maps = texture::upload_leaf_material(gpu, "leaf_texture", plant)?;
        let texture_bytes = maps.bytes;
        // Vertices per leaf, for the per-leaf hash of level-of-detail transitions.
        let leaf_vertices = match plant.leaf_count {
            0 => 4,
            n => (plant.leaves.positions.len() / n).max(1),
        };
        let raw = GpuSpecies {
            bbox_min: [
                plant.bbox_min[0],
                plant.bbox_min[1],
                plant.bbox_min[2],
                leaf_vertices as f32,
            ],
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
            layout: &pipes.material_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&maps.front),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Sampler(&pipes.sampler),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: uniform.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(&maps.back),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(&maps.normal),
                },
            ],
        });
        Ok(Self {
            wood: GpuMesh::new(gpu, &format!("{} wood", plant.name), wood)?,
            leaves: GpuMesh::new(gpu, &format!("{} leaves", plant.name), leaves)?,
            material,
            texture_bytes,
        })
    }

    /// GPU bytes (meshes and texture).
    pub(crate) fn bytes(&self) -> u64 {
        self.texture_bytes
            + self.wood.as_ref().map_or(0, GpuMesh::bytes)
            + self.leaves.as_ref().map_or(0, GpuMesh::bytes)
    }
}

/// The four mesh pipelines (wood and leaves, main and shadow) and their material layout,
/// shared by every technique that draws some of a plant as real geometry.
pub(crate) struct MeshPipelines {
    pub(crate) material_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    pub(crate) wood: wgpu::RenderPipeline,
    pub(crate) leaf: wgpu::RenderPipeline,
    pub(crate) wood_shadow: wgpu::RenderPipeline,
    pub(crate) leaf_shadow: wgpu::RenderPipeline,
}

impl MeshPipelines {
    /// Builds the pipelines for `frame`'s pass layouts.
    pub(crate) fn new(gpu: &Gpu, frame: &FrameResources) -> Self {
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
                layout::texture(
                    3,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::TextureSampleType::Float { filterable: true },
                    wgpu::TextureViewDimension::D2,
                ),
                layout::texture(
                    4,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::TextureSampleType::Float { filterable: true },
                    wgpu::TextureViewDimension::D2,
                ),
            ],
        });
        let sampler = crate::technique::common::trilinear_sampler(gpu, "leaf_sampler");
        let module = sylvan_gpu::shader(gpu, "geometry", &shader_source());
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
                    frame,
                    cull,
                    depth_write: true,
                    blend: None,
                },
            )
        };
        let back = Some(wgpu::Face::Back);
        let main = &frame.main_layout;
        let shadow = &frame.shadow_layout;
        let wood = make(
            "geometry_wood",
            PassKind::Main,
            "vs_plant",
            Some("fs_wood"),
            back,
            main,
        );
        let leaf = make(
            "geometry_leaf",
            PassKind::Main,
            "vs_plant",
            Some("fs_leaf"),
            None,
            main,
        );
        let wood_shadow = make(
            "geometry_wood_shadow",
            PassKind::Shadow,
            "vs_plant_shadow",
            None,
            None,
            shadow,
        );
        let leaf_shadow = make(
            "geometry_leaf_shadow",
            PassKind::Shadow,
            "vs_plant_shadow",
            Some("fs_leaf_shadow"),
            None,
            shadow,
        );
        Self {
            material_layout,
            sampler,
            wood,
            leaf,
            wood_shadow,
            leaf_shadow,
        }
    }

    /// The (wood, leaf) pipelines of a pass.
    pub(crate) fn for_pass(&self, shadow: bool) -> (&wgpu::RenderPipeline, &wgpu::RenderPipeline) {
        if shadow {
            (&self.wood_shadow, &self.leaf_shadow)
        } else {
            (&self.wood, &self.leaf)
        }
    }
}

/// The prepared reference technique.
pub struct Geometry {
    species: Vec<SpeciesMeshes>,
    pipes: MeshPipelines,
}

/// The registry entry.
pub const ENTRY: Entry = Entry {
    name: "geometry",
    kind: Kind::PerTree,
    summary: "the reference: every tree as its full meshes",
    debug_color: [1.0, 0.45, 0.05],
    gpu_driven: true,
    schema: params::schema::<NoParams, NoParams>,
    check: |s| params::resolve::<NoParams, NoParams>("geometry", s).map(|_| ()),
    build: |cx| {
        params::resolve::<NoParams, NoParams>("geometry", &cx.settings_for("geometry"))?;
        Ok(Built {
            technique: Box::new(Geometry::new(cx.gpu, cx.frame, cx.plants)?),
            reports: Vec::new(),
        })
    },
    bake: None,
    casts_translucent: None,
    shaders: || vec![("geometry", shader_source())],
};

impl Technique for Geometry {
    fn name(&self) -> &'static str {
        ENTRY.name
    }

    fn prepare_frame(
        &mut self,
        _: &Gpu,
        _: &mut wgpu::CommandEncoder,
        _: &FrameInput<'_>,
    ) -> Result<(), RenderError> {
        Ok(())
    }

    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts {
        self.record(pass, ctx, ctx.shadow_cascade().is_some())
    }

    fn bytes(&self) -> u64 {
        self.species.iter().map(SpeciesMeshes::bytes).sum()
    }

    /// Per species its wood, then its leaves (the draws of `Geometry::record_indirect`).
    fn indirect_draws(&self) -> Vec<IndirectDraw> {
        self.meshes()
            .map(|(species, _, mesh)| IndirectDraw::indexed(species as u32, mesh.index_count, 0))
            .collect()
    }
}

impl Geometry {
    /// Uploads every species' meshes.
    pub fn new(gpu: &Gpu, frame: &FrameResources, plants: &[Plant]) -> Result<Self, RenderError> {
        let pipes = MeshPipelines::new(gpu, frame);
        let species = plants
            .iter()
            .map(|p| SpeciesMeshes::new(gpu, &pipes, p, &p.wood, &p.leaves))
            .collect::<Result<_, _>>()?;
        Ok(Self { species, pipes })
    }

    /// Every (species, is leaves, mesh), wood before leaves: the order of the indirect draws.
    fn meshes(&self) -> impl Iterator<Item = (usize, bool, &GpuMesh)> {
        [false, true].into_iter().flat_map(move |leaves| {
            self.species.iter().enumerate().filter_map(move |(i, s)| {
                let mesh = if leaves { &s.leaves } else { &s.wood };
                mesh.as_ref().map(|m| (i, leaves, m))
            })
        })
    }

    /// The GPU-driven pass: one indirect draw per (species, mesh) from the cull's lists. The
    /// triangle counts are the last frame's (read back after it).
    fn record_indirect(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        ctx: &DrawContext<'_>,
        culled: &crate::world::Culled<'_>,
        shadow: bool,
    ) -> DrawCounts {
        let (wood, leaf) = self.pipes.for_pass(shadow);
        let mut counts = DrawCounts::default();
        pass.set_bind_group(0, ctx.frame_bind, &[]);
        let mut current = None;
        for (k, (species, leaves, mesh)) in self.meshes().enumerate() {
            let Some(instances) = culled.instances(ctx.pass, species) else {
                continue;
            };
            if current != Some(leaves) {
                pass.set_pipeline(if leaves { leaf } else { wood });
                current = Some(leaves);
            }
            pass.set_bind_group(1, &self.species[species].material, &[]);
            pass.set_vertex_buffer(0, mesh.vertices.slice(..));
            pass.set_vertex_buffer(1, instances);
            pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
            let (args, offset) = culled.args(ctx.pass, k);
            pass.draw_indexed_indirect(args, offset);
            counts.draw_calls += 1;
            counts.triangles +=
                culled.listed(ctx.pass, species) as u64 * (mesh.index_count / 3) as u64;
        }
        counts
    }

    fn record(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        ctx: &DrawContext<'_>,
        shadow: bool,
    ) -> DrawCounts {
        if let Some(culled) = ctx.culled.first() {
            return self.record_indirect(pass, ctx, culled, shadow);
        }
        let (wood, leaf) = self.pipes.for_pass(shadow);
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

/// The WGSL of `geometry` as compiled: the frame's group 0, `bindings.wgsl` (group 1), the
/// shared leaf material (`shaders/leaf.wgsl`), then `geometry.wgsl`.
pub(crate) fn shader_source() -> String {
    crate::pipeline::with_frame(concat!(
        include_str!("bindings.wgsl"),
        include_str!("../../shaders/leaf.wgsl"),
        include_str!("geometry.wgsl")
    ))
}
