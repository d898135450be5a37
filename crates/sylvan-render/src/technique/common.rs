//! GPU pieces shared by the image-based techniques: a per-frame instance buffer that grows but
//! never shrinks, and an atlas of square tiles with per-tile mips in a `texture_2d_array`.
//!
//! (`boxtree` has its own copies of both, written first; they can move onto these.)

use crate::RenderError;
use crate::frame::FrameResources;
use crate::pipeline::{self, PassKind, PipelineSpec};
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};
use sylvan_gpu::Gpu;

/// Hermite smoothstep of `t` clamped to [0, 1]: 0 at 0, 1 at 1, zero slope at both ends.
/// Every level-of-detail cross-fade on the CPU uses it (WGSL has its own built-in).
pub(crate) fn smoothstep01(t: f32) -> f32 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// [`smoothstep01`] from `e0` to `e1`; with `e1 <= e0` a hard step at `e0`.
pub(crate) fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    if e1 <= e0 {
        return if x >= e0 { 1.0 } else { 0.0 };
    }
    smoothstep01((x - e0) / (e1 - e0))
}

/// Premultiplied colour composited "over" what is already drawn.
pub(crate) const PREMULTIPLIED_OVER: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: wgpu::BlendComponent::OVER,
};

/// A trilinear sampler (clamped to the edge) without anisotropy: on lavapipe/llvmpipe an
/// anisotropic sampler made the alpha-tested shadow pass ~1000× slower (measured: 150 s vs
/// 0.1 s for two trees).
pub(crate) fn trilinear_sampler(gpu: &Gpu, label: &str) -> wgpu::Sampler {
    gpu.device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some(label),
        address_mode_u: wgpu::AddressMode::ClampToEdge,
        address_mode_v: wgpu::AddressMode::ClampToEdge,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Linear,
        ..Default::default()
    })
}

