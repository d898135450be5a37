//! The GPU side of `boxtree`: atlas upload, per-frame traversal into instance lists, passes.

use super::bake::{BakedBox, BoxTreeBaked};
use super::gpu::{GpuTraversal, SpeciesBoxes};
use super::traverse::{self, LodView, Placement};
use super::{BoxTreeBakeParams, BoxTreeDrawParams, MAX_BOXES};
use crate::RenderError;
use crate::bake::views::PlaneLayout;
use crate::frame::{CASCADES, FrameResources};
use crate::instances::GpuTreeInstance;
use crate::technique::common::{self, Growable, TileAtlas};
use crate::technique::geometry::{LEAF_TRANSLUCENCY, MeshPipelines, SpeciesMeshes};
use crate::technique::{DrawContext, DrawCounts, FrameInput, Technique};
use crate::world::{Culled, IndirectDraw};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::ops::Range;
use sylvan_gpu::{Gpu, layout};
use sylvan_plant::{Mesh, Plant};
use wgpu::util::DeviceExt;

const PASSES: usize = 1 + CASCADES;
/// Shadow-map texels a box texel may cover before the box opens in a cascade, for trees whose
/// shadows fall outside it (the 3×3 PCF footprint).
pub(super) const SHADOW_FOOTPRINT_TEXELS: f32 = 3.0;
const MAX_PLANES: usize = 6;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Default)]
struct GpuPlane {
    centre: [f32; 4],
    u: [f32; 4],
    v: [f32; 4],
    f: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuBox {
    planes: [GpuPlane; MAX_PLANES],
    plant_min: [f32; 4],
    plant_max: [f32; 4],
    info: [u32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuAtlas {
    tiles: [u32; 4],
    params: [f32; 4],
}

/// One box drawn as images by one tree (vertex locations 4–6, per instance).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug, PartialEq)]
pub(super) struct GpuImpostor {
    base_scale: [f32; 4],
    /// cos, sin, tint seed, presence.
    rot: [f32; 4],
    box_index: u32,
    _pad: [u32; 3],
}

impl GpuImpostor {
    const LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<GpuImpostor>() as u64,
        step_mode: wgpu::VertexStepMode::Instance,
        attributes: &wgpu::vertex_attr_array![4 => Float32x4, 5 => Float32x4, 6 => Uint32],
    };
}

struct Species {
    meshes: SpeciesMeshes,
    boxes: Vec<BakedBox>,
    /// Index of this species' first box in the global box buffer.
    box_base: u32,
    bake_wood: bool,
    /// Whole wood index range (drawn for every tree when wood is not baked).
    wood_all: Range<u32>,
}

/// The prepared LCV04 technique.
pub struct BoxTree {
    draw: BoxTreeDrawParams,
    species: Vec<Species>,
    pipes: MeshPipelines,
    impostor: wgpu::RenderPipeline,
    impostor_shadow: wgpu::RenderPipeline,
    bind: wgpu::BindGroup,
    planes: u32,
    static_bytes: u64,
    preview: image::RgbaImage,
    // Per frame (reused; nothing is allocated once the vectors have grown).
    impostors: Growable,
    residual: Growable,
    imp_staging: Vec<GpuImpostor>,
    imp_sort: Vec<(f32, GpuImpostor)>,
    res_lists: Vec<Vec<GpuTreeInstance>>,
    res_staging: Vec<GpuTreeInstance>,
    stack: Vec<(u32, f32)>,
    imp_ranges: [Range<u32>; PASSES],
    /// `res_ranges[pass][global box]`.
    res_ranges: Vec<Vec<Range<u32>>>,
    /// The GPU-driven frame's traversal (made on the first frame drawn from the world).
    traversal: Option<GpuTraversal>,
}

/// One row per plant of its root box's images, premultiplied colour over mid-grey.
fn preview(baked: &[BoxTreeBaked], images: usize) -> image::RgbaImage {
    let tile = baked.first().map_or(1, |b| b.tile);
    let mut img = image::RgbaImage::from_pixel(
        (tile + 2) * images.max(1) as u32,
        (tile + 2) * baked.len().max(1) as u32,
        image::Rgba([40, 40, 40, 255]),
    );
    for (row, b) in baked.iter().enumerate() {
        for (col, levels) in b.tiles.iter().take(images).enumerate() {
            let Some(l) = levels.first() else { continue };
            for y in 0..l.size {
                for x in 0..l.size {
                    let i = ((y * l.size + x) * 4) as usize;
                    let a = l.color[i + 3] as u32;
                    let px = |c: u8| (c as u32 + (255 - a) * 128 / 255).min(255) as u8;
                    img.put_pixel(
                        col as u32 * (tile + 2) + 1 + x,
                        row as u32 * (tile + 2) + 1 + y,
                        image::Rgba([px(l.color[i]), px(l.color[i + 1]), px(l.color[i + 2]), 255]),
                    );
                }
            }
        }
    }
    img
}

/// Depth of box `i` in its box tree (the root is 0).
fn depth(boxes: &[BakedBox], mut i: usize) -> u32 {
    let mut d = 0;
    while let Some(p) = boxes.get(i).map(|b| b.parent).filter(|&p| p != u32::MAX) {
        i = p as usize;
        d += 1;
    }
    d
}

fn reordered(mesh: &Mesh, indices: &[u32]) -> Mesh {
    Mesh {
        indices: indices.to_vec(),
        ..mesh.clone()
    }
}

impl BoxTree {
    /// Uploads every species' box images into one atlas and builds the pipelines.
    pub fn new(
        gpu: &Gpu,
        frame: &FrameResources,
        plants: &[Plant],
        baked: &[BoxTreeBaked],
        params: &BoxTreeBakeParams,
        draw: &BoxTreeDrawParams,
    ) -> Result<Self, RenderError> {
        if baked.len() != plants.len() {
            return Err(RenderError::Plant(format!(
                "{} baked box trees for {} plants",
                baked.len(),
                plants.len()
            )));
        }
        let device = &gpu.device;
        let tile = params.tile;
        let layout = params.layout;
        let images = layout.images();
        let planes_per_box = layout.normals().len() as u32;
        let mut species = Vec::with_capacity(plants.len());
        let mut gpu_boxes: Vec<GpuBox> = Vec::new();
        let mut tiles: Vec<&Vec<crate::bake::image::TileLevel>> = Vec::new();
        let pipes = MeshPipelines::new(gpu, frame);
        for (plant, b) in plants.iter().zip(baked) {
            if b.tile != tile || b.layout != layout || b.boxes.len() as u32 > MAX_BOXES {
                return Err(RenderError::Plant(format!(
                    "{}: baked box tree does not match the parameters (tile {} vs {tile}, layout {} vs {}) — re-bake",
                    plant.name,
                    b.tile,
                    b.layout.name(),
                    layout.name()
                )));
            }
            let box_base = gpu_boxes.len() as u32;
            for (i, bx) in b.boxes.iter().enumerate() {
                let mut planes = [GpuPlane::default(); MAX_PLANES];
                let frames = layout.frames(Vec3::from(bx.min), Vec3::from(bx.max));
                for (p, f) in planes.iter_mut().zip(frames) {
                    *p = GpuPlane {
                        centre: f.centre.extend(f.half.z).to_array(),
                        u: f.u.extend(f.half.x).to_array(),
                        v: f.v.extend(f.half.y).to_array(),
                        f: f.f.extend(0.0).to_array(),
                    };
                }
                gpu_boxes.push(GpuBox {
                    planes,
                    plant_min: Vec3::from(plant.bbox_min).extend(0.0).to_array(),
                    plant_max: Vec3::from(plant.bbox_max).extend(0.0).to_array(),
                    info: [
                        tiles.len() as u32 + i as u32 * images,
                        layout.sides(),
                        planes_per_box,
                        (layout == PlaneLayout::Billboard) as u32 | depth(&b.boxes, i) << 1,
                    ],
                });
            }
            tiles.extend(b.tiles.iter());
            let leaves = reordered(&plant.leaves, &b.leaf_indices);
            let wood = reordered(&plant.wood, &b.wood_indices);
            species.push(Species {
                meshes: SpeciesMeshes::new(gpu, &pipes, plant, &wood, &leaves)?,
                boxes: b.boxes.clone(),
                box_base,
                bake_wood: b.bake_wood,
                wood_all: 0..b.wood_indices.len() as u32,
            });
        }
        // The atlas: tiles packed row-major into layers, each tile with its own mips; colour
        // and normal/depth share the layout.
        let pick = |f: fn(&crate::bake::image::TileLevel) -> &Vec<u8>| -> Vec<Vec<Vec<u8>>> {
            tiles
                .iter()
                .map(|levels| levels.iter().map(|l| f(l).clone()).collect())
                .collect()
        };
        let (color_data, normal_data) = (pick(|l| &l.color), pick(|l| &l.normal));
        let color = TileAtlas::upload(
            gpu,
            "boxtree_atlas_color",
            wgpu::TextureFormat::Rgba8UnormSrgb,
            tile,
            &color_data.iter().map(Vec::as_slice).collect::<Vec<_>>(),
        )?;
        let normal = TileAtlas::upload(
            gpu,
            "boxtree_atlas_normal",
            wgpu::TextureFormat::Rgba8Unorm,
            tile,
            &normal_data.iter().map(Vec::as_slice).collect::<Vec<_>>(),
        )?;
        let atlas_bytes = color.bytes + normal.bytes;
        let atlas = GpuAtlas {
            tiles: [tile, color.per_row, color.per_layer, 0],
            params: [
                LEAF_TRANSLUCENCY,
                1.0 / color.per_row as f32,
                1.0 / color.rows as f32,
                0.0,
            ],
        };
        let box_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("boxtree_boxes"),
            contents: bytemuck::cast_slice(&gpu_boxes),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let atlas_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("boxtree_atlas"),
            contents: bytemuck::bytes_of(&atlas),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let sampler = common::trilinear_sampler(gpu, "boxtree_sampler");
        let vf = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let bind_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("boxtree_layout"),
            entries: &[
                layout::storage(0, vf),
                layout::atlas(1),
                layout::atlas(2),
                layout::sampler(
                    3,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::SamplerBindingType::Filtering,
                ),
                layout::uniform(4, vf),
            ],
        });
        let (cv, nv) = (color.view(), normal.view());
        let bind = common::bind_group(
            gpu,
            "boxtree_bind",
            &bind_layout,
            &[
                box_buffer.as_entire_binding(),
                wgpu::BindingResource::TextureView(&cv),
                wgpu::BindingResource::TextureView(&nv),
                wgpu::BindingResource::Sampler(&sampler),
                atlas_buffer.as_entire_binding(),
            ],
        );
        let module = sylvan_gpu::shader(gpu, "boxtree", &super::shader_source());
        let (impostor, impostor_shadow) = common::image_pipelines(
            gpu,
            frame,
            &module,
            "impostor",
            &[None, Some(GpuImpostor::LAYOUT)],
            &bind_layout,
        );
        let total_boxes = gpu_boxes.len();
        let preview = preview(baked, images as usize);
        let static_bytes =
            atlas_bytes + box_buffer.size() + species.iter().map(|s| s.meshes.bytes()).sum::<u64>();
        Ok(Self {
            draw: draw.clone(),
            species,
            pipes,
            impostor,
            impostor_shadow,
            bind,
            planes: planes_per_box,
            static_bytes,
            preview,
            impostors: Growable::new(gpu, "boxtree_impostors", 1 << 16),
            residual: Growable::new(gpu, "boxtree_residual", 1 << 16),
            imp_staging: Vec::new(),
            imp_sort: Vec::new(),
            res_lists: vec![Vec::new(); total_boxes],
            res_staging: Vec::new(),
            stack: Vec::new(),
            imp_ranges: std::array::from_fn(|_| 0..0),
            res_ranges: vec![vec![0..0; total_boxes]; PASSES],
            traversal: None,
        })
    }
}

