//! The shared baker: renders a plant, or any subset of its triangles, offscreen on the GPU
//! from a list of orthographic views into tiles of colour + coverage and normal + depth,
//! supersampled, then resolves, dilates and mip-maps them on the CPU ([`image`]), and keeps
//! the result in a versioned, atomically written cache ([`cache`]). Every image-based
//! technique bakes through here.
//!
//! What a tile holds (see [`image::TileImage`]): premultiplied linear albedo with coverage,
//! and the unit normal facing the bake camera with the depth inside the framed box. Lighting
//! is *not* baked: techniques light the texels at run time with the same model as the
//! geometry, so a baked tree stays consistent with the reference when the sun moves.

pub mod cache;
pub mod codec;
pub mod image;
pub mod views;

use crate::RenderError;
use crate::technique::geometry::GpuMesh;
use crate::texture;
use bytemuck::{Pod, Zeroable};
use image::TileImage;
use std::ops::Range;
use sylvan_gpu::{DEPTH_FORMAT, Gpu, layout};
use sylvan_plant::Plant;
use views::PlaneFrame;

/// Largest tile the baker makes (texels per side).
pub const MAX_TILE: u32 = 1024;
/// Largest supersampling factor per axis.
pub const MAX_SUPERSAMPLE: u32 = 8;

/// One view to bake: a plane frame seen from one side, and which triangles to draw.
#[derive(Debug, Clone)]
pub struct BakeRequest {
    /// The framed rectangle and projection axes.
    pub frame: PlaneFrame,
    /// `1.0`: seen from `+f`; `-1.0`: from `-f`.
    pub side: f32,
    /// Index ranges into `plant.leaves.indices`.
    pub leaves: Vec<Range<u32>>,
    /// Index ranges into `plant.wood.indices`.
    pub wood: Vec<Range<u32>>,
}

impl BakeRequest {
    /// All of `plant` (every leaf and wood index) in `frame`, seen from `+f`.
    pub fn whole(plant: &Plant, frame: PlaneFrame) -> Self {
        Self {
            frame,
            side: 1.0,
            leaves: std::iter::once(0..plant.leaves.indices.len() as u32).collect(),
            wood: std::iter::once(0..plant.wood.indices.len() as u32).collect(),
        }
    }
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuBakeView {
    view_proj: [[f32; 4]; 4],
    to_camera: [f32; 4],
}

/// The raw G-buffer format: `Rgba32Float` where the adapter can render to it, else (wgpu's GL
/// backend: "Format Rgba32Float is not renderable") `Rgba16Float` — ample for what the bake
/// keeps (8-bit colour, normal and depth per texel after the resolve).
fn raw_format(gpu: &Gpu) -> wgpu::TextureFormat {
    let full = wgpu::TextureFormat::Rgba32Float;
    let renderable = gpu
        .adapter
        .get_texture_format_features(full)
        .allowed_usages
        .contains(wgpu::TextureUsages::RENDER_ATTACHMENT);
    if renderable {
        full
    } else {
        wgpu::TextureFormat::Rgba16Float
    }
}

/// `f16` bits → `f32` (the `Rgba16Float` read-back).
pub(crate) fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = (h >> 10) & 0x1f;
    let frac = (h & 0x3ff) as f32;
    sign * match exp {
        0 => frac * (-24f32).exp2(),
        31 if frac == 0.0 => f32::INFINITY,
        31 => f32::NAN,
        e => (1.0 + frac / 1024.0) * (e as f32 - 15.0).exp2(),
    }
}
/// Bytes of raw samples read back per batch, at most.
const BATCH_BYTES: u64 = 64 << 20;

/// A plant uploaded for baking.
pub struct PlantBaker {
    wood: Option<GpuMesh>,
    leaves: Option<GpuMesh>,
    leaf_pipeline: wgpu::RenderPipeline,
    wood_pipeline: wgpu::RenderPipeline,
    bind_layout: wgpu::BindGroupLayout,
    leaf_maps: texture::LeafMaterial,
    sampler: wgpu::Sampler,
    tile: u32,
    ss: u32,
    raw: wgpu::TextureFormat,
}

