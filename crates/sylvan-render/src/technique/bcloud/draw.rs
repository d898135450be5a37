//! The GPU side of `billboard-cloud`: every species' three clouds in shared buffers and atlases,
//! the per-frame choice of cloud by apparent size (cross-faded), and the passes.

use super::bake::BillboardCloudBaked;
use super::layers::PlaneRecord;
use super::{BillboardCloudDrawParams, layers};
use crate::RenderError;
use crate::bake::image::TileLevel;
use crate::frame::FrameResources;
use crate::instances::{GpuTreeInstance, Instances};
use crate::pipeline::{self, PassKind, PipelineSpec};
use crate::technique::common::{self, TileAtlas, smoothstep};
use crate::technique::geometry::{GpuMesh, LEAF_TRANSLUCENCY, MeshPipelines, SpeciesMeshes};
use crate::technique::lod::FADE;
use crate::technique::{BandRange, DrawContext, DrawCounts, FrameInput, Technique};
use crate::world::{IndirectDraw, ListLayout, ListRequest};
use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};
use std::ops::Range;
use sylvan_gpu::{Gpu, layout};
use sylvan_plant::{Mesh, Plant};
use wgpu::util::DeviceExt;

/// The three clouds, nearest first.
pub const LEVELS: usize = 3;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct CloudVertex {
    /// Plane space: `s`, `t`, height above the plane.
    pst: [f32; 3],
    plane: u32,
    /// The block's box (plane space): its lowest and highest corner.
    block_lo: [f32; 3],
    block_hi: [f32; 3],
}

impl CloudVertex {
    const LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<CloudVertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &wgpu::vertex_attr_array![
            0 => Float32x3,
            1 => Uint32,
            2 => Float32x3,
            3 => Float32x3
        ],
    };
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuParams {
    level_first: [u32; 4],
    windows: [[f32; 4]; LEVELS],
    draw: [f32; 4],
    atlas_near: [u32; 4],
    atlas_far: [u32; 4],
}

/// What one (cloud, species) draws.
#[derive(Clone)]
struct Part {
    species: usize,
    /// Indices of its planes in the shared index buffer.
    planes: Range<u32>,
}

/// One draw of a cloud: (species, its wood mesh, or its planes' index range).
type LevelDraw<'a> = (usize, Option<&'a GpuMesh>, Option<Range<u32>>);

/// The prepared `billboard-cloud` technique.
pub struct BillboardCloud {
    species: Vec<SpeciesMeshes>,
    /// Per species the far cloud's simplified wood.
    far_wood: Vec<Option<GpuMesh>>,
    pipes: MeshPipelines,
    layered: wgpu::RenderPipeline,
    lowres: wgpu::RenderPipeline,
    layered_shadow: wgpu::RenderPipeline,
    lowres_shadow: wgpu::RenderPipeline,
    bind: wgpu::BindGroup,
    params_buffer: wgpu::Buffer,
    params: GpuParams,
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    /// Per cloud, per species.
    parts: [Vec<Part>; LEVELS],
    draw: BillboardCloudDrawParams,
    band: BandRange,
    static_bytes: u64,
    /// CPU-driven: each cloud's trees this frame.
    lists: Vec<Instances>,
    /// Per cloud: trees drawn in the camera pass last frame (CPU-driven frames; the GPU cull
    /// counts its own, `trees_drawn` per technique).
    drawn: Option<[u32; LEVELS]>,
    /// Per cloud: its presence window by distance (this frame's).
    windows: [[f32; 4]; LEVELS],
}

/// The wood of branches up to `levels` deep (the trunk and main limbs): each kept node's own
/// triangles (its subtree's minus its children's).
pub fn simplified_wood(plant: &Plant, levels: u32) -> Mesh {
    let h = &plant.hierarchy;
    let mut mesh = Mesh {
        indices: Vec::new(),
        ..plant.wood.clone()
    };
    if h.nodes.is_empty() {
        mesh.indices = plant.wood.indices.clone();
        return mesh;
    }
    for node in h.nodes.iter().filter(|n| n.level <= levels) {
        let mut own: Vec<Range<u32>> = vec![node.wood_indices.clone()];
        for &c in &node.children {
            let cr = &h.nodes[c as usize].wood_indices;
            own = own
                .into_iter()
                .flat_map(|r| {
                    [
                        r.start..cr.start.clamp(r.start, r.end),
                        cr.end.clamp(r.start, r.end)..r.end,
                    ]
                })
                .filter(|r| !r.is_empty())
                .collect();
        }
        for r in own {
            mesh.indices
                .extend_from_slice(&plant.wood.indices[r.start as usize..r.end as usize]);
        }
    }
    mesh
}