impl Technique for BoxTree {
    fn name(&self) -> &'static str {
        super::ENTRY.name
    }

    /// Per frame: each culled tree's box-tree traversal per pass — on the GPU from the
    /// world's lists (`GpuTraversal`), or on the CPU from the frame's instances, sorted and
    /// uploaded.
    fn prepare_frame(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        input: &FrameInput<'_>,
    ) -> Result<(), RenderError> {
        if let Some(culled) = input.culled.first() {
            if self.traversal.is_none() {
                let species: Vec<SpeciesBoxes<'_>> = self
                    .species
                    .iter()
                    .map(|s| SpeciesBoxes {
                        boxes: &s.boxes,
                        box_base: s.box_base,
                        bake_wood: s.bake_wood,
                    })
                    .collect();
                self.traversal = Some(GpuTraversal::new(gpu, &species, self.planes * 6)?);
            }
            let traversal = self.traversal.as_mut().expect("made above");
            return traversal.record(gpu, encoder, culled, input, self.species.len(), &self.draw);
        }
        let camera = LodView {
            eye: input.eye,
            pixels_per_metre: input.pixels_per_metre / self.draw.texel_pixels,
            footprint: None,
            band: self.draw.band,
        };
        self.imp_staging.clear();
        self.res_staging.clear();
        for pass in 0..PASSES {
            // Cascade c shadows receivers between the previous cascade's far distance and its
            // own (a 10% margin beyond): trees outside that range never open a box finer than
            // the cascade texels' PCF footprint there. The camera pass uses the camera's levels.
            let view = match pass {
                0 => camera.clone(),
                p => LodView {
                    footprint: Some((
                        input.shadow_texel_m[p - 1] * SHADOW_FOOTPRINT_TEXELS
                            / self.draw.texel_pixels,
                        if p == 1 {
                            0.0
                        } else {
                            input.cascade_far[p - 2]
                        }..input.cascade_far[p - 1] * 1.1,
                    )),
                    ..camera.clone()
                },
            };
            self.imp_sort.clear();
            for list in &mut self.res_lists {
                list.clear();
            }
            for (s, sp) in self.species.iter().enumerate() {
                for rec in input.instances.records(pass, s) {
                    let at = Placement {
                        base: Vec3::new(rec.base_scale[0], rec.base_scale[1], rec.base_scale[2]),
                        scale: rec.base_scale[3],
                        cos: rec.rot[0],
                        sin: rec.rot[1],
                    };
                    let (imp, res) = (&mut self.imp_sort, &mut self.res_lists);
                    traverse::traverse(
                        &sp.boxes,
                        &at,
                        &view,
                        rec.rot[3],
                        &mut self.stack,
                        |b, w, d| {
                            imp.push((
                                d,
                                GpuImpostor {
                                    base_scale: rec.base_scale,
                                    rot: [rec.rot[0], rec.rot[1], rec.rot[2], w],
                                    box_index: sp.box_base + b,
                                    _pad: [0; 3],
                                },
                            ))
                        },
                        |b, w| {
                            let mut r = *rec;
                            r.rot[3] = w;
                            res[(sp.box_base + b) as usize].push(r);
                        },
                    );
                }
            }
            if pass == 0 {
                // Back to front: blending needs the far impostors first.
                self.imp_sort.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
            }
            let start = self.imp_staging.len() as u32;
            self.imp_staging.extend(self.imp_sort.iter().map(|x| x.1));
            self.imp_ranges[pass] = start..self.imp_staging.len() as u32;
            for (g, list) in self.res_lists.iter().enumerate() {
                let start = self.res_staging.len() as u32;
                self.res_staging.extend_from_slice(list);
                self.res_ranges[pass][g] = start..self.res_staging.len() as u32;
            }
        }
        self.impostors
            .write(gpu, bytemuck::cast_slice(&self.imp_staging))?;
        self.residual
            .write(gpu, bytemuck::cast_slice(&self.res_staging))?;
        Ok(())
    }

    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts {
        self.record(pass, ctx, ctx.shadow_cascade().is_some())
    }

    fn bytes(&self) -> u64 {
        self.static_bytes
            + self.impostors.buffer.size()
            + self.residual.buffer.size()
            + self.traversal.as_ref().map_or(0, GpuTraversal::bytes)
    }

    /// One draw per species: all its wood when wood is not baked into the images, else none
    /// (0 vertices) — the traversal reads each list's count from these arguments.
    fn indirect_draws(&self) -> Vec<IndirectDraw> {
        self.species
            .iter()
            .enumerate()
            .map(|(s, sp)| match (&sp.meshes.wood, sp.bake_wood) {
                (Some(_), false) => IndirectDraw::indexed(s as u32, sp.wood_all.end, 0),
                _ => IndirectDraw::vertices(s as u32, 0),
            })
            .collect()
    }

    fn finish_frame(&mut self, gpu: &Gpu) -> Result<bool, RenderError> {
        match &mut self.traversal {
            Some(t) => t.finish(gpu),
            None => Ok(false),
        }
    }

    fn own_triangles(&self, pass: usize) -> u64 {
        let Some(t) = &self.traversal else { return 0 };
        let mut tris = t.impostors(pass) as u64 * self.planes as u64 * 2;
        for sp in &self.species {
            for (b, bx) in sp.boxes.iter().enumerate() {
                let mut per_tree = bx.residual_leaves.len() as u64 / 3;
                if sp.bake_wood {
                    per_tree += bx.residual_wood.len() as u64 / 3;
                }
                tris += t.opened(pass, sp.box_base + b as u32) as u64 * per_tree;
            }
        }
        tris
    }

    fn stats(&self) -> Vec<(&'static str, f64)> {
        match &self.traversal {
            Some(t) => vec![
                ("impostors", t.impostors(0) as f64),
                ("records_dropped", t.dropped as f64),
                ("list_growths", t.reallocations as f64),
            ],
            None => Vec::new(),
        }
    }

    fn atlas_preview(&self) -> Option<&image::RgbaImage> {
        Some(&self.preview)
    }

    fn reallocations(&self) -> u32 {
        self.impostors.reallocations
            + self.residual.reallocations
            + self.traversal.as_ref().map_or(0, |t| t.reallocations)
    }
}