impl PlantBaker {
    /// Uploads `plant` to bake tiles of `tile`² texels, each supersampled `ss`² times.
    pub fn new(gpu: &Gpu, plant: &Plant, tile: u32, ss: u32) -> Result<Self, RenderError> {
        if !(1..=MAX_TILE).contains(&tile) || !(1..=MAX_SUPERSAMPLE).contains(&ss) {
            return Err(RenderError::Option(format!(
                "bake tile {tile} px × supersampling {ss}: the tile must be 1–{MAX_TILE} px and supersampling 1–{MAX_SUPERSAMPLE}"
            )));
        }
        gpu.check_texture_size("bake tile", tile * ss, tile * ss)?;
        let device = &gpu.device;
        let leaf_maps = texture::upload_leaf_material(gpu, "bake_leaf_texture", plant)?;
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("bake_sampler"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        let bind_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("bake_layout"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: true },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                layout::texture(
                    1,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::TextureSampleType::Float { filterable: true },
                    wgpu::TextureViewDimension::D2,
                ),
                layout::sampler(
                    2,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::SamplerBindingType::Filtering,
                ),
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
        let module = sylvan_gpu::shader(gpu, "bake", &shader_source());
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("bake"),
            bind_group_layouts: &[Some(&bind_layout)],
            immediate_size: 0,
        });
        let raw = raw_format(gpu);
        let targets = [
            Some(wgpu::ColorTargetState::from(raw)),
            Some(wgpu::ColorTargetState::from(raw)),
        ];
        let buffers = [Some(crate::technique::geometry::GpuPlantVertex::LAYOUT)];
        let make = |fs: &str| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(fs),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_bake"),
                    compilation_options: Default::default(),
                    buffers: &buffers,
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: &targets,
                }),
                // Two-sided: leaves are cards, and a view from -f mirrors the winding.
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
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
        Ok(Self {
            wood: GpuMesh::new(gpu, &format!("{} wood", plant.name), &plant.wood)?,
            leaves: GpuMesh::new(gpu, &format!("{} leaves", plant.name), &plant.leaves)?,
            leaf_pipeline: make("fs_bake_leaf"),
            wood_pipeline: make("fs_bake_wood"),
            bind_layout,
            leaf_maps,
            sampler,
            tile,
            ss,
            raw,
        })
    }

    /// Bakes every request into a resolved tile, in order, calling `progress(done)` after each
    /// batch. Requests are rendered side by side into one target per batch and read back once.
    pub fn bake(
        &self,
        gpu: &Gpu,
        requests: &[BakeRequest],
        mut progress: impl FnMut(usize),
    ) -> Result<Vec<TileImage>, RenderError> {
        let px = self.tile * self.ss;
        let max_dim = gpu.device.limits().max_texture_dimension_2d;
        let per_sample = 2 * self.raw.block_copy_size(None).unwrap_or(16) as u64;
        let by_bytes = (BATCH_BYTES / (px as u64 * px as u64 * per_sample)).max(1) as u32;
        let batch = (max_dim / px).min(by_bytes).max(1) as usize;
        let mut out = Vec::with_capacity(requests.len());
        for chunk in requests.chunks(batch) {
            out.extend(self.bake_batch(gpu, chunk)?);
            progress(out.len());
        }
        Ok(out)
    }

    fn bake_batch(
        &self,
        gpu: &Gpu,
        requests: &[BakeRequest],
    ) -> Result<Vec<TileImage>, RenderError> {
        let device = &gpu.device;
        let px = self.tile * self.ss;
        let width = px * requests.len() as u32;
        let raw: Vec<GpuBakeView> = requests
            .iter()
            .map(|r| GpuBakeView {
                view_proj: r.frame.view_proj(r.side).to_cols_array_2d(),
                to_camera: (r.frame.f * r.side).extend(0.0).to_array(),
            })
            .collect();
        let views = wgpu::util::DeviceExt::create_buffer_init(
            device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("bake_views"),
                contents: bytemuck::cast_slice(&raw),
                usage: wgpu::BufferUsages::STORAGE,
            },
        );
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("bake_bind"),
            layout: &self.bind_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: views.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&self.leaf_maps.front),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Sampler(&self.sampler),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(&self.leaf_maps.back),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(&self.leaf_maps.normal),
                },
            ],
        });
        let make = |label, format| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width,
                    height: px,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            })
        };
        let color = make("bake_color", self.raw);
        let normal = make("bake_normal", self.raw);
        let depth = make("bake_depth", DEPTH_FORMAT);
        let (cv, nv, dv) = (
            color.create_view(&Default::default()),
            normal.create_view(&Default::default()),
            depth.create_view(&Default::default()),
        );
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let clear = |view| {
                Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })
            };
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("bake_pass"),
                color_attachments: &[clear(&cv), clear(&nv)],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &dv,
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
            pass.set_bind_group(0, &bind, &[]);
            for (i, r) in requests.iter().enumerate() {
                let x = (i as u32 * px) as f32;
                pass.set_viewport(x, 0.0, px as f32, px as f32, 0.0, 1.0);
                pass.set_scissor_rect(i as u32 * px, 0, px, px);
                let view = i as u32..i as u32 + 1;
                for (mesh, pipeline, ranges) in [
                    (&self.wood, &self.wood_pipeline, &r.wood),
                    (&self.leaves, &self.leaf_pipeline, &r.leaves),
                ] {
                    let Some(mesh) = mesh else { continue };
                    pass.set_pipeline(pipeline);
                    pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                    pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                    for range in ranges.iter().filter(|r| !r.is_empty()) {
                        if range.end > mesh.index_count {
                            return Err(RenderError::Plant(format!(
                                "bake range {range:?} exceeds the mesh's {} indices",
                                mesh.index_count
                            )));
                        }
                        pass.draw_indexed(range.clone(), 0, view.clone());
                    }
                }
            }
        }
        gpu.queue.submit([encoder.finish()]);
        let floats = |t: &wgpu::Texture| -> Result<Vec<[f32; 4]>, RenderError> {
            let bytes = sylvan_gpu::read_texture_bytes(gpu, t)?;
            Ok(if self.raw == wgpu::TextureFormat::Rgba32Float {
                bytemuck::pod_collect_to_vec(&bytes)
            } else {
                let halves: Vec<[u16; 4]> = bytemuck::pod_collect_to_vec(&bytes);
                halves.iter().map(|h| h.map(f16_to_f32)).collect()
            })
        };
        let (rc, rn) = (floats(&color)?, floats(&normal)?);
        gpu.check()?;
        Ok((0..requests.len())
            .map(|i| {
                TileImage::resolve(
                    &rc,
                    &rn,
                    width as usize,
                    i * px as usize,
                    self.tile,
                    self.ss,
                )
            })
            .collect())
    }
}