/// Cells per side of the blocks a plane is cut into.
const BLOCK: u32 = 8;

/// The parts of a plane worth drawing (plane coordinates, min and max): for a cloud with lists,
/// each row of `BLOCK²`-cell blocks holding any non-empty cell, merged along the row, so the
/// rasteriser does not run the shader over the empty stretches of a large thin cluster's
/// rectangle; the whole rectangle for the far cloud (low-resolution tiles only).
fn occupied_rects(c: &layers::Cloud, p: &PlaneRecord) -> Vec<(Vec2, Vec2)> {
    let (min, size) = (p.min(), p.size());
    if !c.layered {
        return vec![(min, min + size)];
    }
    let (nx, ny) = p.cells();
    let cm = p.origin_cell[3];
    let first = p.grid[2] as usize;
    let occupied = |bx: u32, by: u32| {
        (by * BLOCK..((by + 1) * BLOCK).min(ny)).any(|cy| {
            (bx * BLOCK..((bx + 1) * BLOCK).min(nx))
                .any(|cx| c.cells[first + (cy * nx + cx) as usize] != 0)
        })
    };
    let mut out = Vec::new();
    for by in 0..ny.div_ceil(BLOCK) {
        let mut bx = 0;
        while bx < nx.div_ceil(BLOCK) {
            if !occupied(bx, by) {
                bx += 1;
                continue;
            }
            let start = bx;
            while bx < nx.div_ceil(BLOCK) && occupied(bx, by) {
                bx += 1;
            }
            let lo = min + Vec2::new(start as f32, by as f32) * (BLOCK as f32 * cm);
            let hi =
                (min + Vec2::new(bx as f32, (by + 1) as f32) * (BLOCK as f32 * cm)).min(min + size);
            out.push((lo, hi));
        }
    }
    out
}

/// The heights above plane `p` that the leaves listed in the cells of its block `[lo, hi]`
/// span (a ray through the block meets its leaves inside them): thinner than the plane's slab
/// where the cluster is curved. The far cloud is flat.
fn block_heights(c: &layers::Cloud, plane: usize, lo: Vec2, hi: Vec2) -> (f32, f32) {
    if !c.layered {
        return (0.0, 0.0);
    }
    let p = &c.planes[plane];
    let cm = p.origin_cell[3];
    let (nx, ny) = p.cells();
    let a = ((lo - p.min()) / cm).round();
    let b = ((hi - p.min()) / cm).round();
    let (mut h0, mut h1) = (f32::MAX, f32::MIN);
    for cy in (a.y as u32)..(b.y as u32).min(ny) {
        for cx in (a.x as u32)..(b.x as u32).min(nx) {
            for &r in c.list(plane, cx, cy) {
                if let Some((z0, z1)) = c.records[r as usize].heights() {
                    (h0, h1) = (h0.min(z0), h1.max(z1));
                }
            }
        }
    }
    if h0 > h1 {
        return (0.0, 0.0);
    }
    // Inside the plane's slab, with the same margin.
    let (s0, s1) = p.heights();
    ((h0 - 1e-3).max(s0), (h1 + 1e-3).min(s1))
}