impl BoxTree {
    /// Each species with a wood (`wood`) or leaf mesh, with that mesh.
    fn meshes(
        &self,
        wood: bool,
    ) -> impl Iterator<Item = (usize, &Species, &crate::technique::geometry::GpuMesh)> {
        self.species.iter().enumerate().filter_map(move |(s, sp)| {
            let mesh = if wood {
                &sp.meshes.wood
            } else {
                &sp.meshes.leaves
            };
            mesh.as_ref().map(|m| (s, sp, m))
        })
    }

    fn record(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        ctx: &DrawContext<'_>,
        shadow: bool,
    ) -> DrawCounts {
        if let (Some(culled), Some(t)) = (ctx.culled.first(), &self.traversal) {
            return self.record_indirect(pass, ctx, culled, t, shadow);
        }
        let mut counts = DrawCounts::default();
        let p = ctx.pass;
        pass.set_bind_group(0, ctx.frame_bind, &[]);
        // Opaque first: the geometry of opened boxes (or all wood, when wood is not baked).
        let (wood, leaf) = self.pipes.for_pass(shadow);
        for (pipeline, is_wood) in [(wood, true), (leaf, false)] {
            pass.set_pipeline(pipeline);
            for (s, sp, mesh) in self.meshes(is_wood) {
                pass.set_bind_group(1, &sp.meshes.material, &[]);
                if is_wood && !sp.bake_wood {
                    counts += mesh.draw_range(
                        pass,
                        sp.wood_all.clone(),
                        ctx.instances.buffer(),
                        ctx.ranges[s].clone(),
                    );
                    continue;
                }
                for (b, bx) in sp.boxes.iter().enumerate() {
                    let range = if is_wood {
                        &bx.residual_wood
                    } else {
                        &bx.residual_leaves
                    };
                    let inst = self.res_ranges[p][(sp.box_base + b as u32) as usize].clone();
                    counts += mesh.draw_range(pass, range.clone(), &self.residual.buffer, inst);
                }
            }
        }
        // Then every impostor of every species in one draw (sorted back to front).
        let r = self.imp_ranges[p].clone();
        if !r.is_empty() {
            pass.set_pipeline(if shadow {
                &self.impostor_shadow
            } else {
                &self.impostor
            });
            pass.set_bind_group(1, &self.bind, &[]);
            pass.set_vertex_buffer(1, self.impostors.buffer.slice(..));
            let n = r.end - r.start;
            pass.draw(0..self.planes * 6, r);
            counts += DrawCounts {
                draw_calls: 1,
                triangles: n as u64 * self.planes as u64 * 2,
            };
        }
        counts
    }
}

