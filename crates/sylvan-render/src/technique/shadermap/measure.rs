//! Measuring the ground tables by rendering z-field forest patches (BN12 §6, "the functions
//! 𝔾, 𝕋, 𝔻, 𝔼 are precomputed by rendering forest patches").
//!
//! The patch is a periodic Poisson tile of side `patch_radii · r` (`r` the scene's pattern
//! radius), thinned per density node with nested thresholds (every tree of a sparser node is in
//! the denser ones), species drawn by the mix's weights, heights uniform in each species'
//! range, rotations and tints random. For every direction of the table's grid
//! (`1 + (θ − 2) · φ` of them: the zenith, and 90° is analytic: no ground is seen through an
//! endless forest) the patch is drawn with `zfield`'s own atlases and vertex shader through a
//! sheared ground-aligned orthographic projection (pixel (i, j) is ground texel (i, j) in every
//! direction, and copies of the tile cover the wrap-around exactly) into a mask of the ground
//! texels some tree hides (`measure.wgsl`). The masks are read back once per batch and the
//! tables are bit counts: `Gd(θ) = |visible(θ, 0)| / N`, `G(θv, θl, φ) = |visible(θv, 0) ∧
//! visible(θl, φ)| / N`. A view mask is the light mask of the same direction, so view and light
//! share one set of renders.

use super::ShaderMapBakeParams;
use super::tables::{GroundTables, real_zenith};
use crate::RenderError;
use crate::bake::codec::Fnv64;
use crate::bake::{BakeReport, CachePolicy, cache};
use crate::directions::HemiGrid;
use crate::frame::GpuFrame;
use crate::instances::GpuTreeInstance;
use crate::technique::zfield::{
    ZFieldBake, ZFieldBakeParams, ZFieldBaked, ZFieldBindings, ZFieldDrawParams,
};
use glam::{Mat4, Vec2, Vec3, Vec4};
use sylvan_gpu::{Gpu, layout};
use sylvan_plant::Plant;
use sylvan_plant::rng::Rng;
use wgpu::util::DeviceExt;

/// Name of the tables in the cache (`<species>-shadermap-<hash>.sylbake`).
pub const NAME: &str = "shadermap";
/// Version of the tables' payload and of the measurement; bump when either changes.
pub const FORMAT_VERSION: u32 = 1;
/// Most trees in one patch (before the copies that cover the wrap-around).
pub const MAX_PATCH_TREES: usize = 20_000;
/// Directions steeper than this are measured at it (the sheared projection degenerates at
/// 90°, where the table is analytic).
const MAX_MEASURED_ZENITH_DEG: f32 = 87.0;

/// One species of the mix the tables are measured for.
#[derive(Clone, Copy)]
pub struct MixSpecies<'a> {
    /// The plant.
    pub plant: &'a Plant,
    /// Its `zfield` bake (the patch is drawn from it).
    pub zfield: &'a ZFieldBaked,
    /// Its share of the trees (any positive scale; normalised over the mix).
    pub weight: f32,
    /// Tree heights, metres (uniform in the range).
    pub height_m: [f32; 2],
}

/// The forest the tables describe.
pub struct ForestMix<'a> {
    /// The species, each with its `zfield` bake.
    pub species: Vec<MixSpecies<'a>>,
    /// The `zfield` bake parameters all of them were baked with.
    pub zfield_bake: ZFieldBakeParams,
    /// The Poisson pattern radius `r` (the scene's minimum spacing), metres.
    pub radius_m: f32,
    /// The densest forest to tabulate, trees per m² (the scene's peak).
    pub lambda_max: f32,
}

/// One species' crown as the tables see it.
#[derive(Debug, Clone, Copy)]
struct Crown {
    /// α-weighted area of the top view, m², at the mean squared scale.
    area_m2: f32,
    /// Foliage height (leaf mesh extent), m, at the mean scale.
    height_m: f32,
}