/// An sRGB-encoded value in [0, 1] to linear.
pub(crate) fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A bind group binding `resources` to slots 0, 1, 2, … of `layout`.
pub(crate) fn bind_group(
    gpu: &Gpu,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    resources: &[wgpu::BindingResource<'_>],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = resources
        .iter()
        .enumerate()
        .map(|(binding, resource)| wgpu::BindGroupEntry {
            binding: binding as u32,
            resource: resource.clone(),
        })
        .collect();
    gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// An image technique's two pipelines over group 1 `layout`: the camera pass
/// (`vs_{entry}`/`fs_{entry}`: two-sided, premultiplied over, no depth write) and the shadow
/// pass (`vs_{entry}_shadow`/`fs_{entry}_shadow`: two-sided, depth only).
pub(crate) fn image_pipelines(
    gpu: &Gpu,
    frame: &FrameResources,
    module: &wgpu::ShaderModule,
    entry: &str,
    buffers: &[Option<wgpu::VertexBufferLayout<'_>>],
    layout: &wgpu::BindGroupLayout,
) -> (wgpu::RenderPipeline, wgpu::RenderPipeline) {
    let (vs, fs) = (format!("vs_{entry}"), format!("fs_{entry}"));
    let (vs_shadow, fs_shadow) = (format!("{vs}_shadow"), format!("{fs}_shadow"));
    let main = pipeline::build(
        gpu,
        &PipelineSpec {
            label: entry,
            layouts: &[&frame.main_layout, layout],
            module,
            vs: &vs,
            fs: Some(&fs),
            buffers,
            pass: PassKind::Main,
            frame,
            cull: None,
            depth_write: false,
            blend: Some(PREMULTIPLIED_OVER),
        },
    );
    let shadow = pipeline::build(
        gpu,
        &PipelineSpec {
            label: &vs_shadow,
            layouts: &[&frame.shadow_layout, layout],
            module,
            vs: &vs_shadow,
            fs: Some(&fs_shadow),
            buffers,
            pass: PassKind::Shadow,
            frame,
            cull: None,
            depth_write: true,
            blend: None,
        },
    );
    (main, shadow)
}

/// A vertex buffer that grows (doubling) when a frame needs more, and never shrinks.
pub(crate) struct Growable {
    pub(crate) buffer: wgpu::Buffer,
    label: &'static str,
    pub(crate) reallocations: u32,
}

impl Growable {
    pub(crate) fn new(gpu: &Gpu, label: &'static str, bytes: u64) -> Self {
        Self {
            buffer: Self::make(gpu, label, bytes.max(256)),
            label,
            reallocations: 0,
        }
    }

    fn make(gpu: &Gpu, label: &str, size: u64) -> wgpu::Buffer {
        gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// Writes `data` at offset 0, growing the buffer first when it is too small.
    pub(crate) fn write(&mut self, gpu: &Gpu, data: &[u8]) -> Result<(), RenderError> {
        let need = data.len() as u64;
        if need > self.buffer.size() {
            let limit = gpu.device.limits().max_buffer_size;
            let size = need.next_power_of_two().min(limit);
            if need > size {
                return Err(RenderError::Gpu(sylvan_gpu::GpuError::Limit {
                    what: format!("{} instance buffer", self.label),
                    needed: need,
                    limit,
                    fix: "lower the tree count".into(),
                }));
            }
            self.buffer = Self::make(gpu, self.label, size);
            self.reallocations += 1;
        }
        if !data.is_empty() {
            gpu.queue.write_buffer(&self.buffer, 0, data);
        }
        Ok(())
    }
}

/// Side of one atlas layer, at most (texels).
const LAYER_SIZE: u32 = 2048;
/// The same on wgpu's GL backend (see [`TileAtlas::upload`]).
const GL_LAYER_SIZE: u32 = 1024;

/// Square tiles of one size packed row-major into the layers of a 2D array texture, as close
/// to square and as tight as the tile count allows; each tile keeps its own mip chain (tile
/// sizes are powers of two and layers whole numbers of tiles, so mip `m` of the atlas holds mip
/// `m` of every tile at the same cell).
pub(crate) struct TileAtlas {
    pub(crate) texture: wgpu::Texture,
    /// Tiles per row of a layer.
    pub(crate) per_row: u32,
    /// Rows of tiles per layer.
    pub(crate) rows: u32,
    /// Tiles per layer.
    pub(crate) per_layer: u32,
    /// GPU bytes (all mips).
    pub(crate) bytes: u64,
}

impl TileAtlas {
    /// Uploads `tiles[i][mip]` (RGBA8, `(tile >> mip)²·4` bytes each; a power-of-two `tile`).
    pub(crate) fn upload(
        gpu: &Gpu,
        label: &str,
        format: wgpu::TextureFormat,
        tile: u32,
        tiles: &[&[Vec<u8>]],
    ) -> Result<Self, RenderError> {
        let limits = gpu.device.limits();
        // On wgpu's GL backend (llvmpipe, Mesa 22.3) a 2048² × 4-layer atlas samples black
        // while 1024² × 16 layers of the same tiles, 2048² × 3 and 4096² × 2 draw right
        // (measured, cause not found): GL atlases use 1024² layers.
        let gl = gpu.info.backend == wgpu::Backend::Gl;
        let layer_size = if gl { GL_LAYER_SIZE } else { LAYER_SIZE };
        let max_row = (layer_size.min(limits.max_texture_dimension_2d) / tile).max(1);
        let count = (tiles.len() as u32).max(1);
        let per_row = ((count as f64).sqrt().ceil() as u32).clamp(1, max_row);
        let rows = count.div_ceil(per_row).min(max_row);
        let per_layer = per_row * rows;
        let layers = count.div_ceil(per_layer);
        if layers > limits.max_texture_array_layers {
            return Err(RenderError::Gpu(sylvan_gpu::GpuError::Limit {
                what: format!("{label} layers"),
                needed: layers as u64,
                limit: limits.max_texture_array_layers as u64,
                fix: "use smaller tiles or fewer directions".into(),
            }));
        }
        let mips = tile.ilog2() + 1;
        let allocated = if gl {
            gl_array_layers(layers, per_row == rows)
        } else {
            layers
        };
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: per_row * tile,
                height: rows * tile,
                depth_or_array_layers: allocated,
            },
            mip_level_count: mips,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        for (t, levels) in tiles.iter().enumerate() {
            let t = t as u32;
            let (l, cell) = (t / per_layer, t % per_layer);
            let (cx, cy) = (cell % per_row, cell / per_row);
            for (m, data) in levels.iter().enumerate().take(mips as usize) {
                let size = (tile >> m).max(1);
                if data.len() != (size * size * 4) as usize {
                    return Err(RenderError::Plant(format!(
                        "{label}: tile {t} mip {m} has {} bytes, expected {}",
                        data.len(),
                        size * size * 4
                    )));
                }
                gpu.queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &texture,
                        mip_level: m as u32,
                        origin: wgpu::Origin3d {
                            x: cx * size,
                            y: cy * size,
                            z: l,
                        },
                        aspect: wgpu::TextureAspect::All,
                    },
                    data,
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(size * 4),
                        rows_per_image: Some(size),
                    },
                    wgpu::Extent3d {
                        width: size,
                        height: size,
                        depth_or_array_layers: 1,
                    },
                );
            }
        }
        let bytes = (0..mips)
            .map(|m| {
                let side = (tile >> m).max(1) as u64;
                (per_row as u64 * side) * (rows as u64 * side) * 4 * allocated as u64
            })
            .sum();
        Ok(Self {
            texture,
            per_row,
            rows,
            per_layer,
            bytes,
        })
    }

    /// A `D2Array` view of every layer and mip.
    pub(crate) fn view(&self) -> wgpu::TextureView {
        self.texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        })
    }
}