impl BoxTree {
    /// The GPU-driven pass: the opened boxes' geometry and the impostors from the
    /// traversal's lists, every draw indirect (the counts are the last frame's read back).
    fn record_indirect(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        ctx: &DrawContext<'_>,
        culled: &Culled<'_>,
        t: &GpuTraversal,
        shadow: bool,
    ) -> DrawCounts {
        let mut counts = DrawCounts::default();
        let p = ctx.pass;
        pass.set_bind_group(0, ctx.frame_bind, &[]);
        let (wood, leaf) = self.pipes.for_pass(shadow);
        for (pipeline, is_wood) in [(wood, true), (leaf, false)] {
            pass.set_pipeline(pipeline);
            for (s, sp, mesh) in self.meshes(is_wood) {
                pass.set_bind_group(1, &sp.meshes.material, &[]);
                pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                if is_wood && !sp.bake_wood {
                    let Some(instances) = culled.instances(p, s) else {
                        continue;
                    };
                    pass.set_vertex_buffer(1, instances);
                    let (args, offset) = culled.args(p, s);
                    pass.draw_indexed_indirect(args, offset);
                    counts.draw_calls += 1;
                    continue;
                }
                pass.set_vertex_buffer(1, t.out_res.slice(..));
                // One multi-draw for the species' opened boxes (#15).
                let (args, first, draws) = t.residual_run(p, s, !is_wood);
                pass.multi_draw_indexed_indirect(args, first, draws);
                counts.draw_calls += 1;
            }
        }
        pass.set_pipeline(if shadow {
            &self.impostor_shadow
        } else {
            &self.impostor
        });
        pass.set_bind_group(1, &self.bind, &[]);
        pass.set_vertex_buffer(1, t.out_imp.slice(..));
        let (args, offset) = t.impostor_args(p);
        pass.draw_indirect(args, offset);
        counts.draw_calls += 1;
        counts.triangles = self.own_triangles(p);
        counts
    }
}