/// The box `[lo, hi]` (plane space) of one block of plane `r` (number `plane` in the plane
/// table), six faces wound counter-clockwise seen from outside (the pipelines draw the inside
/// faces); a flat box (the far cloud) gives its two faces only.
fn block_box(
    r: &PlaneRecord,
    plane: u32,
    lo: Vec3,
    hi: Vec3,
    vertices: &mut Vec<CloudVertex>,
    indices: &mut Vec<u32>,
) {
    let (o, u, v, n) = (
        Vec3::from_slice(&r.origin_cell[..3]),
        Vec3::from_slice(&r.u[..3]),
        Vec3::from_slice(&r.v[..3]),
        Vec3::from_slice(&r.n[..3]),
    );
    let (h0, h1) = (lo.z, hi.z);
    let corner = |i: u32| {
        Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { h0 } else { h1 },
        )
    };
    let base = vertices.len() as u32;
    // Model-space corners, for the winding.
    let model = [0, 1, 2, 3, 4, 5, 6, 7].map(|i| {
        let p = corner(i);
        o + u * p.x + v * p.y + n * p.z
    });
    for i in 0..8 {
        let p = corner(i);
        vertices.push(CloudVertex {
            pst: p.to_array(),
            plane,
            block_lo: lo.to_array(),
            block_hi: hi.to_array(),
        });
    }
    // Faces as corner numbers, with their outward direction (plane space).
    let faces: [([u32; 4], Vec3); 6] = [
        ([4, 5, 7, 6], Vec3::Z),
        ([0, 2, 3, 1], -Vec3::Z),
        ([0, 1, 5, 4], -Vec3::Y),
        ([2, 6, 7, 3], Vec3::Y),
        ([0, 4, 6, 2], -Vec3::X),
        ([1, 3, 7, 5], Vec3::X),
    ];
    let flat = h1 <= h0;
    for (k, (f, out)) in faces.iter().enumerate() {
        if flat && k >= 2 {
            break;
        }
        // Counter-clockwise seen from outside in model space (the plane's axes may be either
        // handed).
        let m = |i: u32| model[i as usize];
        let outward = u * out.x + v * out.y + n * out.z;
        let winding = (m(f[1]) - m(f[0])).cross(m(f[2]) - m(f[0])).dot(outward);
        let f = if winding >= 0.0 {
            *f
        } else {
            [f[0], f[3], f[2], f[1]]
        };
        indices.extend([0, 1, 2, 0, 2, 3].map(|i| base + f[i]));
    }
}