/// The baker's WGSL as compiled: the shared leaf material (`shaders/leaf.wgsl`), then
/// `bake.wgsl`.
pub(crate) fn shader_source() -> String {
    concat!(
        include_str!("../shaders/leaf.wgsl"),
        include_str!("bake.wgsl")
    )
    .to_string()
}

/// Where baked assets are cached.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum CachePolicy {
    /// The default folder ([`cache::default_dir`]).
    #[default]
    Default,
    /// This folder.
    Dir(std::path::PathBuf),
    /// Exactly this file (`sylvan bake --out`).
    File(std::path::PathBuf),
    /// Always bake, never read or write files.
    Off,
}

/// How one plant's asset was obtained.
#[derive(Debug, Clone, PartialEq)]
pub struct BakeReport {
    /// Plant name (for a species mix, the file stem naming its species).
    pub plant: String,
    /// Read from the cache (no GPU work).
    pub from_cache: bool,
    /// Milliseconds spent baking or reading.
    pub ms: f64,
    /// The cache file, when caching is on.
    pub path: Option<std::path::PathBuf>,
    /// Why an existing file was not used (re-baked), if one existed.
    pub stale: Option<String>,
    /// Payload bytes.
    pub bytes: u64,
}

/// The offline half of a technique: one plant → one asset (its payload through
/// [`codec::Codec`]), a pure function of the plant and
/// the bake parameters, cached on disk by [`load_or_bake`]. The cache key is the hash of the
/// parameters' canonical serialisation (every field, none picked by hand), the plant's whole
/// content ([`plant_hash`]) and the format versions.
pub trait Bake {
    /// The technique's name (the cache file names it).
    const NAME: &'static str;
    /// Version of the payload; bump when the asset's [`codec::Codec::encode`] output or the
    /// bake's result changes.
    const FORMAT_VERSION: u32;
    /// Everything the bake depends on besides the plant.
    type Params: crate::technique::params::ParamTable;
    /// One plant's baked asset, with its payload codec.
    type Asset: Clone + codec::Codec;
    /// Bakes one plant; `progress(done, total)` reports work units as they complete.
    fn bake(
        gpu: &Gpu,
        plant: &Plant,
        params: &Self::Params,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<Self::Asset, RenderError>;
    /// What `sylvan bake` reports about an asset.
    fn describe(asset: &Self::Asset) -> AssetSummary;
    /// Checks a decoded asset against the plant it is for (indices in range, finite bounds):
    /// a cache file whose checksum holds but whose content does not fit is re-baked like a
    /// corrupt one. The message names what is wrong.
    fn check(_asset: &Self::Asset, _plant: &Plant) -> Result<(), String> {
        Ok(())
    }
}

/// A baked asset described for `sylvan bake`'s line and JSON.
#[derive(Debug, Clone, Default)]
pub struct AssetSummary {
    /// The technique's part of the human-readable line ("24 boxes, 144 images of 64²").
    pub line: String,
    /// GPU texture bytes of its images (all mips).
    pub image_bytes: u64,
    /// Images baked.
    pub images: usize,
    /// Texels per image side.
    pub tile: u32,
    /// The technique's own figures (merged into the JSON object).
    pub fields: serde_json::Map<String, serde_json::Value>,
}

/// The cache key of `B`'s asset for `plant`: name, versions, the canonical JSON of `params`
/// (struct field order, so every field counts) and [`plant_hash`].
pub fn cache_key<B: Bake>(plant: &Plant, params: &B::Params) -> u64 {
    let canonical = serde_json::to_vec(params).unwrap_or_default();
    let mut h = codec::Fnv64::default();
    h.field(B::NAME.as_bytes())
        .u32s(&[B::FORMAT_VERSION, cache::CONTAINER_VERSION])
        .field(&canonical)
        .write(&plant_hash(plant).to_le_bytes());
    h.finish()
}

/// Content hash of everything in a plant a bake may read: meshes, leaf texture, bounds, the
/// branch hierarchy and the instancing (not its name).
pub fn plant_hash(plant: &Plant) -> u64 {
    fn mesh(h: &mut codec::Fnv64, m: &sylvan_plant::Mesh) {
        h.f32s(bytemuck::cast_slice(&m.positions))
            .f32s(bytemuck::cast_slice(&m.normals))
            .f32s(bytemuck::cast_slice(&m.uvs))
            .f32s(bytemuck::cast_slice(&m.colors))
            .u32s(&m.indices);
    }
    let mut h = codec::Fnv64::default();
    mesh(&mut h, &plant.wood);
    mesh(&mut h, &plant.leaves);
    for t in [&plant.leaf_texture, &plant.leaf_back, &plant.leaf_normal] {
        h.u32s(&[t.width, t.height]).field(&t.rgba);
    }
    h.f32s(&plant.bbox_min).f32s(&plant.bbox_max);
    let hier = &plant.hierarchy;
    h.u32s(&[hier.nodes.len() as u32])
        .u32s(&hier.leaf_first_index);
    for n in &hier.nodes {
        h.u32s(&[
            n.parent.unwrap_or(u32::MAX),
            n.level,
            n.leaves.start,
            n.leaves.end,
            n.own_leaves,
            n.own_internodes,
            n.leaf_indices.start,
            n.leaf_indices.end,
            n.wood_indices.start,
            n.wood_indices.end,
        ])
        .u32s(&n.children)
        .f32s(&n.bbox_min)
        .f32s(&n.bbox_max);
    }
    let inst = &plant.instancing;
    h.u32s(&[inst.root, inst.objects.len() as u32]);
    for o in &inst.objects {
        h.u32s(&[o.level, o.uses, o.instances.len() as u32]);
        mesh(&mut h, &o.wood);
        mesh(&mut h, &o.leaves);
        for i in &o.instances {
            h.u32s(&[i.object]).f32s(&i.transform.to_cols_array());
        }
    }
    h.finish()
}

/// Returns `B`'s baked asset for `plant`: from the cache when a file with the same inputs
/// exists, else baked on the GPU and written atomically. A stale, truncated or corrupt file is
/// reported in [`BakeReport::stale`] and replaced. `progress(done, total)` follows the bake.
pub fn load_or_bake<B: Bake>(
    gpu: &Gpu,
    plant: &Plant,
    params: &B::Params,
    policy: &CachePolicy,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<(B::Asset, BakeReport), RenderError> {
    use crate::technique::params::ParamTable;
    params
        .validate()
        .map_err(|why| RenderError::Param(format!("{}: {why}", B::NAME)))?;
    let key = cache::CacheKey {
        technique: B::NAME.to_string(),
        format_version: B::FORMAT_VERSION,
        hash: cache_key::<B>(plant, params),
    };
    load_or_compute(
        &plant.name,
        &key,
        policy,
        |a: &B::Asset| {
            B::check(a, plant).map_err(|e| format!("payload does not fit the plant: {e}"))
        },
        || B::bake(gpu, plant, params, progress),
    )
}

/// The cache round of every baked asset ([`load_or_bake`] for one plant, `shadermap`'s tables
/// for a species mix): the file `<stem>-<technique>-<hash>.sylbake` (or `policy`'s) read,
/// verified (container, key, checksum, then `check` on the decoded payload) and returned; else
/// `compute` runs and its result is written atomically. A stale, truncated or corrupt file is
/// reported in [`BakeReport::stale`] and replaced; an unwritable cache folder is a warning
/// (the asset is used from memory) unless `policy` names the file.
pub fn load_or_compute<A: codec::Codec>(
    stem: &str,
    key: &cache::CacheKey,
    policy: &CachePolicy,
    check: impl Fn(&A) -> Result<(), String>,
    compute: impl FnOnce() -> Result<A, RenderError>,
) -> Result<(A, BakeReport), RenderError> {
    let start = std::time::Instant::now();
    let path = match policy {
        CachePolicy::Default => Some(cache::default_dir().join(cache::file_name(stem, key))),
        CachePolicy::Dir(d) => Some(d.join(cache::file_name(stem, key))),
        CachePolicy::File(f) => Some(f.clone()),
        CachePolicy::Off => None,
    };
    let mut stale = None;
    if let Some(p) = &path {
        match cache::read(p, key) {
            cache::Lookup::Hit(payload) => match A::decode(&payload)
                .map_err(|e| format!("payload does not decode: {e}"))
                .and_then(|a| {
                    check(&a)?;
                    Ok(a)
                }) {
                Ok(baked) => {
                    return Ok((
                        baked,
                        BakeReport {
                            plant: stem.to_string(),
                            from_cache: true,
                            ms: start.elapsed().as_secs_f64() * 1e3,
                            path: path.clone(),
                            stale: None,
                            bytes: payload.len() as u64,
                        },
                    ));
                }
                Err(why) => stale = Some(why),
            },
            cache::Lookup::Miss => {}
            cache::Lookup::Stale(why) => stale = Some(why),
        }
    }
    let baked = compute()?;
    let payload = baked.encode();
    if let Some(p) = &path
        && let Err(e) = cache::write(p, key, &payload)
    {
        let what = format!(
            "{}: cannot write the bake cache: {e} — set SYLVAN_CACHE_DIR to a writable folder",
            p.display()
        );
        // `--out FILE` asked for the file; a cache folder is only a cache: draw from memory.
        if matches!(policy, CachePolicy::File(_)) {
            return Err(RenderError::Option(what));
        }
        eprintln!("warning: {what} (the asset is used from memory)");
    }
    Ok((
        baked,
        BakeReport {
            plant: stem.to_string(),
            from_cache: false,
            ms: start.elapsed().as_secs_f64() * 1e3,
            path,
            stale,
            bytes: payload.len() as u64,
        },
    ))
}

#[cfg(test)]
mod tests {
    #[test]
    fn halves_decode() {
        for (bits, v) in [
            (0x3c00u16, 1.0f32),
            (0xc000, -2.0),
            (0x3800, 0.5),
            (0x0000, 0.0),
            (0x7bff, 65504.0),
            (0x0001, 5.960_464_5e-8),
        ] {
            assert_eq!(super::f16_to_f32(bits), v, "{bits:#x}");
        }
        assert!(super::f16_to_f32(0x7e00).is_nan());
    }
}
