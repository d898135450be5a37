//! The occlusion cull's depth pyramid (#15 "occlusion against the previous frame's depth
//! pyramid"): after a frame's trees are drawn, the main target's depth is reduced into levels
//! of `R32Float` texels, each the **farthest** depth (reversed Z: the smallest value) of the
//! square of pixels it covers (`hiz.wgsl`). The next frame's cull projects each tree's box with
//! *that* frame's view-projection, picks the level where the box spans at most 2×2 texels, and
//! drops the tree from the camera list when its nearest point is farther than everything drawn
//! there (`cull.wgsl`, `occluded`).
//!
//! Limits, plainly: the test is one frame late (a tree hidden from the previous eye but seen
//! from this one is missing for a frame — BENCHMARKS measures how often); the pyramid is not
//! used after the eye moved more than [`MAX_MOVE_M`] (a cut: that frame culls without it); only
//! Sylvan's own main target (reversed Z, one sample) is reduced; shadow passes do not use it;
//! what occludes is what writes depth (blended impostors do not).

use crate::RenderError;
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};
use sylvan_gpu::Gpu;

/// The pyramid is not trusted after the eye moved more than this since the frame it holds
/// (metres): one frame at 100 m/s and 60 Hz moves 1.7 m.
pub const MAX_MOVE_M: f32 = 10.0;

/// Most levels (a 16k-pixel target has 14).
pub const MAX_LEVELS: usize = 16;

const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuLevel {
    here: [u32; 4],
    below: [u32; 4],
}

/// Sizes of the levels of a pyramid over a `source`-pixel target: level 0 half of it
/// (rounding up), then halving (rounding down, as mip chains), down to 1×1.
pub(crate) fn level_sizes(source: [u32; 2]) -> Vec<[u32; 2]> {
    let first = [source[0].div_ceil(2).max(1), source[1].div_ceil(2).max(1)];
    let levels = (32 - first[0].max(first[1]).leading_zeros()) as usize;
    (0..levels.min(MAX_LEVELS))
        .map(|l| [(first[0] >> l).max(1), (first[1] >> l).max(1)])
        .collect()
}

/// The pyramid's two textures (even levels in the first, odd in the second, each level at the
/// x offset of the widths of the levels before it), and per level its bind group.
struct Levels {
    textures: [wgpu::Texture; 2],
    views: [wgpu::TextureView; 2],
    sizes: Vec<[u32; 2]>,
    offsets: Vec<u32>,
    /// Per level above 0 (reading the level below); level 0's reads the depth target (see
    /// [`DepthPyramid::source`]).
    binds: Vec<wgpu::BindGroup>,
    uniforms: Vec<wgpu::Buffer>,
}

/// The pyramid and what the cull needs to test against it.
pub(crate) struct DepthPyramid {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    levels: Levels,
    /// The depth target's size the pyramid was made for.
    source_size: [u32; 2],
    /// Level 0's bind group and the depth view it reads (made again when the view or the
    /// levels change).
    source: Option<(wgpu::TextureView, wgpu::BindGroup)>,
    /// The frame it holds: view-projection and eye (`None` until a frame was reduced).
    held: Option<(Mat4, Vec3)>,
    /// Changes whenever the textures are replaced (the cull's bind groups bind them).
    pub generation: u64,
}

/// What the cull tests against this frame.
pub(crate) struct PyramidUse<'a> {
    /// Even and odd levels.
    pub views: [&'a wgpu::TextureView; 2],
    pub generation: u64,
    /// The previous frame's view-projection (zero: no test).
    pub view_proj: Mat4,
    /// x 1: test on; y levels; zw the full-resolution size (pixels).
    pub info: [f32; 4],
    /// Per level its x offset (4 per row).
    pub offsets: [[u32; 4]; MAX_LEVELS / 4],
}

impl<'a> PyramidUse<'a> {
    /// No test, binding `views` (any two R32Float textures).
    pub fn none(views: [&'a wgpu::TextureView; 2]) -> Self {
        Self {
            views,
            generation: 0,
            view_proj: Mat4::ZERO,
            info: [0.0; 4],
            offsets: [[0; 4]; MAX_LEVELS / 4],
        }
    }
}

/// Two 1×1 textures for a cull without a pyramid to bind.
pub(crate) fn placeholder(gpu: &Gpu) -> [wgpu::TextureView; 2] {
    let t = || {
        gpu.device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some("no_depth_pyramid"),
                size: wgpu::Extent3d {
                    width: 1,
                    height: 1,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: FORMAT,
                usage: wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            })
            .create_view(&Default::default())
    };
    [t(), t()]
}

