//! The GPU records of `hbt` and their creation: the image sets, sample frames and atlas
//! parameters the shader reads ([`GpuHbtSet`], [`GpuSampleFrame`], [`GpuHbtAtlas`]), the
//! per-billboard instance record ([`GpuHbtInstance`], built by [`billboard`] and [`caster`]),
//! and the atlas, bind group and pipelines ([`BillboardGpu::new`]).

use super::super::{HbtDrawParams, HbtProjection, HbtShadows};
use crate::RenderError;
use crate::directions::DirectionSet;
use crate::frame::FrameResources;
use crate::technique::common::{self, TileAtlas};
use crate::technique::hbt::bake as hb;
use bytemuck::{Pod, Zeroable};
use glam::{Affine3A, Vec3};
use sylvan_gpu::{Gpu, layout};
use wgpu::util::DeviceExt;

/// One image set (a tree's BTF, or an object's of the level below) as the shader sees it.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, PartialEq)]
pub(super) struct GpuHbtSet {
    min: [f32; 4],
    max: [f32; 4],
    info: [u32; 4],
    counts: [u32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(super) struct GpuSampleFrame {
    u: [f32; 4],
    v: [f32; 4],
    f: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(super) struct GpuHbtAtlas {
    tiles: [u32; 4],
    params: [f32; 4],
    shading: [f32; 4],
}

/// One billboard (a tree, or one object of an opened tree) as the `hbt` shader sees it
/// (vertex locations 4–13, per instance).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug, PartialEq)]
pub(super) struct GpuHbtInstance {
    /// Rows of the model → world affine map.
    pub(super) m: [[f32; 4]; 3],
    /// The 3 view samples; w: image set.
    pub(super) views: [u32; 4],
    /// The 3 light samples; w: hierarchy level (0 tree, 1 main branch, 2 small branch), for
    /// the technique debug view.
    pub(super) lights: [u32; 4],
    /// Pair weights `w[3·view + light]`; the last 3 unused.
    pub(super) weights: [f32; 12],
    /// Sun transmittance at the 8 box corners (x: corners 0–3, y: 4–7, unorm8), then the sky
    /// transmittance (z, w): the visibility cube-maps' levels combined (MNP01 §4.2).
    pub(super) vis: [u32; 4],
    /// Tint seed, presence, uniform scale, world bounding radius.
    pub(super) extra: [f32; 4],
}

impl GpuHbtInstance {
    const LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<GpuHbtInstance>() as u64,
        step_mode: wgpu::VertexStepMode::Instance,
        attributes: &wgpu::vertex_attr_array![
            4 => Float32x4, 5 => Float32x4, 6 => Float32x4, 7 => Uint32x4, 8 => Uint32x4,
            9 => Float32x4, 10 => Float32x4, 11 => Float32x4, 12 => Uint32x4, 13 => Float32x4
        ],
    };
}

/// The billboards' persistent GPU state: the atlas of every image set with its records, bound
/// once, and the camera and shadow pipelines.
pub(super) struct BillboardGpu {
    pub(super) pipeline: wgpu::RenderPipeline,
    pub(super) shadow_pipeline: wgpu::RenderPipeline,
    pub(super) bind: wgpu::BindGroup,
    /// Bytes of the atlas and the buffers.
    pub(super) bytes: u64,
}

impl BillboardGpu {
    /// Uploads `tiles` (tile side `tile`) into one atlas with the image sets `sets` and their
    /// sample frames `frames`, and builds the pipelines.
    pub(super) fn new(
        gpu: &Gpu,
        frame: &FrameResources,
        tile: u32,
        tiles: &[&[Vec<u8>]],
        sets: &[GpuHbtSet],
        frames: &[GpuSampleFrame],
        params: &HbtDrawParams,
    ) -> Result<Self, RenderError> {
        let device = &gpu.device;
        let atlas = TileAtlas::upload(
            gpu,
            "hbt_atlas",
            wgpu::TextureFormat::Rgba8UnormSrgb,
            tile,
            tiles,
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
                (params.shadows == HbtShadows::Cascades) as u32 as f32,
                params.lod_bias,
            ],
            shading: [params.shadow_margin, 0.0, 0.0, 0.0],
        };
        let storage = |label, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let species_buffer = storage("hbt_sets", bytemuck::cast_slice(sets));
        let frame_buffer = storage("hbt_frames", bytemuck::cast_slice(frames));
        let atlas_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("hbt_atlas_params"),
            contents: bytemuck::bytes_of(&uniform),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let sampler = common::trilinear_sampler(gpu, "hbt_sampler");
        let vf = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let bind_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hbt_layout"),
            entries: &[
                layout::storage(0, vf),
                layout::storage(1, vf),
                layout::atlas(2),
                layout::sampler(
                    3,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::SamplerBindingType::Filtering,
                ),
                layout::uniform(4, vf),
            ],
        });
        let atlas_view = atlas.view();
        let bind = common::bind_group(
            gpu,
            "hbt_bind",
            &bind_layout,
            &[
                species_buffer.as_entire_binding(),
                frame_buffer.as_entire_binding(),
                wgpu::BindingResource::TextureView(&atlas_view),
                wgpu::BindingResource::Sampler(&sampler),
                atlas_buffer.as_entire_binding(),
            ],
        );
        let module = sylvan_gpu::shader(gpu, "hbt", &super::super::shader_source());
        let (main, shadow) = common::image_pipelines(
            gpu,
            frame,
            &module,
            "hbt",
            &[None, Some(GpuHbtInstance::LAYOUT)],
            &bind_layout,
        );
        Ok(Self {
            pipeline: main,
            shadow_pipeline: shadow,
            bind,
            bytes: atlas.bytes + species_buffer.size() + frame_buffer.size() + atlas_buffer.size(),
        })
    }
}