/// `pick(level)` of every tile's mip chain, as [`TileAtlas::upload`] takes them.
pub(crate) fn tile_chains(
    tiles: &[&Vec<crate::bake::image::TileLevel>],
    pick: fn(&crate::bake::image::TileLevel) -> &Vec<u8>,
) -> Vec<Vec<Vec<u8>>> {
    tiles
        .iter()
        .map(|levels| levels.iter().map(|l| pick(l).clone()).collect())
        .collect()
}

/// A GPU storage buffer holding `contents`.
pub(crate) fn storage_buffer(gpu: &Gpu, label: &str, contents: &[u8]) -> wgpu::Buffer {
    use wgpu::util::DeviceExt;
    gpu.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage: wgpu::BufferUsages::STORAGE,
        })
}

/// The CPU-driven twin of the GPU cull's mixed lists (one per pass holding every species,
/// `rot.z` = species + tint seed, as the cull writes it) for one-quad-per-tree techniques:
/// `staging` gets each pass's records, `ranges` their ranges; the camera pass is sorted back
/// to front by the distance of each tree's frame centre (`centres`, per species, model
/// space) when `sort_camera`.
pub(crate) fn mixed_lists(
    input: &crate::technique::FrameInput<'_>,
    centres: &[glam::Vec3],
    sort_camera: bool,
    sort: &mut Vec<(f32, crate::instances::GpuTreeInstance)>,
    staging: &mut Vec<crate::instances::GpuTreeInstance>,
    ranges: &mut [std::ops::Range<u32>],
) {
    staging.clear();
    for (pass, range) in ranges.iter_mut().enumerate() {
        sort.clear();
        for (s, centre) in centres.iter().enumerate() {
            for rec in input.instances.records(pass, s) {
                let [x, y, z, scale] = rec.base_scale;
                let (c, sn) = (rec.rot[0], rec.rot[1]);
                let q = *centre * scale;
                let world =
                    glam::Vec3::new(x + c * q.x + sn * q.z, y + q.y, z - sn * q.x + c * q.z);
                sort.push((
                    world.distance_squared(input.eye),
                    crate::instances::GpuTreeInstance {
                        base_scale: rec.base_scale,
                        rot: [rec.rot[0], rec.rot[1], s as f32 + rec.rot[2], rec.rot[3]],
                    },
                ));
            }
        }
        if pass == 0 && sort_camera {
            // Back to front: premultiplied "over" needs the far trees first.
            sort.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
        }
        let start = staging.len() as u32;
        staging.extend(sort.iter().map(|x| x.1));
        *range = start..staging.len() as u32;
    }
}