fn crown(s: &MixSpecies<'_>) -> Result<Crown, RenderError> {
    let z = s.zfield;
    let grid = HemiGrid::new(z.order)
        .ok_or_else(|| RenderError::Option(format!("zfield order {}", z.order)))?;
    let top = grid
        .directions()
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.y.total_cmp(&b.1.y))
        .map(|(k, _)| k)
        .unwrap_or(0);
    let alpha: f64 = z
        .views
        .get(top)
        .and_then(|v| v.zfield.first())
        .map(|t| t.chunks_exact(4).map(|p| p[3] as f64 / 255.0).sum())
        .unwrap_or(0.0);
    let texel = 2.0 * z.radius as f64 / z.tile as f64;
    let plant_h = s.plant.bbox_max[1].max(1e-3);
    let [s0, s1] = s.height_m.map(|h| h / plant_h);
    let mean_s2 = (s0 * s0 + s0 * s1 + s1 * s1) / 3.0;
    let ys = s.plant.leaves.positions.iter().map(|p| p[1]);
    let (lo, hi) = ys.fold((f32::MAX, f32::MIN), |(a, b), y| (a.min(y), b.max(y)));
    let extent = if hi > lo {
        hi - lo
    } else {
        s.plant.bbox_max[1] - s.plant.bbox_min[1]
    };
    Ok(Crown {
        area_m2: (alpha * texel * texel) as f32 * mean_s2,
        height_m: extent * 0.5 * (s0 + s1),
    })
}

/// The mix's mean crown area A and shape h (area-weighted), and its normalised weights.
fn mix_shape(mix: &ForestMix<'_>) -> Result<(f32, f32, Vec<f32>), RenderError> {
    let total: f32 = mix.species.iter().map(|s| s.weight).sum();
    let weights: Vec<f32> = mix.species.iter().map(|s| s.weight / total).collect();
    let (mut area, mut shaped) = (0.0f32, 0.0f32);
    for (s, w) in mix.species.iter().zip(&weights) {
        let c = crown(s)?;
        let radius = (c.area_m2 / std::f32::consts::PI).sqrt().max(1e-3);
        let h = (c.height_m / radius).clamp(0.25, 16.0);
        area += w * c.area_m2;
        shaped += w * c.area_m2 * h;
    }
    let h = if area > 0.0 { shaped / area } else { 2.0 };
    Ok((area, h, weights))
}

fn check_mix(mix: &ForestMix<'_>, params: &ShaderMapBakeParams) -> Result<(), RenderError> {
    use crate::technique::params::ParamTable;
    params
        .validate()
        .map_err(|why| RenderError::Param(format!("shadermap: {why}")))?;
    if mix.species.is_empty() {
        return Err(RenderError::Option(
            "shadermap tables need at least one species — add a [[species]] with a density".into(),
        ));
    }
    for s in &mix.species {
        if !(s.weight.is_finite() && s.weight > 0.0) {
            return Err(RenderError::Option(format!(
                "{}: weight {} in the shadermap mix — give each species a positive share",
                s.plant.name, s.weight
            )));
        }
        let [a, b] = s.height_m;
        if !(a.is_finite() && b.is_finite() && a > 0.0 && b >= a) {
            return Err(RenderError::Option(format!(
                "{}: height range [{a}, {b}] m — give 0 < min ≤ max",
                s.plant.name
            )));
        }
        if s.zfield.order != mix.zfield_bake.order || s.zfield.tile != mix.zfield_bake.tile {
            return Err(RenderError::Plant(format!(
                "{}: zfield bake has order {} tile {}, the mix says order {} tile {} — re-bake",
                s.plant.name,
                s.zfield.order,
                s.zfield.tile,
                mix.zfield_bake.order,
                mix.zfield_bake.tile
            )));
        }
    }
    if !(mix.radius_m.is_finite() && mix.radius_m > 0.05) {
        return Err(RenderError::Option(format!(
            "shadermap pattern radius {} m — it must be over 0.05 m",
            mix.radius_m
        )));
    }
    if !(mix.lambda_max.is_finite() && mix.lambda_max > 0.0) {
        return Err(RenderError::Option(format!(
            "shadermap peak density {} trees/m² — it must be positive",
            mix.lambda_max
        )));
    }
    Ok(())
}

/// The cache key of the tables: the format, the parameters, and per species the `zfield`
/// asset's own key (plant and bake parameters), its weight and heights; the pattern radius
/// and peak density.
pub fn table_key(mix: &ForestMix<'_>, params: &ShaderMapBakeParams) -> u64 {
    let mut h = Fnv64::default();
    h.field(NAME.as_bytes())
        .u32s(&[FORMAT_VERSION, cache::CONTAINER_VERSION])
        .field(&serde_json::to_vec(params).unwrap_or_default())
        .f32s(&[mix.radius_m, mix.lambda_max]);
    for s in &mix.species {
        let zkey = crate::bake::cache_key::<ZFieldBake>(s.plant, &mix.zfield_bake);
        h.write(&zkey.to_le_bytes())
            .f32s(&[s.weight, s.height_m[0], s.height_m[1]]);
    }
    h.finish()
}