/// Where prepared image sets go: their shader records, sample frames and atlas tiles.
pub(super) struct SetSink<'s, 'a> {
    pub(super) sets: &'s mut Vec<GpuHbtSet>,
    pub(super) frames: &'s mut Vec<GpuSampleFrame>,
    pub(super) tiles: &'s mut Vec<&'a [Vec<u8>]>,
    pub(super) tile: u32,
}

impl<'a> SetSink<'_, 'a> {
    /// Adds one image set (views `dirs`, `lights` light samples, framing `bbox`); returns its
    /// index.
    pub(super) fn add(
        &mut self,
        dirs: &DirectionSet,
        lights: usize,
        bbox: (Vec3, Vec3),
        direct: &'a [Vec<Vec<u8>>],
        ambient: &'a [Vec<Vec<u8>>],
    ) -> u32 {
        let (min, max) = bbox;
        let first_frame = self.frames.len() as u32;
        for &d in dirs.directions() {
            let f = hb::view_frame(d, min, max, self.tile);
            self.frames.push(GpuSampleFrame {
                u: f.u.extend(f.half.x).to_array(),
                v: f.v.extend(f.half.y).to_array(),
                f: f.f.extend(f.half.z).to_array(),
            });
        }
        let first_tile = self.tiles.len() as u32;
        self.tiles.extend(direct.iter().map(|m| m.as_slice()));
        self.tiles.extend(ambient.iter().map(|m| m.as_slice()));
        let (nv, nl) = (dirs.len() as u32, lights as u32);
        self.sets.push(GpuHbtSet {
            min: min.extend((max - min).length() * 0.5).to_array(),
            max: max.extend(0.0).to_array(),
            info: [first_tile, nl, first_tile + nv * nl, first_frame],
            counts: [nv, 0, 0, 0],
        });
        self.sets.len() as u32 - 1
    }
}

fn pack_unorm(v: [f32; 4]) -> u32 {
    v.iter().enumerate().fold(0u32, |acc, (k, x)| {
        acc | (((x.clamp(0.0, 1.0) * 255.0).round() as u32) << (8 * k))
    })
}

pub(super) fn pack8(v: [f32; 8]) -> [u32; 2] {
    [
        pack_unorm([v[0], v[1], v[2], v[3]]),
        pack_unorm([v[4], v[5], v[6], v[7]]),
    ]
}

/// One billboard record: `to_world` (a similarity), image set `set`, view and light look-ups
/// (model space), visibility and presence.
#[allow(clippy::too_many_arguments)]
pub(super) fn billboard(
    to_world: &Affine3A,
    set: u32,
    views: ([u32; 3], [f32; 3]),
    lights: ([u32; 3], [f32; 3]),
    min_weight: f32,
    vis: ([f32; 8], [f32; 8]),
    tint: f32,
    presence: f32,
    scale: f32,
    radius: f32,
) -> GpuHbtInstance {
    let m = to_world.matrix3;
    let t = to_world.translation;
    let w = hb::reconstruction_weights(views.1, lights.1, min_weight);
    let mut weights = [0.0; 12];
    weights[..9].copy_from_slice(&w);
    let (sun, sky) = (pack8(vis.0), pack8(vis.1));
    GpuHbtInstance {
        m: [
            [m.x_axis.x, m.y_axis.x, m.z_axis.x, t.x],
            [m.x_axis.y, m.y_axis.y, m.z_axis.y, t.y],
            [m.x_axis.z, m.y_axis.z, m.z_axis.z, t.z],
        ],
        views: [views.0[0], views.0[1], views.0[2], set],
        lights: [lights.0[0], lights.0[1], lights.0[2], 0],
        weights,
        vis: [sun[0], sun[1], sky[0], sky[1]],
        extra: [tint, presence, scale, radius],
    }
}

/// Which of the 3 view samples a caster uses: the largest weight, the weights quantised to
/// 1/1024 and the first of equal ones — so that a tie in exact arithmetic (the sun on a
/// symmetry plane of the direction set, as for a tree turned by 0 under a sun at 135°) is
/// broken alike by the CPU and by a GPU whose rounding differs (`select.wgsl`'s `caster`; on
/// GL the unquantised choice differed for one tree of a test grove: ꟻLIP 0.0053).
pub(super) fn caster_sample(w: [f32; 3]) -> usize {
    let q = w.map(|x| (x * 1024.0).floor());
    let mut best = 0;
    for k in 1..3 {
        if q[k] > q[best] {
            best = k;
        }
    }
    best
}

/// One shadow-caster record: seen from the sun only coverage matters, so the nearest of the
/// view samples `views` (looked up from the sun, in the object's frame) alone — blending 3
/// samples' differing silhouettes thins the crown's coverage, and with it its shadow (on the
/// test grove, ground shadow coverage 0.070 blended vs 0.112 reference).
pub(super) fn caster(
    to_world: &Affine3A,
    set: u32,
    views: ([u32; 3], [f32; 3]),
    tint: f32,
    presence: f32,
    scale: f32,
    radius: f32,
) -> GpuHbtInstance {
    let (v, vw) = views;
    let best = caster_sample(vw);
    let mut inst = billboard(
        to_world,
        set,
        (v, vw),
        ([0; 3], [1.0, 0.0, 0.0]),
        0.0,
        ([1.0; 8], [1.0; 8]),
        tint,
        presence,
        scale,
        radius,
    );
    inst.weights = [0.0; 12];
    inst.weights[3 * best] = 1.0;
    inst
}