/// A buffer read back a frame or more late: copy → map after the frame's submission → read.
pub(crate) struct LateReadback {
    pub(crate) buffer: wgpu::Buffer,
    bytes: u64,
    /// 0 idle, 1 copied (not yet mapped), 2 map pending, 3 mapped, 4 map failed.
    state: Arc<AtomicU8>,
}

impl LateReadback {
    pub(crate) fn new(gpu: &Gpu, bytes: u64) -> Self {
        Self {
            buffer: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("late_readback"),
                size: bytes.next_multiple_of(256),
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            bytes,
            state: Arc::new(AtomicU8::new(0)),
        }
    }

    /// Records the copy when the buffer is free.
    pub(crate) fn copy(&self, encoder: &mut wgpu::CommandEncoder, src: &wgpu::Buffer) {
        if self.state.load(Ordering::Acquire) == 0 {
            encoder.copy_buffer_to_buffer(src, 0, &self.buffer, 0, self.bytes);
            self.state.store(1, Ordering::Release);
        }
    }

    /// Advances without waiting (the copy's frame has been submitted); the words once mapped.
    pub(crate) fn poll(&self) -> Option<Vec<u32>> {
        match self.state.load(Ordering::Acquire) {
            1 => {
                self.state.store(2, Ordering::Release);
                let state = self.state.clone();
                self.buffer
                    .slice(..self.bytes)
                    .map_async(wgpu::MapMode::Read, move |r| {
                        state.store(if r.is_ok() { 3 } else { 4 }, Ordering::Release);
                    });
                None
            }
            3 => {
                let words = self
                    .buffer
                    .slice(..self.bytes)
                    .get_mapped_range()
                    .ok()
                    .map(|d| bytemuck::cast_slice::<u8, u32>(&d).to_vec());
                self.buffer.unmap();
                self.state.store(0, Ordering::Release);
                words
            }
            4 => {
                self.state.store(0, Ordering::Release);
                None
            }
            _ => None,
        }
    }

    /// Waits for the copied words (after the frame's submission has completed).
    pub(crate) fn finish(&self, gpu: &Gpu) -> Result<Option<Vec<u32>>, RenderError> {
        for _ in 0..3 {
            if let Some(words) = self.poll() {
                return Ok(Some(words));
            }
            if self.state.load(Ordering::Acquire) == 0 {
                return Ok(None);
            }
            gpu.wait()?;
        }
        Ok(None)
    }
}

/// A storage buffer of at least `bytes` (256-byte multiple) with `extra` usages.
pub(crate) fn storage(
    gpu: &Gpu,
    label: &str,
    extra: wgpu::BufferUsages,
    bytes: u64,
) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(256).next_multiple_of(256),
        usage: wgpu::BufferUsages::STORAGE | extra,
        mapped_at_creation: false,
    })
}

/// A GPU-written list of `records`: its parked records (`parked` bytes each, a storage buffer)
/// and its output (`out` bytes each, also a vertex buffer), labelled `{prefix}_parked_{label}`
/// and `{prefix}_{label}` (`boxtree`'s and `hbt`'s GPU-driven frames).
pub(crate) fn parked_lists(
    gpu: &Gpu,
    prefix: &str,
    label: &str,
    records: u32,
    parked: u64,
    out: u64,
) -> (wgpu::Buffer, wgpu::Buffer) {
    (
        storage(
            gpu,
            &format!("{prefix}_parked_{label}"),
            wgpu::BufferUsages::empty(),
            records as u64 * parked,
        ),
        storage(
            gpu,
            &format!("{prefix}_{label}"),
            wgpu::BufferUsages::VERTEX,
            records as u64 * out,
        ),
    )
}

/// The layers to allocate for a `texture_2d_array` of `layers` that wgpu's GL backend can
/// sample: it picks the GL target from the size — one layer makes a GL_TEXTURE_2D and a square
/// (`square`: width = height) multiple of 6 layers a cube map, which the array binding then
/// samples as incomplete (black, opaque) — so at least two, never a square 6k.
pub(crate) fn gl_array_layers(layers: u32, square: bool) -> u32 {
    let n = layers.max(2);
    if square && n.is_multiple_of(6) {
        n + 1
    } else {
        n
    }
}