impl DepthPyramid {
    /// A 1×1 pyramid that tests nothing, until [`DepthPyramid::reduce`] sizes it.
    pub fn new(gpu: &Gpu) -> Self {
        let device = &gpu.device;
        let module = sylvan_gpu::shader(gpu, "hiz", include_str!("hiz.wgsl"));
        let c = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hiz_layout"),
            entries: &[
                sylvan_gpu::layout::uniform(0, c),
                sylvan_gpu::layout::texture(
                    1,
                    c,
                    wgpu::TextureSampleType::Float { filterable: false },
                    wgpu::TextureViewDimension::D2,
                ),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: c,
                    ty: wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format: FORMAT,
                        view_dimension: wgpu::TextureViewDimension::D2,
                    },
                    count: None,
                },
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hiz_pipeline_layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("hiz_reduce"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("reduce"),
            compilation_options: Default::default(),
            cache: None,
        });
        let levels = make(gpu, &layout, [1, 1]);
        Self {
            pipeline,
            layout,
            levels,
            source_size: [0, 0],
            source: None,
            held: None,
            // 0 is the generation of `PyramidUse::none`'s textures.
            generation: 1,
        }
    }

    /// GPU bytes.
    pub fn bytes(&self) -> u64 {
        self.levels
            .textures
            .iter()
            .map(|t| t.width() as u64 * t.height() as u64 * 4)
            .sum()
    }

    /// What this frame's cull tests against: the pyramid of the last reduced frame, unless the
    /// eye moved more than [`MAX_MOVE_M`] since (or none was reduced).
    pub fn for_frame(&self, eye: Vec3) -> PyramidUse<'_> {
        let held = self
            .held
            .filter(|&(_, at)| at.distance(eye) <= MAX_MOVE_M && self.source_size[0] > 0);
        let mut offsets = [[0; 4]; MAX_LEVELS / 4];
        for (l, &o) in self.levels.offsets.iter().enumerate() {
            offsets[l / 4][l % 4] = o;
        }
        PyramidUse {
            views: [&self.levels.views[0], &self.levels.views[1]],
            generation: self.generation,
            view_proj: held.map_or(Mat4::ZERO, |h| h.0),
            info: [
                held.is_some() as u32 as f32,
                self.levels.sizes.len() as f32,
                self.source_size[0] as f32,
                self.source_size[1] as f32,
            ],
            offsets,
        }
    }

    /// Records the reduction of `depth` (the main target's reversed-Z depth, `size` pixels),
    /// drawn from `eye` with `view_proj`.
    pub fn reduce(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        depth: &wgpu::TextureView,
        size: [u32; 2],
        view_proj: Mat4,
        eye: Vec3,
    ) -> Result<(), RenderError> {
        if size != self.source_size {
            let first = level_sizes(size)[0];
            gpu.check_texture_size("depth pyramid", first[0] * 2, first[1])?;
            self.levels = make(gpu, &self.layout, size);
            self.source_size = size;
            self.source = None;
            self.generation += 1;
        }
        let l = &self.levels;
        if self.source.as_ref().is_none_or(|(view, _)| view != depth) {
            let bind = crate::technique::common::bind_group(
                gpu,
                "hiz_from_depth",
                &self.layout,
                &[
                    l.uniforms[0].as_entire_binding(),
                    wgpu::BindingResource::TextureView(depth),
                    wgpu::BindingResource::TextureView(&l.views[0]),
                ],
            );
            self.source = Some((depth.clone(), bind));
        }
        let first = &self.source.as_ref().expect("made above").1;
        for (level, &[w, h]) in l.sizes.iter().enumerate() {
            // One pass per level: each reads the one below.
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("hiz"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(
                0,
                match level {
                    0 => first,
                    _ => &l.binds[level - 1],
                },
                &[],
            );
            pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
        }
        self.held = Some((view_proj, eye));
        Ok(())
    }
}

/// The levels of a pyramid over a `source`-pixel target.
fn make(gpu: &Gpu, layout: &wgpu::BindGroupLayout, source: [u32; 2]) -> Levels {
    use wgpu::util::DeviceExt;
    let sizes = level_sizes(source);
    let mut offsets = Vec::with_capacity(sizes.len());
    let mut at = 0;
    for s in &sizes {
        offsets.push(at);
        at += s[0];
    }
    let texture = || {
        gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("depth_pyramid"),
            size: wgpu::Extent3d {
                width: at.max(1),
                height: sizes[0][1],
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: FORMAT,
            usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        })
    };
    let textures = [texture(), texture()];
    let views = [
        textures[0].create_view(&Default::default()),
        textures[1].create_view(&Default::default()),
    ];
    let uniforms: Vec<wgpu::Buffer> = (0..sizes.len())
        .map(|l| {
            let (below_offset, below) = match l {
                0 => (0, source),
                _ => (offsets[l - 1], sizes[l - 1]),
            };
            let level = GpuLevel {
                here: [offsets[l], 0, sizes[l][0], sizes[l][1]],
                below: [below_offset, 0, below[0], below[1]],
            };
            gpu.device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("hiz_level"),
                    contents: bytemuck::bytes_of(&level),
                    usage: wgpu::BufferUsages::UNIFORM,
                })
        })
        .collect();
    let binds = (1..sizes.len())
        .map(|l| {
            crate::technique::common::bind_group(
                gpu,
                "hiz_level",
                layout,
                &[
                    uniforms[l].as_entire_binding(),
                    wgpu::BindingResource::TextureView(&views[(l - 1) % 2]),
                    wgpu::BindingResource::TextureView(&views[l % 2]),
                ],
            )
        })
        .collect();
    Levels {
        textures,
        views,
        sizes,
        offsets,
        binds,
        uniforms,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_halve_down_to_one_texel() {
        assert_eq!(
            level_sizes([1280, 720]),
            vec![
                [640, 360],
                [320, 180],
                [160, 90],
                [80, 45],
                [40, 22],
                [20, 11],
                [10, 5],
                [5, 2],
                [2, 1],
                [1, 1]
            ]
        );
        assert_eq!(level_sizes([1, 1]), vec![[1, 1]]);
        assert_eq!(level_sizes([3, 1]), vec![[2, 1], [1, 1]]);
    }
}