/// The tables for `mix`: from the cache when the same inputs were measured before, else
/// measured ([`measure_ground`]) and written atomically. The file is named after the species.
pub fn load_or_measure(
    gpu: &Gpu,
    mix: &ForestMix<'_>,
    params: &ShaderMapBakeParams,
    policy: &CachePolicy,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<(GroundTables, BakeReport), RenderError> {
    check_mix(mix, params)?;
    let key = cache::CacheKey {
        technique: NAME.to_string(),
        format_version: FORMAT_VERSION,
        hash: table_key(mix, params),
    };
    let stem: Vec<&str> = mix.species.iter().map(|s| s.plant.name.as_str()).collect();
    let (theta, phi, lambda) = (params.theta, params.phi, params.lambda);
    crate::bake::load_or_compute(
        &stem.join("+"),
        &key,
        policy,
        |t: &GroundTables| {
            if (t.theta, t.phi, t.lambdas.len() as u32) != (theta, phi, lambda) {
                return Err("the tables' sizes differ from the parameters".into());
            }
            Ok(())
        },
        || measure_ground(gpu, mix, params, progress),
    )
}

/// The direction of table node (θ′ `k`, φ `m`) in the real (unscaled) world: `S⁻¹ v′`, with
/// the azimuth measured from +X. Zenith capped at [`MAX_MEASURED_ZENITH_DEG`].
fn direction(t: &GroundTables, k: u32, m: u32) -> Vec3 {
    let theta = real_zenith(t.theta_at(k), t.h).min(MAX_MEASURED_ZENITH_DEG.to_radians());
    let phi = t.phi_at(m);
    Vec3::new(
        theta.sin() * phi.cos(),
        theta.cos(),
        theta.sin() * phi.sin(),
    )
}

/// The sheared ground-aligned projection for direction `d` over the patch `[0, w]²`: ground
/// point (x, 0, z) to clip `((x, z) / w) · 2 − 1` (z downwards), every point moved along `d` to
/// the ground first; depth 0.5.
fn sheared(d: Vec3, w: f32) -> Mat4 {
    let (tx, tz) = (d.x / d.y, d.z / d.y);
    let s = 2.0 / w;
    Mat4::from_cols(
        Vec4::new(s, 0.0, 0.0, 0.0),
        Vec4::new(-tx * s, tz * s, 0.0, 0.0),
        Vec4::new(0.0, -s, 0.0, 0.0),
        Vec4::new(-1.0, 1.0, 0.5, 1.0),
    )
}

/// The patch's trees: for each candidate, the density at which it appears (`u · ρ_c`) and its
/// instance. Candidates are sorted by that density, so node `λ` is a prefix.
struct Patch {
    side: f32,
    /// (appears at, instance), by `appears at`.
    trees: Vec<(f32, GpuTreeInstance)>,
    /// Candidate density ρ_c, trees per m² (the densest node possible).
    rho: f32,
    /// Highest point of any tree above the ground and widest crown radius, metres.
    top_m: f32,
    reach_m: f32,
}

fn patch(
    mix: &ForestMix<'_>,
    params: &ShaderMapBakeParams,
    weights: &[f32],
) -> Result<Patch, RenderError> {
    let side = mix.radius_m * params.patch_radii as f32;
    let expected = side * side / (mix.radius_m * mix.radius_m);
    if expected > 2.0 * MAX_PATCH_TREES as f32 {
        return Err(RenderError::Option(format!(
            "shadermap patch_radii {}: about {expected:.0} candidates, more than {} — lower it",
            params.patch_radii,
            2 * MAX_PATCH_TREES
        )));
    }
    let points = sylvan_scene::poisson_tile(side, mix.radius_m, params.seed as u64);
    let rho = points.len() as f32 / (side * side);
    let mut rng = Rng::new(params.seed as u64 ^ 0x5eed_7ab1e5);
    let (mut top_m, mut reach_m) = (0.0f32, 0.0f32);
    let mut trees = Vec::with_capacity(points.len());
    for p in points.into_iter().take(MAX_PATCH_TREES) {
        let appears = rng.next_f64() as f32 * rho;
        let pick = rng.next_f64() as f32;
        let mut species = weights.len() - 1;
        let mut acc = 0.0;
        for (i, w) in weights.iter().enumerate() {
            acc += w;
            if pick < acc {
                species = i;
                break;
            }
        }
        let s = &mix.species[species];
        let [h0, h1] = s.height_m;
        let height = h0 + rng.next_f64() as f32 * (h1 - h0);
        let angle = rng.next_f64() as f32 * std::f32::consts::TAU;
        let tint = rng.next_f64() as f32;
        let scale = height / s.plant.bbox_max[1].max(1e-3);
        let z = s.zfield;
        top_m = top_m.max((z.centre[1] + z.radius) * scale);
        reach_m = reach_m.max(z.radius * scale);
        let base = Vec2::new(p.x, p.y);
        trees.push((
            appears,
            GpuTreeInstance {
                base_scale: [base.x, 0.0, base.y, scale],
                rot: [
                    angle.cos(),
                    angle.sin(),
                    species as f32 + tint.min(0.999),
                    1.0,
                ],
            },
        ));
    }
    trees.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(Patch {
        side,
        trees,
        rho,
        top_m,
        reach_m,
    })
}

/// Copies `k` of the tile (offset `k · side` along one axis) whose trees can hide ground of
/// the tile along a direction with horizontal shift `t` per metre of height.
fn copy_range(p: &Patch, t: f32) -> std::ops::RangeInclusive<i32> {
    let reach = p.top_m * t.abs() + p.reach_m * std::f32::consts::SQRT_2 * (1.0 + t.abs());
    let k = (reach / p.side).ceil() as i32 + 1;
    -k..=k
}

/// The ground visible from each direction, one bit per texel.
struct Masks {
    words: usize,
    /// `bits[dir]`: set where the ground is visible.
    bits: Vec<Vec<u64>>,
}

impl Masks {
    fn count(&self, a: usize) -> u32 {
        self.bits[a].iter().map(|w| w.count_ones()).sum()
    }

    fn count_both(&self, a: usize, b: usize) -> u32 {
        self.bits[a]
            .iter()
            .zip(&self.bits[b])
            .map(|(x, y)| (x & y).count_ones())
            .sum()
    }
}

/// The GPU side of the measurement, built once per table bake.
struct MaskRenderer {
    pipeline: wgpu::RenderPipeline,
    frame_layout: wgpu::BindGroupLayout,
    z: ZFieldBindings,
    px: u32,
    /// Tiles per atlas row and rows.
    cols: u32,
    rows: u32,
    atlas: wgpu::Texture,
}

/// The module `measure.wgsl` is compiled in: `zfield`'s shader plus the measuring entry points.
pub(crate) fn shader_source() -> String {
    format!(
        "{}\n{}",
        crate::technique::zfield::shader_source(),
        include_str!("measure.wgsl")
    )
}

impl MaskRenderer {
    fn new(gpu: &Gpu, mix: &ForestMix<'_>, px: u32, dirs: usize) -> Result<Self, RenderError> {
        let plants: Vec<Plant> = mix.species.iter().map(|s| s.plant.clone()).collect();
        let baked: Vec<ZFieldBaked> = mix.species.iter().map(|s| s.zfield.clone()).collect();
        let z = ZFieldBindings::upload(
            gpu,
            &plants,
            &baked,
            &mix.zfield_bake,
            &ZFieldDrawParams::default(),
            0.0,
        )?;
        let device = &gpu.device;
        let frame_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadermap_measure_frame"),
            entries: &[layout::uniform(0, wgpu::ShaderStages::VERTEX_FRAGMENT)],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shadermap_measure"),
            bind_group_layouts: &[Some(&frame_layout), Some(&z.layout)],
            immediate_size: 0,
        });
        let module = sylvan_gpu::shader(gpu, "shadermap_measure", &shader_source());
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("shadermap_measure"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_measure"),
                compilation_options: Default::default(),
                buffers: &[None, Some(GpuTreeInstance::LAYOUT)],
            },
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_measure_mask"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: wgpu::TextureFormat::R8Unorm,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            multiview_mask: None,
            cache: None,
        });
        // An atlas of at most 64 tiles (4 MiB at 256²) and the device's texture size.
        let max = device.limits().max_texture_dimension_2d;
        let fit = (max / px).max(1);
        let cols = fit.min(8);
        let rows = fit.min(8).min((dirs as u32).div_ceil(cols)).max(1);
        let atlas = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("shadermap_measure_masks"),
            size: wgpu::Extent3d {
                width: cols * px,
                height: rows * px,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R8Unorm,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        Ok(Self {
            pipeline,
            frame_layout,
            z,
            px,
            cols,
            rows,
            atlas,
        })
    }

    /// The visibility masks of `dirs` for the first `n` trees of `p`.
    fn masks(&self, gpu: &Gpu, p: &Patch, n: usize, dirs: &[Vec3]) -> Result<Masks, RenderError> {
        let px = self.px;
        let words = (px as usize * px as usize).div_ceil(64);
        let mut out = Masks {
            words,
            bits: Vec::with_capacity(dirs.len()),
        };
        if n == 0 {
            out.bits = vec![vec![u64::MAX; words]; dirs.len()];
            return Ok(out);
        }
        let k = dirs
            .iter()
            .map(|d| {
                let r = copy_range(p, (d.x / d.y).abs().max((d.z / d.y).abs()));
                *r.end()
            })
            .max()
            .unwrap_or(1);
        let side = 2 * k + 1;
        let mut instances = Vec::with_capacity(side as usize * side as usize * n);
        for cz in -k..=k {
            for cx in -k..=k {
                for (_, t) in &p.trees[..n] {
                    let mut t = *t;
                    t.base_scale[0] += cx as f32 * p.side;
                    t.base_scale[2] += cz as f32 * p.side;
                    instances.push(t);
                }
            }
        }
        let device = &gpu.device;
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("shadermap_measure_trees"),
            contents: bytemuck::cast_slice(&instances),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let align = device.limits().min_uniform_buffer_offset_alignment as u64;
        let stride = (std::mem::size_of::<GpuFrame>() as u64).div_ceil(align) * align;
        let per_batch = (self.cols * self.rows) as usize;
        let view = self.atlas.create_view(&Default::default());
        for batch in dirs.chunks(per_batch) {
            let mut uniforms = vec![0u8; stride as usize * batch.len()];
            for (i, d) in batch.iter().enumerate() {
                let f = frame_for(*d, p.side, px);
                let at = i * stride as usize;
                uniforms[at..at + std::mem::size_of::<GpuFrame>()]
                    .copy_from_slice(bytemuck::bytes_of(&f));
            }
            let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("shadermap_measure_frames"),
                contents: &uniforms,
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let binds: Vec<wgpu::BindGroup> = (0..batch.len())
                .map(|i| {
                    device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("shadermap_measure_frame"),
                        layout: &self.frame_layout,
                        entries: &[wgpu::BindGroupEntry {
                            binding: 0,
                            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                                buffer: &ubuf,
                                offset: i as u64 * stride,
                                size: wgpu::BufferSize::new(std::mem::size_of::<GpuFrame>() as u64),
                            }),
                        }],
                    })
                })
                .collect();
            let mut encoder = device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("shadermap_measure"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(1, &self.z.bind, &[]);
                pass.set_vertex_buffer(1, buffer.slice(..));
                for (i, d) in batch.iter().enumerate() {
                    let (x, y) = ((i as u32 % self.cols) * px, (i as u32 / self.cols) * px);
                    pass.set_viewport(x as f32, y as f32, px as f32, px as f32, 0.0, 1.0);
                    pass.set_scissor_rect(x, y, px, px);
                    pass.set_bind_group(0, &binds[i], &[]);
                    let (rx, rz) = (copy_range(p, d.x / d.y), copy_range(p, d.z / d.y));
                    for cz in rz.clone() {
                        let row = (cz + k) as usize * side as usize;
                        let first = (row + (*rx.start() + k) as usize) * n;
                        let last = (row + (*rx.end() + k) as usize + 1) * n;
                        pass.draw(0..6, first as u32..last as u32);
                    }
                }
            }
            gpu.queue.submit([encoder.finish()]);
            let bytes = sylvan_gpu::read_texture_bytes(gpu, &self.atlas)?;
            let width = (self.cols * px) as usize;
            for i in 0..batch.len() {
                let (x0, y0) = (
                    (i as u32 % self.cols * px) as usize,
                    (i as u32 / self.cols * px) as usize,
                );
                let mut bits = vec![0u64; words];
                for y in 0..px as usize {
                    let row = &bytes[(y0 + y) * width + x0..][..px as usize];
                    for (x, &b) in row.iter().enumerate() {
                        if b == 0 {
                            let t = y * px as usize + x;
                            bits[t / 64] |= 1 << (t % 64);
                        }
                    }
                }
                out.bits.push(bits);
            }
        }
        Ok(out)
    }
}

