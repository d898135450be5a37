//! Measuring the tables by rendering z-field forest patches (BN12 §6, "the functions 𝔾, 𝕋,
//! 𝔻, 𝔼 are precomputed by rendering forest patches").
//!
//! The patch is a periodic Poisson tile of side `patch_radii · r` (`r` the scene's pattern
//! radius), thinned per density node with nested thresholds (every tree of a sparser node is in
//! the denser ones), species drawn by the mix's weights, heights uniform in each species'
//! range, rotations and tints random. For every direction of the table's grid
//! (`1 + (θ − 1) · φ` of them) the patch is drawn with `zfield`'s own atlases and vertex shader
//! through a sheared ground-aligned orthographic projection (pixel (i, j) is ground texel (i, j)
//! in every direction, and copies of the tile cover the wrap-around exactly), writing the
//! highest tree point along each texel's ray (`measure.wgsl`): G-buffers for the view
//! directions (those of φ = 0), light maps for all. `measure_eval` then sums, per (view,
//! light) pair, the ground texels seen and lit (𝔾; the diagonal and the view's ground seen give
//! Gd) and the sunlight reaching each tree sample (𝕋), and per view the sky reaching it (𝔼)
//! and the part of it below the horizon of the tree point's baked normal (𝔼ₙ);
//! the sums are read back once per density node. 𝔻 is the quadrature of the diagonal.

use super::ShaderMapBakeParams;
use super::tables::{ShaderMapTables, real_zenith};
use crate::RenderError;
use crate::bake::codec::Fnv64;
use crate::bake::{BakeReport, CachePolicy, cache};
use crate::directions::HemiGrid;
use crate::frame::GpuFrame;
use crate::instances::GpuTreeInstance;
use crate::technique::common;
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
pub const FORMAT_VERSION: u32 = 4;
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
    /// The `zfield` draw parameters the trees are lit with (`tau`, `opacity_scaled_tau` and
    /// `normal_weight` enter 𝕋; the others are applied at run time).
    pub zfield_draw: ZFieldDrawParams,
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

/// A species' mean albedo (linear RGB): its views' premultiplied sRGB albedo decoded and
/// divided by their coverage, over every view.
pub(super) fn mean_albedo(z: &ZFieldBaked) -> [f64; 3] {
    let (mut sum, mut alpha) = ([0.0f64; 3], 0.0f64);
    for v in &z.views {
        if let Some(level) = v.levels.first() {
            for p in level.color.chunks_exact(4) {
                for c in 0..3 {
                    sum[c] += crate::technique::common::srgb_to_linear(p[c] as f32 / 255.0) as f64;
                }
                alpha += p[3] as f64 / 255.0;
            }
        }
    }
    sum.map(|s| (s / alpha.max(1e-9)).clamp(0.0, 1.0))
}

/// The mix's mean tree albedo: species by share × crown area.
fn mix_albedo(mix: &ForestMix<'_>, weights: &[f32]) -> Result<[f32; 3], RenderError> {
    let (mut sum, mut total) = ([0.0f64; 3], 0.0f64);
    for (s, w) in mix.species.iter().zip(weights) {
        let k = *w as f64 * crown(s)?.area_m2 as f64;
        let a = mean_albedo(s.zfield);
        for c in 0..3 {
            sum[c] += k * a[c];
        }
        total += k;
    }
    Ok(sum.map(|v| (v / total.max(1e-12)) as f32))
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
    let d = &mix.zfield_draw;
    h.f32s(&[
        d.tau,
        d.normal_weight,
        crate::technique::geometry::LEAF_TRANSLUCENCY,
    ])
    .u32s(&[d.opacity_scaled_tau as u32]);
    h.finish()
}

/// The tables for `mix`: from the cache when the same inputs were measured before, else
/// measured ([`measure_tables`]) and written atomically. The file is named after the species.
pub fn load_or_measure(
    gpu: &Gpu,
    mix: &ForestMix<'_>,
    params: &ShaderMapBakeParams,
    policy: &CachePolicy,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<(ShaderMapTables, BakeReport), RenderError> {
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
        |t: &ShaderMapTables| {
            if (t.theta, t.phi, t.lambdas.len() as u32) != (theta, phi, lambda) {
                return Err("the tables' sizes differ from the parameters".into());
            }
            Ok(())
        },
        || measure_tables(gpu, mix, params, progress),
    )
}

