//! The GPU side of `hbt`: atlas upload, per-frame instance lists with the direction look-ups and
//! reconstruction weights (MNP01 §4.1), and the passes.

use super::bake::{self as hb, HbtBaked};
use super::{HbtParams, HbtProjection};
use crate::RenderError;
use crate::bake::codec::DecodeError;
use crate::directions::{DirectionLut, DirectionSet};
use crate::frame::{CASCADES, FrameResources};
use crate::pipeline::{self, PassKind, PipelineSpec};
use crate::technique::common::{Growable, TileAtlas};
use crate::technique::{DrawContext, DrawCounts, FrameInput, Representation};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::ops::Range;
use sylvan_gpu::{Gpu, layout};
use sylvan_plant::Plant;
use wgpu::util::DeviceExt;

const PASSES: usize = 1 + CASCADES;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuHbtSpecies {
    min: [f32; 4],
    max: [f32; 4],
    info: [u32; 4],
    counts: [u32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuSampleFrame {
    u: [f32; 4],
    v: [f32; 4],
    f: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuHbtAtlas {
    tiles: [u32; 4],
    params: [f32; 4],
}

/// One tree as the `hbt` shader sees it (vertex locations 4–10, per instance).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug, PartialEq)]
struct GpuHbtInstance {
    base_scale: [f32; 4],
    /// cos, sin, tint seed, presence.
    rot: [f32; 4],
    /// The 3 view samples; w: species.
    views: [u32; 4],
    /// The 3 light samples.
    lights: [u32; 4],
    /// Pair weights `w[3·view + light]`; the last 3 unused.
    weights: [f32; 12],
}

impl GpuHbtInstance {
    const LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<GpuHbtInstance>() as u64,
        step_mode: wgpu::VertexStepMode::Instance,
        attributes: &wgpu::vertex_attr_array![
            4 => Float32x4, 5 => Float32x4, 6 => Uint32x4, 7 => Uint32x4,
            8 => Float32x4, 9 => Float32x4, 10 => Float32x4
        ],
    };
}

/// The prepared MNP01 technique (top level).
pub struct Hbt {
    params: HbtParams,
    /// MNP01 §4.1's direction → 3 samples tables (same results as `DirectionSet::nearest3`,
    /// ~3× faster on the CPU).
    views: DirectionLut,
    lights: DirectionLut,
    /// Model-space bounding-box centre per species.
    centres: Vec<Vec3>,
    pipeline: wgpu::RenderPipeline,
    shadow_pipeline: wgpu::RenderPipeline,
    bind: wgpu::BindGroup,
    static_bytes: u64,
    // Per frame (reused; nothing is allocated once the vectors have grown).
    instances: Growable,
    staging: Vec<GpuHbtInstance>,
    sort: Vec<(f32, GpuHbtInstance)>,
    ranges: [Range<u32>; PASSES],
}

impl Hbt {
    /// Instance-buffer re-allocations so far.
    pub fn reallocations(&self) -> u32 {
        self.instances.reallocations
    }
}

/// World direction → model space of a tree rotated by (cos, sin) about Y.
fn to_model_dir(d: Vec3, c: f32, s: f32) -> Vec3 {
    Vec3::new(c * d.x - s * d.z, d.y, s * d.x + c * d.z)
}

fn to_world_dir(d: Vec3, c: f32, s: f32) -> Vec3 {
    Vec3::new(c * d.x + s * d.z, d.y, -s * d.x + c * d.z)
}

impl Representation for Hbt {
    const NAME: &'static str = "hbt";
    const FORMAT_VERSION: u32 = hb::FORMAT_VERSION;
    type Params = HbtParams;
    type Baked = HbtBaked;

    fn input_hash(plant: &Plant, params: &HbtParams) -> u64 {
        hb::input_hash(plant, params)
    }

    fn bake(
        gpu: &Gpu,
        plant: &Plant,
        params: &HbtParams,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<HbtBaked, RenderError> {
        hb::bake(gpu, plant, params, progress)
    }

    fn encode(baked: &HbtBaked) -> Vec<u8> {
        baked.encode()
    }

    fn decode(bytes: &[u8]) -> Result<HbtBaked, DecodeError> {
        HbtBaked::decode(bytes)
    }

    fn prepare(
        gpu: &Gpu,
        frame: &FrameResources,
        plants: &[Plant],
        baked: &[HbtBaked],
        params: &HbtParams,
    ) -> Result<Self, RenderError> {
        params.validate()?;
        if baked.len() != plants.len() {
            return Err(RenderError::Plant(format!(
                "{} baked BTFs for {} plants",
                baked.len(),
                plants.len()
            )));
        }
        let option = |e: crate::directions::DirectionError| RenderError::Option(e.to_string());
        let views = DirectionSet::new(params.view_level).map_err(option)?;
        let lights = DirectionSet::new(params.light_level).map_err(option)?;
        let (nv, nl) = (views.len() as u32, lights.len() as u32);
        let tile = params.tile;
        let mut gpu_species = Vec::with_capacity(plants.len());
        let mut frames = Vec::new();
        let mut tiles: Vec<&[Vec<u8>]> = Vec::new();
        let mut centres = Vec::with_capacity(plants.len());
        for (s, (plant, b)) in plants.iter().zip(baked).enumerate() {
            if b.tile != tile
                || b.view_level != params.view_level
                || b.light_level != params.light_level
            {
                return Err(RenderError::Plant(format!(
                    "{}: baked BTF does not match the parameters (tile {} vs {tile}, levels {}/{} vs {}/{}) — re-bake",
                    plant.name,
                    b.tile,
                    b.view_level,
                    b.light_level,
                    params.view_level,
                    params.light_level
                )));
            }
            let (min, max) = (Vec3::from(b.bbox_min), Vec3::from(b.bbox_max));
            // Species sharing a plant share its images (the bake gives them equal assets).
            if let Some(same) = baked[..s].iter().position(|o| o == b) {
                gpu_species.push(gpu_species[same]);
                centres.push(centres[same]);
                continue;
            }
            let first_frame = frames.len() as u32;
            for &d in views.directions() {
                let f = hb::view_frame(d, min, max, tile);
                frames.push(GpuSampleFrame {
                    u: f.u.extend(f.half.x).to_array(),
                    v: f.v.extend(f.half.y).to_array(),
                    f: f.f.extend(f.half.z).to_array(),
                });
            }
            let first_tile = tiles.len() as u32;
            tiles.extend(b.direct.iter().map(|m| m.as_slice()));
            tiles.extend(b.ambient.iter().map(|m| m.as_slice()));
            gpu_species.push(GpuHbtSpecies {
                min: min.extend((max - min).length() * 0.5).to_array(),
                max: max.extend(0.0).to_array(),
                info: [first_tile, nl, first_tile + nv * nl, first_frame],
                counts: [nv, 0, 0, 0],
            });
            centres.push((min + max) * 0.5);
        }
        let device = &gpu.device;
        let atlas = TileAtlas::upload(
            gpu,
            "hbt_atlas",
            wgpu::TextureFormat::Rgba8UnormSrgb,
            tile,
            &tiles,
        )?;
        let uniform = GpuHbtAtlas {
            tiles: [
                tile,
                atlas.per_row,
                atlas.per_layer,
                (params.projection == HbtProjection::Cross) as u32,
            ],
            params: [
                1.0 / atlas.per_row as f32,
                1.0 / atlas.rows as f32,
                0.0,
                0.0,
            ],
        };
        let storage = |label, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let species_buffer = storage("hbt_species", bytemuck::cast_slice(&gpu_species));
        let frame_buffer = storage("hbt_frames", bytemuck::cast_slice(&frames));
        let atlas_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("hbt_atlas_params"),
            contents: bytemuck::bytes_of(&uniform),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("hbt_sampler"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            // No anisotropy (see the geometry technique: ~1000× slower on lavapipe).
            ..Default::default()
        });
        let vf = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let storage_entry = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: vf,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: true },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let bind_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hbt_layout"),
            entries: &[
                storage_entry(0),
                storage_entry(1),
                layout::texture(
                    2,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::TextureSampleType::Float { filterable: true },
                    wgpu::TextureViewDimension::D2Array,
                ),
                layout::sampler(
                    3,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::SamplerBindingType::Filtering,
                ),
                layout::uniform(4, vf),
            ],
        });
        let atlas_view = atlas.view();
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hbt_bind"),
            layout: &bind_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: species_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: frame_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&atlas_view),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::Sampler(&sampler),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: atlas_buffer.as_entire_binding(),
                },
            ],
        });
        let module =
            sylvan_gpu::shader(gpu, "hbt", &pipeline::with_frame(include_str!("hbt.wgsl")));
        let buffers = [None, Some(GpuHbtInstance::LAYOUT)];
        let premultiplied = wgpu::BlendState {
            color: wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::One,
                dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
                operation: wgpu::BlendOperation::Add,
            },
            alpha: wgpu::BlendComponent::OVER,
        };
        let main = pipeline::build(
            gpu,
            &PipelineSpec {
                label: "hbt",
                layouts: &[&frame.main_layout, &bind_layout],
                module: &module,
                vs: "vs_hbt",
                fs: Some("fs_hbt"),
                buffers: &buffers,
                pass: PassKind::Main,
                cull: None,
                depth_write: false,
                blend: Some(premultiplied),
            },
        );
        let shadow = pipeline::build(
            gpu,
            &PipelineSpec {
                label: "hbt_shadow",
                layouts: &[&frame.shadow_layout, &bind_layout],
                module: &module,
                vs: "vs_hbt_shadow",
                fs: Some("fs_hbt_shadow"),
                buffers: &buffers,
                pass: PassKind::Shadow,
                cull: None,
                depth_write: true,
                blend: None,
            },
        );
        let static_bytes =
            atlas.bytes + species_buffer.size() + frame_buffer.size() + atlas_buffer.size();
        Ok(Self {
            params: params.clone(),
            views: DirectionLut::new(&views, DirectionLut::DEFAULT_RESOLUTION).map_err(option)?,
            lights: DirectionLut::new(&lights, DirectionLut::DEFAULT_RESOLUTION).map_err(option)?,
            centres,
            pipeline: main,
            shadow_pipeline: shadow,
            bind,
            static_bytes,
            instances: Growable::new(gpu, "hbt_instances", 1 << 16),
            staging: Vec::new(),
            sort: Vec::new(),
            ranges: std::array::from_fn(|_| 0..0),
        })
    }

    fn update(&mut self, gpu: &Gpu, input: &FrameInput<'_>) -> Result<(), RenderError> {
        self.staging.clear();
        let sun = input.sun_dir;
        let light = self
            .params
            .fixed_light
            .map_or(sun, |l| Vec3::from(l).normalize());
        for pass in 0..PASSES {
            self.sort.clear();
            for (s, centre) in self.centres.iter().enumerate() {
                for rec in input.instances.records(pass, s) {
                    let (c, sn) = (rec.rot[0], rec.rot[1]);
                    let base = Vec3::new(rec.base_scale[0], rec.base_scale[1], rec.base_scale[2]);
                    let world_centre = base + to_world_dir(*centre * rec.base_scale[3], c, sn);
                    let mut inst = GpuHbtInstance {
                        base_scale: rec.base_scale,
                        rot: rec.rot,
                        views: [0, 0, 0, s as u32],
                        lights: [0; 4],
                        weights: [0.0; 12],
                    };
                    let eye = input.eye - world_centre;
                    if pass == 0 {
                        // MNP01 §4.1: 3 view × 3 light samples, products of barycentrics.
                        let (v, vw) = self.views.lookup(to_model_dir(eye, c, sn));
                        let (l, lw) = self.lights.lookup(to_model_dir(light, c, sn));
                        let w = hb::reconstruction_weights(vw, lw, self.params.min_weight);
                        inst.views[..3].copy_from_slice(&v);
                        inst.lights[..3].copy_from_slice(&l);
                        inst.weights[..9].copy_from_slice(&w);
                    } else {
                        // Shadow casters are seen from the sun: only coverage matters, so the
                        // view weights go in the first column.
                        let (v, vw) = self.views.lookup(to_model_dir(sun, c, sn));
                        inst.views[..3].copy_from_slice(&v);
                        for (i, w) in vw.iter().enumerate() {
                            inst.weights[3 * i] = *w;
                        }
                    }
                    self.sort.push((eye.length_squared(), inst));
                }
            }
            if pass == 0 {
                // Back to front: blending needs the far trees first.
                self.sort.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
            }
            let start = self.staging.len() as u32;
            self.staging.extend(self.sort.iter().map(|x| x.1));
            self.ranges[pass] = start..self.staging.len() as u32;
        }
        self.instances
            .write(gpu, bytemuck::cast_slice(&self.staging))
    }

    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts {
        self.record(pass, ctx, false)
    }

    fn draw_shadow(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts {
        self.record(pass, ctx, true)
    }

    fn bytes(&self) -> u64 {
        self.static_bytes + self.instances.buffer.size()
    }
}

impl Hbt {
    fn record(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        ctx: &DrawContext<'_>,
        shadow: bool,
    ) -> DrawCounts {
        let r = self.ranges[ctx.pass].clone();
        if r.is_empty() {
            return DrawCounts::default();
        }
        let quads = if !shadow && self.params.projection == HbtProjection::Cross {
            3
        } else {
            1
        };
        pass.set_bind_group(0, ctx.frame_bind, &[]);
        pass.set_pipeline(if shadow {
            &self.shadow_pipeline
        } else {
            &self.pipeline
        });
        pass.set_bind_group(1, &self.bind, &[]);
        pass.set_vertex_buffer(1, self.instances.buffer.slice(..));
        let n = (r.end - r.start) as u64;
        pass.draw(0..quads * 6, r);
        DrawCounts {
            draw_calls: 1,
            triangles: n * quads as u64 * 2,
        }
    }
}