/// The frame uniforms of one direction's render.
fn frame_for(d: Vec3, side: f32, px: u32) -> GpuFrame {
    let mut f: GpuFrame = bytemuck::Zeroable::zeroed();
    f.view_proj = sheared(d, side).to_cols_array_2d();
    f.sun_dir = d.extend(0.0).to_array();
    f.camera = [0.0, 0.0, 0.0, px as f32 / side];
    f.shadow_params = [1.0 / px as f32, 0.0, 0.0, 1.0];
    f
}

/// Measures 𝔾, its diagonal and 𝔻 for `mix` (see the module doc). `progress(done, total)`
/// counts density nodes.
pub fn measure_ground(
    gpu: &Gpu,
    mix: &ForestMix<'_>,
    params: &ShaderMapBakeParams,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<GroundTables, RenderError> {
    check_mix(mix, params)?;
    let (area, h, weights) = mix_shape(mix)?;
    let p = patch(mix, params, &weights)?;
    let (nt, np, nl) = (params.theta, params.phi, params.lambda);
    // Node l holds the first n_l trees of the patch, n_l as near λ_max·l/(λ − 1) × area as
    // the candidates allow and rising; its λ is n_l / area exactly (not the nominal value).
    let area_m2 = p.side * p.side;
    let lambda_max = mix.lambda_max.min(p.rho);
    let mut counts = Vec::with_capacity(nl as usize);
    for l in 0..nl as usize {
        let want = (lambda_max * area_m2 * l as f32 / (nl - 1) as f32).round() as usize;
        let floor = counts.last().map_or(0, |&c: &usize| c + 1);
        counts.push(want.max(floor).min(p.trees.len()));
    }
    if counts.windows(2).any(|w| w[1] <= w[0]) {
        return Err(RenderError::Option(format!(
            "shadermap: the patch holds {} trees, too few for {nl} density nodes — raise patch_radii",
            p.trees.len()
        )));
    }
    let lambdas: Vec<f32> = counts.iter().map(|&c| c as f32 / area_m2).collect();
    let px = params.patch_px;
    let mut t = GroundTables {
        theta: nt,
        phi: np,
        lambdas,
        h,
        crown_area_m2: area,
        samples: px * px,
        g: vec![0.0; (nl * nt * nt * np) as usize],
        gd: vec![0.0; (nl * nt) as usize],
        d: vec![0.0; nl as usize],
    };
    // Measured directions: the zenith, then (θ node k, φ node m) for 0 < k < θ − 1.
    let mut dirs = vec![Vec3::Y];
    for k in 1..nt - 1 {
        for m in 0..np {
            dirs.push(direction(&t, k, m));
        }
    }
    let index = |k: u32, m: u32| -> Option<usize> {
        match k {
            0 => Some(0),
            k if k == nt - 1 => None,
            k => Some(1 + ((k - 1) * np + m) as usize),
        }
    };
    let renderer = MaskRenderer::new(gpu, mix, px, dirs.len())?;
    let n_all = (px * px) as f32;
    for (l, &n) in counts.iter().enumerate() {
        progress(l, nl as usize);
        let masks = renderer.masks(gpu, &p, n, &dirs)?;
        debug_assert_eq!(masks.words, (px as usize * px as usize).div_ceil(64));
        for v in 0..nt {
            let gd = match index(v, 0) {
                Some(a) => masks.count(a) as f32 / n_all,
                None if n == 0 => 1.0,
                None => 0.0,
            };
            t.gd[l * nt as usize + v as usize] = gd;
            for s in 0..nt {
                for m in 0..np {
                    let g = match (index(v, 0), index(s, m)) {
                        (Some(a), Some(b)) => masks.count_both(a, b) as f32 / n_all,
                        _ if n == 0 => 1.0,
                        _ => 0.0,
                    };
                    let at = ((l * nt as usize + v as usize) * nt as usize + s as usize)
                        * np as usize
                        + m as usize;
                    t.g[at] = g;
                }
            }
        }
        t.d[l] = t.integrate_d(l, 64).clamp(0.0, 1.0);
    }
    progress(nl as usize, nl as usize);
    Ok(t)
}