impl BillboardCloud {
    /// Uploads every species' clouds and builds the pipelines.
    pub fn new(
        gpu: &Gpu,
        frame: &FrameResources,
        plants: &[Plant],
        baked: &[BillboardCloudBaked],
        draw: &BillboardCloudDrawParams,
        population: &Instances,
        band: BandRange,
    ) -> Result<Self, RenderError> {
        if baked.len() != plants.len() {
            return Err(RenderError::Plant(format!(
                "{} billboard-cloud bakes for {} plants",
                baked.len(),
                plants.len()
            )));
        }
        let tile_near = baked.first().map_or(16, |b| b.clouds[0].tile);
        let tile_far = baked.first().map_or(32, |b| b.clouds[1].tile);
        if baked.iter().any(|b| {
            b.clouds[0].tile != tile_near
                || b.clouds[1].tile != tile_far
                || b.clouds[2].tile != tile_far
        }) {
            return Err(RenderError::Plant(
                "billboard-cloud bakes with different tile sizes — re-bake".into(),
            ));
        }
        let mut gplanes: Vec<[u32; 28]> = Vec::new();
        let (mut cells, mut lists, mut records) = (Vec::new(), Vec::new(), Vec::new());
        let mut vertices: Vec<CloudVertex> = Vec::new();
        let mut indices: Vec<u32> = Vec::new();
        let mut near_tiles: Vec<&Vec<TileLevel>> = Vec::new();
        let mut far_tiles: Vec<&Vec<TileLevel>> = Vec::new();
        let mut parts: [Vec<Part>; LEVELS] = Default::default();
        let mut level_first = [0u32; 4];
        for (level, level_parts) in parts.iter_mut().enumerate() {
            level_first[level] = gplanes.len() as u32;
            for (s, b) in baked.iter().enumerate() {
                let c = &b.clouds[level];
                let (record_offset, list_offset, cell_offset) =
                    (records.len() as u32, lists.len() as u32, cells.len() as u32);
                let first_index = indices.len() as u32;
                for (p, rec) in c.planes.iter().enumerate() {
                    let tiles = if level == 0 {
                        &mut near_tiles
                    } else {
                        &mut far_tiles
                    };
                    let pair = tiles.len() as u32 / 2;
                    tiles.push(&c.lowres[2 * p]);
                    tiles.push(&c.lowres[2 * p + 1]);
                    let mut r: PlaneRecord = *rec;
                    r.grid[2] += cell_offset;
                    let mut raw = [0u32; 28];
                    raw[..24].copy_from_slice(bytemuck::cast_slice(std::slice::from_ref(&r)));
                    raw[24..].copy_from_slice(&[record_offset, pair, list_offset, 0]);
                    let global = gplanes.len() as u32;
                    gplanes.push(raw);
                    for (lo, hi) in occupied_rects(c, rec) {
                        let (h0, h1) = block_heights(c, p, lo, hi);
                        block_box(
                            &r,
                            global,
                            lo.extend(h0),
                            hi.extend(h1),
                            &mut vertices,
                            &mut indices,
                        );
                    }
                }
                cells.extend_from_slice(&c.cells);
                lists.extend_from_slice(&c.lists);
                records.extend_from_slice(&c.records);
                level_parts.push(Part {
                    species: s,
                    planes: first_index..indices.len() as u32,
                });
            }
        }
        level_first[3] = gplanes.len() as u32;
        // Storage bindings must not be empty.
        for v in [&mut cells, &mut lists] {
            if v.is_empty() {
                v.push(0);
            }
        }
        if records.is_empty() {
            records.push(layers::LeafRecord::zeroed());
        }
        if gplanes.is_empty() || vertices.is_empty() {
            return Err(RenderError::Plant(
                "billboard-cloud: no plant has leaves to cluster".into(),
            ));
        }
        let limit = gpu.device.limits().max_storage_buffer_binding_size;
        for (what, bytes) in [
            ("hash cells", cells.len() as u64 * 4),
            ("lists", lists.len() as u64 * 4),
            (
                "leaf records",
                (records.len() * std::mem::size_of::<layers::LeafRecord>()) as u64,
            ),
        ] {
            if bytes > limit {
                return Err(RenderError::Gpu(sylvan_gpu::GpuError::Limit {
                    what: format!("billboard-cloud {what}"),
                    needed: bytes,
                    limit,
                    fix: "lower billboard-cloud cells or use fewer species".into(),
                }));
            }
        }
        let upload = |label, format, tile, data: Vec<Vec<Vec<u8>>>| {
            let refs: Vec<&[Vec<u8>]> = data.iter().map(Vec::as_slice).collect();
            TileAtlas::upload(gpu, label, format, tile, &refs)
        };
        let srgb = wgpu::TextureFormat::Rgba8UnormSrgb;
        let unorm = wgpu::TextureFormat::Rgba8Unorm;
        let near_c = upload(
            "bcloud_near_color",
            srgb,
            tile_near,
            common::tile_chains(&near_tiles, |l| &l.color),
        )?;
        let near_n = upload(
            "bcloud_near_normal",
            unorm,
            tile_near,
            common::tile_chains(&near_tiles, |l| &l.normal),
        )?;
        let far_c = upload(
            "bcloud_far_color",
            srgb,
            tile_far,
            common::tile_chains(&far_tiles, |l| &l.color),
        )?;
        let far_n = upload(
            "bcloud_far_normal",
            unorm,
            tile_far,
            common::tile_chains(&far_tiles, |l| &l.normal),
        )?;
        let params = GpuParams {
            level_first,
            windows: [ListRequest::ALL; LEVELS],
            draw: [
                draw.entries_per_px,
                LEAF_TRANSLUCENCY,
                1.0 / tile_near as f32,
                1.0 / tile_far as f32,
            ],
            atlas_near: [near_c.per_row, near_c.per_layer, near_c.rows, 0],
            atlas_far: [far_c.per_row, far_c.per_layer, far_c.rows, 0],
        };
        let device = &gpu.device;
        let storage = |label, contents: &[u8]| common::storage_buffer(gpu, label, contents);
        let plane_main: Vec<[u32; 24]> = gplanes
            .iter()
            .map(|p| p[..24].try_into().expect("24 words"))
            .collect();
        let plane_extra: Vec<[u32; 4]> = gplanes
            .iter()
            .map(|p| p[24..].try_into().expect("4 words"))
            .collect();
        let planes_buf = storage("bcloud_planes", bytemuck::cast_slice(&plane_main));
        let extra_buf = storage("bcloud_plane_extra", bytemuck::cast_slice(&plane_extra));
        let cells_buf = storage("bcloud_cells", bytemuck::cast_slice(&cells));
        let lists_buf = storage("bcloud_lists", bytemuck::cast_slice(&lists));
        let records_buf = storage("bcloud_records", bytemuck::cast_slice(&records));
        let params_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("bcloud_params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let vertex_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("bcloud_vertices"),
            contents: bytemuck::cast_slice(&vertices),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let index_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("bcloud_indices"),
            contents: bytemuck::cast_slice(&indices),
            usage: wgpu::BufferUsages::INDEX,
        });
        let sampler = common::trilinear_sampler(gpu, "bcloud_sampler");
        let vf = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let fs = wgpu::ShaderStages::FRAGMENT;
        let bind_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("bcloud_layout"),
            entries: &[
                layout::storage(0, vf),
                layout::storage(1, fs),
                layout::storage(2, fs),
                layout::storage(3, fs),
                layout::atlas(4),
                layout::atlas(5),
                layout::atlas(6),
                layout::atlas(7),
                layout::sampler(8, fs, wgpu::SamplerBindingType::Filtering),
                layout::uniform(9, vf),
                layout::storage(10, fs),
            ],
        });
        let views = [near_c.view(), near_n.view(), far_c.view(), far_n.view()];
        let bind = common::bind_group(
            gpu,
            "bcloud_bind",
            &bind_layout,
            &[
                planes_buf.as_entire_binding(),
                cells_buf.as_entire_binding(),
                lists_buf.as_entire_binding(),
                records_buf.as_entire_binding(),
                wgpu::BindingResource::TextureView(&views[0]),
                wgpu::BindingResource::TextureView(&views[1]),
                wgpu::BindingResource::TextureView(&views[2]),
                wgpu::BindingResource::TextureView(&views[3]),
                wgpu::BindingResource::Sampler(&sampler),
                params_buffer.as_entire_binding(),
                extra_buf.as_entire_binding(),
            ],
        );
        let pipes = MeshPipelines::new(gpu, frame);
        let module = sylvan_gpu::shader(gpu, "billboard-cloud", &super::shader_source());
        let buffers = [Some(CloudVertex::LAYOUT), Some(GpuTreeInstance::LAYOUT)];
        let make = |label, pass, vs, fs, layout: &wgpu::BindGroupLayout| {
            pipeline::build(
                gpu,
                &PipelineSpec {
                    label,
                    layouts: &[layout, &bind_layout, &pipes.material_layout],
                    module: &module,
                    vs,
                    fs: Some(fs),
                    buffers: &buffers,
                    pass,
                    frame,
                    // Each box's inside faces: one fragment per pixel, also with the eye
                    // inside the box.
                    cull: Some(wgpu::Face::Front),
                    depth_write: true,
                    blend: None,
                },
            )
        };
        let (main, shadow) = (&frame.main_layout, &frame.shadow_layout);
        let layered = make("bcloud", PassKind::Main, "vs_cloud", "fs_cloud", main);
        let lowres = make(
            "bcloud_lowres",
            PassKind::Main,
            "vs_cloud",
            "fs_cloud_lowres",
            main,
        );
        let layered_shadow = make(
            "bcloud_shadow",
            PassKind::Shadow,
            "vs_cloud_shadow",
            "fs_cloud_shadow",
            shadow,
        );
        let lowres_shadow = make(
            "bcloud_lowres_shadow",
            PassKind::Shadow,
            "vs_cloud_shadow",
            "fs_cloud_lowres_shadow",
            shadow,
        );
        let no_leaves = Mesh::default();
        let species = plants
            .iter()
            .map(|p| SpeciesMeshes::new(gpu, &pipes, p, &p.wood, &no_leaves))
            .collect::<Result<Vec<_>, _>>()?;
        let far_wood = plants
            .iter()
            .map(|p| {
                GpuMesh::new(
                    gpu,
                    &format!("{} far wood", p.name),
                    &simplified_wood(p, draw.far_wood_levels),
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        let static_bytes = [&near_c, &near_n, &far_c, &far_n]
            .iter()
            .map(|a| a.bytes)
            .sum::<u64>()
            + [
                &planes_buf,
                &extra_buf,
                &cells_buf,
                &lists_buf,
                &records_buf,
                &vertex_buf,
                &index_buf,
            ]
            .iter()
            .map(|b| b.size())
            .sum::<u64>();
        let lists = (0..LEVELS)
            .map(|_| Instances::derived(gpu, population.capacity(), population.species_count()))
            .collect();
        let mut me = Self {
            species,
            far_wood,
            pipes,
            layered,
            lowres,
            layered_shadow,
            lowres_shadow,
            bind,
            params_buffer,
            params,
            vertices: vertex_buf,
            indices: index_buf,
            parts,
            draw: draw.clone(),
            band,
            static_bytes,
            lists,
            drawn: None,
            windows: [ListRequest::ALL; LEVELS],
        };
        // Until the first frame: a 1080p camera with a 60° field of view.
        me.windows = me.level_windows(935.0);
        Ok(me)
    }

    /// Each cloud's presence window for a view of `pixels_per_metre` (eye distance of a
    /// switch: the distance where a metre spans `mid_px_per_m` or `far_px_per_m` pixels).
    pub fn level_windows(&self, pixels_per_metre: f32) -> [[f32; 4]; LEVELS] {
        let d_mid = pixels_per_metre / self.draw.mid_px_per_m;
        let d_far = pixels_per_metre / self.draw.far_px_per_m;
        let (lo, hi) = (1.0 - FADE, 1.0 + FADE);
        [
            [-1e30, -1e30, d_mid * lo, d_mid * hi],
            [d_mid * lo, d_mid * hi, d_far * lo, d_far * hi],
            [d_far * lo, d_far * hi, 1e30, 1e30],
        ]
    }

    /// The band's own window (as the `auto` chain fades it), intersected with each cloud's.
    fn composed(&self, w: [f32; 4]) -> [f32; 4] {
        crate::world::intersect_windows(w, self.band.window())
    }

    /// The draws of cloud `level` in order: each species' wood, then each species' planes.
    fn level_draws(&self, level: usize) -> Vec<LevelDraw<'_>> {
        let mut out = Vec::new();
        for (s, sp) in self.species.iter().enumerate() {
            let wood = if level == LEVELS - 1 {
                self.far_wood[s].as_ref()
            } else {
                sp.wood.as_ref()
            };
            if let Some(w) = wood {
                out.push((s, Some(w), None));
            }
        }
        for part in &self.parts[level] {
            if !part.planes.is_empty() {
                out.push((part.species, None, Some(part.planes.clone())));
            }
        }
        out
    }

    fn record_level(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        ctx: &DrawContext<'_>,
        level: usize,
        culled: Option<&crate::world::Culled<'_>>,
    ) -> DrawCounts {
        let shadow = ctx.shadow_cascade().is_some();
        let (wood_pipe, _) = self.pipes.for_pass(shadow);
        let cloud_pipe = match (level == LEVELS - 1, shadow) {
            (false, false) => &self.layered,
            (true, false) => &self.lowres,
            (false, true) => &self.layered_shadow,
            (true, true) => &self.lowres_shadow,
        };
        let list = &self.lists[level];
        let mut counts = DrawCounts::default();
        pass.set_bind_group(0, ctx.frame_bind, &[]);
        for (k, (s, wood, planes)) in self.level_draws(level).into_iter().enumerate() {
            let (instances, n) = match culled {
                Some(c) => match c.instances(ctx.pass, s) {
                    Some(i) => (i, c.listed(ctx.pass, s)),
                    None => continue,
                },
                None => {
                    let r = list.ranges[ctx.pass][s].clone();
                    if r.is_empty() {
                        continue;
                    }
                    (list.buffer().slice(..), r.end - r.start)
                }
            };
            let cpu_range = list.ranges[ctx.pass][s].clone();
            if let Some(w) = wood {
                pass.set_pipeline(wood_pipe);
                pass.set_bind_group(1, &self.species[s].material, &[]);
                pass.set_vertex_buffer(0, w.vertices.slice(..));
                pass.set_vertex_buffer(1, instances);
                pass.set_index_buffer(w.indices.slice(..), wgpu::IndexFormat::Uint32);
                match culled {
                    Some(c) => {
                        let (args, offset) = c.args(ctx.pass, k);
                        pass.draw_indexed_indirect(args, offset);
                    }
                    None => pass.draw_indexed(0..w.index_count, 0, cpu_range.clone()),
                }
                counts.draw_calls += 1;
                counts.triangles += n as u64 * (w.index_count / 3) as u64;
            }
            if let Some(planes) = planes {
                pass.set_pipeline(cloud_pipe);
                pass.set_bind_group(1, &self.bind, &[]);
                pass.set_bind_group(2, &self.species[s].material, &[]);
                pass.set_vertex_buffer(0, self.vertices.slice(..));
                pass.set_vertex_buffer(1, instances);
                pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
                match culled {
                    Some(c) => {
                        let (args, offset) = c.args(ctx.pass, k);
                        pass.draw_indexed_indirect(args, offset);
                    }
                    None => pass.draw_indexed(planes.clone(), 0, cpu_range),
                }
                counts.draw_calls += 1;
                counts.triangles += n as u64 * ((planes.end - planes.start) / 3) as u64;
            }
        }
        counts
    }
}