/// The work a measurement at `params` does: renders (light maps for every direction and a
/// G-buffer per view direction, per non-empty density node) and tree-sample evaluations (one
/// per (view, light) pair per sample of the evaluation grid per node; ground texels are
/// counted at every texel besides).
pub fn work(params: &ShaderMapBakeParams) -> (u64, u64) {
    let (nt, np, nl) = (params.theta as u64, params.phi as u64, params.lambda as u64);
    let dirs = 1 + (nt - 1) * np;
    let side = (params.patch_px / (params.patch_px / TREE_SAMPLES_SIDE).max(1)) as u64;
    ((dirs + nt) * (nl - 1), nt * dirs * side * side * (nl - 1))
}

/// The direction of table node (θ′ `k`, φ `m`) in the real (unscaled) world: `S⁻¹ v′`, with
/// the azimuth measured from +X. Zenith capped at [`MAX_MEASURED_ZENITH_DEG`].
fn direction(t: &ShaderMapTables, k: u32, m: u32) -> Vec3 {
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
    // The evaluation finds a tree's copy of the tile from a point of its crown: every crown
    // must lie within half a tile of its trunk.
    let widest = mix
        .species
        .iter()
        .map(|s| {
            let z = s.zfield;
            let scale = s.height_m[1] / s.plant.bbox_max[1].max(1e-3);
            (z.centre[0].hypot(z.centre[2]) + z.radius) * scale
        })
        .fold(0.0f32, f32::max);
    if widest >= 0.5 * side {
        return Err(RenderError::Option(format!(
            "shadermap patch_radii {}: a {side:.0} m patch is too small for crowns reaching {widest:.1} m from their trunks — raise patch_radii",
            params.patch_radii
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

/// What one (view, light) pair's evaluation sums.
#[derive(Debug, Clone, Copy, Default)]
struct PairSums {
    /// Σ S′ over the tree samples.
    sun: f64,
    /// Tree samples.
    trees: u32,
    /// Ground texels seen from the view and lit by the light.
    ground_lit: u32,
}

/// What one view's evaluation sums (with its first light).
#[derive(Debug, Clone, Copy, Default)]
struct ViewSums {
    /// Σ δ·hole over the tree samples.
    sky: f64,
    /// Σ δ·hole·(1 − n_y)/2 (n: the baked normal, facing the view).
    sky_side: f64,
    /// Tree samples.
    trees: u32,
    /// Ground texels seen.
    ground: u32,
}

/// Fixed-point scales of the evaluation's sums (`SUN_ONE`, `SKY_ONE` in `measure.wgsl`).
const SUN_ONE: f64 = 4096.0;
const SKY_ONE: f64 = 16384.0;

/// Samples per side of the G-buffer grid 𝕋 and 𝔼 are evaluated on (every `patch_px / 128`-th
/// texel): 16,384 per (view, light) pair, of which the trees' share counts.
const TREE_SAMPLES_SIDE: u32 = 128;

/// The most table directions (`lights` in `measure.wgsl`): `1 + (32 − 1) · 32` fit.
const MAX_DIRECTIONS: usize = 1024;

/// Most bytes of patch instances drawn for one density node.
const MAX_DRAWN_BYTES: u64 = 256 << 20;

/// The most directions drawn into one atlas (8 × 8 tiles).
const ATLAS_TILES: u32 = 64;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuEval {
    view: [f32; 4],
    sizes: [f32; 4],
    tiles: [u32; 4],
    sky: [u32; 4],
}

/// An atlas of `cols × rows` square tiles of `px` texels, and its depth buffer.
struct Atlas {
    /// Colour and depth of the whole atlas (`sylvan_gpu`'s target).
    target: sylvan_gpu::RenderTarget,
    cols: u32,
    rows: u32,
}

impl Atlas {
    fn new(
        gpu: &Gpu,
        label: &str,
        format: wgpu::TextureFormat,
        px: u32,
        tiles: u32,
    ) -> Result<Self, RenderError> {
        let max = gpu.device.limits().max_texture_dimension_2d;
        let fit = (max / px).clamp(1, 8);
        let cols = fit.min(tiles.max(1));
        let rows = tiles.max(1).div_ceil(cols).min(fit);
        Ok(Self {
            target: sylvan_gpu::RenderTarget::new(gpu, label, cols * px, rows * px, format)?,
            cols,
            rows,
        })
    }

    fn tiles(&self) -> usize {
        (self.cols * self.rows) as usize
    }

    fn origin(&self, i: usize, px: u32) -> (u32, u32) {
        ((i as u32 % self.cols) * px, (i as u32 / self.cols) * px)
    }
}

/// The GPU side of the measurement, built once per table bake.
struct Measurer {
    gbuffer: wgpu::RenderPipeline,
    light: wgpu::RenderPipeline,
    eval: wgpu::ComputePipeline,
    frame_layout: wgpu::BindGroupLayout,
    eval_layout: wgpu::BindGroupLayout,
    empty: wgpu::BindGroup,
    z: ZFieldBindings,
    px: u32,
    views: Atlas,
    lights: Atlas,
}

/// The module `measure.wgsl` is compiled in: `zfield`'s shader plus the measuring entry points.
pub(crate) fn shader_source() -> String {
    format!(
        "{}\n{}",
        crate::technique::zfield::shader_source(),
        include_str!("measure.wgsl")
    )
}

/// The patch's trees drawn for a set of directions: the tile's first `n` trees in every copy
/// any direction needs.
struct Drawn {
    buffer: wgpu::Buffer,
    /// The tile's trees alone (the evaluation's `trees`).
    tile: wgpu::Buffer,
    n: usize,
    /// Copies per side / 2.
    k: i32,
}

impl Measurer {
    fn new(
        gpu: &Gpu,
        mix: &ForestMix<'_>,
        px: u32,
        dirs: usize,
        views: usize,
    ) -> Result<Self, RenderError> {
        let plants: Vec<Plant> = mix.species.iter().map(|s| s.plant.clone()).collect();
        let baked: Vec<ZFieldBaked> = mix.species.iter().map(|s| s.zfield.clone()).collect();
        let z = ZFieldBindings::upload(
            gpu,
            &plants,
            &baked,
            &mix.zfield_bake,
            &mix.zfield_draw,
            0.0,
        )?;
        let device = &gpu.device;
        let vf = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let frame_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadermap_measure_frame"),
            entries: &[layout::uniform(0, vf)],
        });
        let cs = wgpu::ShaderStages::COMPUTE;
        let uint = wgpu::TextureSampleType::Uint;
        let d2 = wgpu::TextureViewDimension::D2;
        let eval_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadermap_measure_eval"),
            entries: &[
                layout::uniform(0, cs),
                layout::texture(1, cs, uint, d2),
                layout::texture(2, cs, uint, d2),
                layout::storage(3, cs),
                layout::uniform(4, cs),
                layout::storage_rw(5, cs),
            ],
        });
        let empty_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadermap_measure_empty"),
            entries: &[],
        });
        let empty = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shadermap_measure_empty"),
            layout: &empty_layout,
            entries: &[],
        });
        let module = sylvan_gpu::shader(gpu, "shadermap_measure", &shader_source());
        let render_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shadermap_measure"),
            bind_group_layouts: &[Some(&frame_layout), Some(&z.layout)],
            immediate_size: 0,
        });
        let render = |label, vs, fs, format, depth: bool| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&render_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers: &[None, Some(GpuTreeInstance::LAYOUT)],
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                primitive: Default::default(),
                depth_stencil: depth.then(|| wgpu::DepthStencilState {
                    format: sylvan_gpu::DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Less),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                multiview_mask: None,
                cache: None,
            })
        };
        let gbuffer = render(
            "shadermap_measure_gbuffer",
            "vs_measure_tree",
            "fs_measure_gbuffer",
            wgpu::TextureFormat::Rgba32Uint,
            true,
        );
        let light = render(
            "shadermap_measure_light",
            "vs_measure_tree",
            "fs_measure_light",
            wgpu::TextureFormat::Rg32Uint,
            true,
        );
        let eval_pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shadermap_measure_eval"),
            bind_group_layouts: &[Some(&empty_layout), Some(&z.layout), Some(&eval_layout)],
            immediate_size: 0,
        });
        let eval = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("shadermap_measure_eval"),
            layout: Some(&eval_pipeline_layout),
            module: &module,
            entry_point: Some("measure_eval"),
            compilation_options: Default::default(),
            cache: None,
        });
        let dirs = dirs as u32;
        let views_atlas = Atlas::new(
            gpu,
            "shadermap_gbuffers",
            wgpu::TextureFormat::Rgba32Uint,
            px,
            views as u32,
        )?;
        if views_atlas.tiles() < views {
            return Err(RenderError::Option(format!(
                "shadermap: {views} view G-buffers of {px}² do not fit the device's textures — lower patch_px or theta"
            )));
        }
        let lights = Atlas::new(
            gpu,
            "shadermap_light_maps",
            wgpu::TextureFormat::Rg32Uint,
            px,
            dirs.min(ATLAS_TILES),
        )?;
        Ok(Self {
            gbuffer,
            light,
            eval,
            frame_layout,
            eval_layout,
            empty,
            z,
            px,
            views: views_atlas,
            lights,
        })
    }

    /// The tile's first `n` trees, copied wherever `dirs` can see them from the tile.
    fn drawn(&self, gpu: &Gpu, p: &Patch, n: usize, dirs: &[Vec3]) -> Result<Drawn, RenderError> {
        let k = dirs
            .iter()
            .map(|d| *copy_range(p, (d.x / d.y).abs().max((d.z / d.y).abs())).end())
            .max()
            .unwrap_or(1);
        let bytes =
            ((2 * k + 1) as u64).pow(2) * n as u64 * std::mem::size_of::<GpuTreeInstance>() as u64;
        let limit = MAX_DRAWN_BYTES.min(gpu.device.limits().max_buffer_size);
        if bytes > limit {
            return Err(RenderError::Option(format!(
                "shadermap: the patch's copies along the grazing directions need {} MB of trees, more than {} MB — raise patch_radii (the trees are tall for the patch)",
                bytes >> 20,
                limit >> 20
            )));
        }
        let mut instances = Vec::with_capacity(((2 * k + 1) * (2 * k + 1)) as usize * n.max(1));
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
        if instances.is_empty() {
            instances.push(bytemuck::Zeroable::zeroed());
        }
        let tile: Vec<GpuTreeInstance> = p.trees[..n.max(1).min(p.trees.len())]
            .iter()
            .map(|(_, t)| *t)
            .collect();
        let init = |label, contents: &[u8], usage| {
            gpu.device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents,
                    usage,
                })
        };
        Ok(Drawn {
            buffer: init(
                "shadermap_measure_trees",
                bytemuck::cast_slice(&instances),
                wgpu::BufferUsages::VERTEX,
            ),
            tile: init(
                "shadermap_measure_tile",
                bytemuck::cast_slice(&tile),
                wgpu::BufferUsages::STORAGE,
            ),
            n,
            k,
        })
    }

    /// Frame bind groups for `dirs` (one uniform block each).
    fn frames(
        &self,
        gpu: &Gpu,
        p: &Patch,
        n: usize,
        dirs: &[Vec3],
    ) -> (wgpu::Buffer, Vec<wgpu::BindGroup>) {
        let device = &gpu.device;
        let align = device.limits().min_uniform_buffer_offset_alignment as u64;
        let size = std::mem::size_of::<GpuFrame>() as u64;
        let stride = size.div_ceil(align) * align;
        let mut bytes = vec![0u8; (stride as usize * dirs.len()).max(stride as usize)];
        for (i, d) in dirs.iter().enumerate() {
            let f = frame_for(*d, p, n, self.px);
            let at = i * stride as usize;
            bytes[at..at + size as usize].copy_from_slice(bytemuck::bytes_of(&f));
        }
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("shadermap_measure_frames"),
            contents: &bytes,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let binds = (0..dirs.len())
            .map(|i| {
                common::bind_group(
                    gpu,
                    "shadermap_measure_frame",
                    &self.frame_layout,
                    &[wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &buffer,
                        offset: i as u64 * stride,
                        size: wgpu::BufferSize::new(size),
                    })],
                )
            })
            .collect();
        (buffer, binds)
    }

    /// Draws `dirs` (bind groups `binds`) into `atlas` tiles `0..` with `pipeline`.
    #[allow(clippy::too_many_arguments)]
    fn draw_tiles(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        pipeline: &wgpu::RenderPipeline,
        atlas: &Atlas,
        p: &Patch,
        drawn: &Drawn,
        dirs: &[Vec3],
        binds: &[wgpu::BindGroup],
    ) {
        let px = self.px;
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("shadermap_measure"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &atlas.target.color_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &atlas.target.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        if drawn.n == 0 {
            return;
        }
        pass.set_pipeline(pipeline);
        pass.set_bind_group(1, &self.z.bind, &[]);
        let side = (2 * drawn.k + 1) as usize;
        let record = std::mem::size_of::<GpuTreeInstance>() as u64;
        for (i, d) in dirs.iter().enumerate() {
            let (x, y) = atlas.origin(i, px);
            pass.set_viewport(x as f32, y as f32, px as f32, px as f32, 0.0, 1.0);
            pass.set_scissor_rect(x, y, px, px);
            pass.set_bind_group(0, &binds[i], &[]);
            let (rx, rz) = (copy_range(p, d.x / d.y), copy_range(p, d.z / d.y));
            for cz in rz {
                // Whole copies from a copy boundary, bound as the vertex buffer's range (no
                // first instance: GL), so instance index mod n is the tree in the tile.
                let row = (cz + drawn.k) as usize * side;
                let first = (row + (*rx.start() + drawn.k) as usize) * drawn.n;
                let last = (row + (*rx.end() + drawn.k) as usize + 1) * drawn.n;
                pass.set_vertex_buffer(
                    1,
                    drawn
                        .buffer
                        .slice(first as u64 * record..last as u64 * record),
                );
                pass.draw(0..6, 0..(last - first) as u32);
            }
        }
    }

    /// The stride between the G-buffer texels 𝕋 and 𝔼 are evaluated at: at most
    /// [`TREE_SAMPLES_SIDE`]² samples per (view, light) pair.
    fn stride(&self) -> u32 {
        (self.px / TREE_SAMPLES_SIDE).max(1)
    }

    /// The sums of every (view, light) pair: view G-buffers once, then per batch of lights
    /// their light maps and one evaluation dispatch per view. Returns per view and light
    /// [`PairSums`] and per view [`ViewSums`].
    fn evaluate(
        &self,
        gpu: &Gpu,
        p: &Patch,
        drawn: &Drawn,
        views: &[Vec3],
        lights: &[Vec3],
        lambda: f32,
    ) -> Result<(Vec<PairSums>, Vec<ViewSums>), RenderError> {
        let device = &gpu.device;
        let (nv, nl) = (views.len(), lights.len());
        // Per (view, light) pair one entry; per view two (𝔼's sums, then 𝔼ₙ's in its first
        // word).
        let entries = nv * nl + 2 * nv;
        let acc = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("shadermap_measure_acc"),
            contents: &vec![0u8; entries * 12],
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        });
        let mut light_dirs = vec![[0.0f32; 4]; MAX_DIRECTIONS];
        for (slot, d) in light_dirs.iter_mut().zip(lights) {
            *slot = d.extend(0.0).to_array();
        }
        let light_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("shadermap_measure_lights"),
            contents: bytemuck::cast_slice(&light_dirs),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let per_batch = self.lights.tiles();
        let batches = nl.div_ceil(per_batch);
        let align = device.limits().min_uniform_buffer_offset_alignment as u64;
        let size = std::mem::size_of::<GpuEval>() as u64;
        let stride = size.div_ceil(align) * align;
        let mut bytes = vec![0u8; stride as usize * nv * batches];
        for b in 0..batches {
            let first = b * per_batch;
            for (k, v) in views.iter().enumerate() {
                let (x, y) = self.views.origin(k, self.px);
                let e = GpuEval {
                    view: v.extend(p.side).to_array(),
                    sizes: [self.px as f32, drawn.n as f32, lambda, self.stride() as f32],
                    tiles: [x, y, self.lights.cols, (k * nl + first) as u32],
                    sky: [(nv * nl + 2 * k) as u32, (b == 0) as u32, first as u32, 0],
                };
                let at = (b * nv + k) * stride as usize;
                bytes[at..at + size as usize].copy_from_slice(bytemuck::bytes_of(&e));
            }
        }
        let evals = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("shadermap_measure_evals"),
            contents: &bytes,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let binds: Vec<wgpu::BindGroup> = (0..nv * batches)
            .map(|i| {
                common::bind_group(
                    gpu,
                    "shadermap_measure_eval",
                    &self.eval_layout,
                    &[
                        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &evals,
                            offset: i as u64 * stride,
                            size: wgpu::BufferSize::new(size),
                        }),
                        wgpu::BindingResource::TextureView(&self.views.target.color_view),
                        wgpu::BindingResource::TextureView(&self.lights.target.color_view),
                        drawn.tile.as_entire_binding(),
                        light_buffer.as_entire_binding(),
                        acc.as_entire_binding(),
                    ],
                )
            })
            .collect();
        let (_vbuf, vbinds) = self.frames(gpu, p, drawn.n, views);
        let (_lbuf, lbinds) = self.frames(gpu, p, drawn.n, lights);
        let mut encoder = device.create_command_encoder(&Default::default());
        self.draw_tiles(
            &mut encoder,
            &self.gbuffer,
            &self.views,
            p,
            drawn,
            views,
            &vbinds,
        );
        let groups = self.px.div_ceil(8);
        for b in 0..batches {
            let first = b * per_batch;
            let count = per_batch.min(nl - first);
            self.draw_tiles(
                &mut encoder,
                &self.light,
                &self.lights,
                p,
                drawn,
                &lights[first..first + count],
                &lbinds[first..first + count],
            );
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("shadermap_measure_eval"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.eval);
            pass.set_bind_group(0, &self.empty, &[]);
            pass.set_bind_group(1, &self.z.bind, &[]);
            for k in 0..nv {
                pass.set_bind_group(2, &binds[b * nv + k], &[]);
                pass.dispatch_workgroups(groups, groups, count as u32);
            }
        }
        gpu.queue.submit([encoder.finish()]);
        let raw = sylvan_gpu::read_buffer_bytes(gpu, &acc)?;
        let words: &[u32] = bytemuck::cast_slice(&raw);
        let pairs = (0..nv * nl)
            .map(|e| PairSums {
                sun: words[3 * e] as f64 / SUN_ONE,
                trees: words[3 * e + 1],
                ground_lit: words[3 * e + 2],
            })
            .collect();
        let views = (0..nv)
            .map(|k| {
                let e = nv * nl + 2 * k;
                ViewSums {
                    sky: words[3 * e] as f64 / SKY_ONE,
                    sky_side: words[3 * e + 3] as f64 / SKY_ONE,
                    trees: words[3 * e + 1],
                    ground: words[3 * e + 2],
                }
            })
            .collect();
        Ok((pairs, views))
    }
}