impl Technique for BillboardCloud {
    fn name(&self) -> &'static str {
        super::ENTRY.name
    }

    /// Per frame: each cloud's window from the view's apparent size; on the CPU path each
    /// cloud's trees with their cross-fade presence.
    fn prepare_frame(
        &mut self,
        gpu: &Gpu,
        _: &mut wgpu::CommandEncoder,
        input: &FrameInput<'_>,
    ) -> Result<(), RenderError> {
        self.windows = self.level_windows(input.pixels_per_metre);
        for l in 0..LEVELS {
            self.params.windows[l] = self.composed(self.windows[l]);
        }
        gpu.queue
            .write_buffer(&self.params_buffer, 0, bytemuck::bytes_of(&self.params));
        if input.instances.total() == 0 {
            // GPU-driven: the cull makes the lists.
            self.drawn = None;
            return Ok(());
        }
        let mut drawn = [0; LEVELS];
        for (l, list) in self.lists.iter_mut().enumerate() {
            let w = self.windows[l];
            let eye = input.eye;
            list.fill_from(gpu, input.instances, |r: &GpuTreeInstance, _| {
                let d = Vec3::from_slice(&r.base_scale[..3]).distance(eye);
                smoothstep(w[0], w[1], d) * (1.0 - smoothstep(w[2], w[3], d))
            });
            drawn[l] = list.drawn();
        }
        self.drawn = Some(drawn);
        Ok(())
    }

    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts {
        let mut counts = DrawCounts::default();
        for level in 0..LEVELS {
            counts += self.record_level(pass, ctx, level, ctx.culled.get(level));
        }
        counts
    }

    fn bytes(&self) -> u64 {
        self.static_bytes
            + self.species.iter().map(SpeciesMeshes::bytes).sum::<u64>()
            + self
                .far_wood
                .iter()
                .flatten()
                .map(GpuMesh::bytes)
                .sum::<u64>()
    }

    fn stats(&self) -> Vec<(&'static str, f64)> {
        let mut s = vec![
            ("mid_from_m", self.windows[1][0] as f64),
            ("far_from_m", self.windows[2][0] as f64),
        ];
        if let Some(d) = self.drawn {
            s.extend([
                ("near_trees", d[0] as f64),
                ("mid_trees", d[1] as f64),
                ("far_trees", d[2] as f64),
            ]);
        }
        s
    }

    /// One request per cloud: each species' wood and planes, by the cloud's window.
    fn list_requests(&self) -> Vec<ListRequest> {
        (0..LEVELS)
            .map(|l| ListRequest {
                technique: super::ENTRY.name,
                layout: ListLayout::default(),
                draws: self
                    .level_draws(l)
                    .into_iter()
                    .map(|(s, wood, planes)| match (wood, planes) {
                        (Some(w), _) => IndirectDraw::indexed(s as u32, w.index_count, 0),
                        (None, Some(p)) => {
                            IndirectDraw::indexed(s as u32, p.end - p.start, p.start)
                        }
                        (None, None) => IndirectDraw::indexed(s as u32, 0, 0),
                    })
                    .collect(),
                window: self.composed(self.windows[l]),
                field_end: None,
            })
            .collect()
    }

    fn list_windows(&self, pixels_per_metre: f32) -> Option<Vec<[f32; 4]>> {
        Some(
            self.level_windows(pixels_per_metre)
                .iter()
                .map(|&w| self.composed(w))
                .collect(),
        )
    }

    fn reallocations(&self) -> u32 {
        0
    }
}