/// The frame uniforms of one direction's render.
fn frame_for(d: Vec3, p: &Patch, n: usize, px: u32) -> GpuFrame {
    let mut f: GpuFrame = bytemuck::Zeroable::zeroed();
    f.view_proj = sheared(d, p.side).to_cols_array_2d();
    f.sun_dir = d.extend(0.0).to_array();
    f.camera = [
        0.0,
        p.top_m * 1.01 + 1.0,
        n.max(1) as f32,
        px as f32 / p.side,
    ];
    f.shadow_params = [1.0 / px as f32, p.side / px as f32, 0.0, 1.0];
    f
}

/// Measures the tables for `mix` (see the module doc). `progress(done, total)` counts density
/// nodes.
pub fn measure_tables(
    gpu: &Gpu,
    mix: &ForestMix<'_>,
    params: &ShaderMapBakeParams,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<ShaderMapTables, RenderError> {
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
    let full = (nl * nt * nt * np) as usize;
    let mut t = ShaderMapTables {
        theta: nt,
        phi: np,
        lambdas,
        h,
        crown_area_m2: area,
        samples: px * px,
        tree_albedo: mix_albedo(mix, &weights)?,
        g: vec![0.0; full],
        gd: vec![0.0; (nl * nt) as usize],
        d: vec![0.0; nl as usize],
        t: vec![0.0; full],
        e: vec![0.0; (nl * nt) as usize],
        e_side: vec![0.0; (nl * nt) as usize],
    };
    // Directions: the zenith, then (θ node k, φ node m) for 0 < k < θ; the view directions are
    // those of φ = 0. 𝔾 at 90° is analytic (no ground is seen through an endless forest);
    // 𝕋 and 𝔼 there are measured at the capped zenith.
    let mut dirs = vec![Vec3::Y];
    for k in 1..nt {
        for m in 0..np {
            dirs.push(direction(&t, k, m));
        }
    }
    let index = |k: u32, m: u32| -> usize {
        match k {
            0 => 0,
            k => 1 + ((k - 1) * np + m) as usize,
        }
    };
    let view_dirs: Vec<Vec3> = (0..nt).map(|k| dirs[index(k, 0)]).collect();
    let measurer = Measurer::new(gpu, mix, px, dirs.len(), view_dirs.len())?;
    let n_all = (px * px) as f32;
    let (ntu, npu) = (nt as usize, np as usize);
    for (l, &n) in counts.iter().enumerate() {
        progress(l, nl as usize);
        let drawn = measurer.drawn(gpu, &p, n, &dirs)?;
        let (pairs, views) = if n > 0 {
            measurer.evaluate(gpu, &p, &drawn, &view_dirs, &dirs, t.lambdas[l])?
        } else {
            (Vec::new(), Vec::new())
        };
        let grazing = |k: u32| k == nt - 1;
        let nd = dirs.len();
        for v in 0..nt {
            let vi = v as usize;
            let gd = match (grazing(v), n) {
                (_, 0) => 1.0,
                (true, _) => 0.0,
                _ => views[vi].ground as f32 / n_all,
            };
            t.gd[l * ntu + vi] = gd;
            if n > 0 {
                let w = views[vi];
                let trees = w.trees.max(1) as f64;
                t.e[l * ntu + vi] = (w.sky / trees).clamp(0.0, 1.0) as f32;
                t.e_side[l * ntu + vi] = (w.sky_side / trees).clamp(0.0, 1.0) as f32;
            }
            for s in 0..nt {
                for m in 0..np {
                    let pair = pairs
                        .get(vi * nd + index(s, m))
                        .copied()
                        .unwrap_or_default();
                    let g = match (grazing(v) || grazing(s), n) {
                        (_, 0) => 1.0,
                        (true, _) => 0.0,
                        _ => pair.ground_lit as f32 / n_all,
                    };
                    let at = ((l * ntu + vi) * ntu + s as usize) * npu + m as usize;
                    t.g[at] = g;
                    if n > 0 {
                        t.t[at] = (pair.sun / pair.trees.max(1) as f64).clamp(0.0, 4.0) as f32;
                    }
                }
            }
        }
        t.d[l] = t.integrate_d(l, 64).clamp(0.0, 1.0);
    }
    // No tree at node 0: its 𝕋, 𝔼 and 𝔼ₙ are node 1's (they are never weighted there).
    let (row, erow) = (ntu * ntu * npu, ntu);
    let (first, rest) = t.t.split_at_mut(row);
    first.copy_from_slice(&rest[..row]);
    for e in [&mut t.e, &mut t.e_side] {
        let (first, rest) = e.split_at_mut(erow);
        first.copy_from_slice(&rest[..erow]);
    }
    progress(nl as usize, nl as usize);
    Ok(t)
}
