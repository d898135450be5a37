//! The stats overlay's numbers (frame times on the GPU timer and the CPU clock, what the frame
//! drew, GPU memory) and the `--stats` report of a scripted run, with wgpu's live GPU object
//! counts — the check that nothing is allocated per frame while nothing changes.

use serde::Serialize;
use std::collections::{BTreeMap, VecDeque};
use sylvan_render::FrameStats;

/// Frames the overlay averages over.
pub const WINDOW: usize = 30;

/// Recent frame times and the last frame's counts.
#[derive(Default)]
pub struct FrameClock {
    gpu_ms: VecDeque<f64>,
    cpu_ms: VecDeque<f64>,
    /// The last frame's stats.
    pub last: Option<FrameStats>,
}

impl FrameClock {
    /// Adds a frame: the renderer's stats and the CPU time between frame starts.
    pub fn push(&mut self, stats: FrameStats, cpu_ms: f64) {
        for (q, v) in [
            (&mut self.gpu_ms, stats.frame_ms),
            (&mut self.cpu_ms, cpu_ms),
        ] {
            if q.len() == WINDOW {
                q.pop_front();
            }
            q.push_back(v);
        }
        self.last = Some(stats);
    }

    /// Mean renderer frame time (GPU timestamps, or wall clock where the adapter has none).
    pub fn gpu_ms(&self) -> f64 {
        mean(&self.gpu_ms)
    }

    /// Mean CPU time per frame (the whole loop: render, panel, present).
    pub fn cpu_ms(&self) -> f64 {
        mean(&self.cpu_ms)
    }
}

fn mean(q: &VecDeque<f64>) -> f64 {
    if q.is_empty() {
        0.0
    } else {
        q.iter().sum::<f64>() / q.len() as f64
    }
}

/// `1.2 MiB`-style sizes.
pub fn bytes(b: u64) -> String {
    const MIB: f64 = 1024.0 * 1024.0;
    if b as f64 >= MIB {
        format!("{:.1} MiB", b as f64 / MIB)
    } else {
        format!("{:.1} KiB", b as f64 / 1024.0)
    }
}

/// Live GPU objects and memory as wgpu counts them (its `counters` feature).
#[derive(Serialize, Debug, Clone, Copy, PartialEq, Eq)]
pub struct GpuObjects {
    /// Buffers.
    pub buffers: isize,
    /// Textures.
    pub textures: isize,
    /// Texture views.
    pub texture_views: isize,
    /// Bind groups.
    pub bind_groups: isize,
    /// Samplers.
    pub samplers: isize,
    /// Render pipelines.
    pub render_pipelines: isize,
    /// Shader modules.
    pub shader_modules: isize,
    /// Query sets.
    pub query_sets: isize,
    /// Bytes of buffer memory.
    pub buffer_memory: isize,
    /// Bytes of texture memory.
    pub texture_memory: isize,
    /// Memory allocations.
    pub memory_allocations: isize,
}

impl GpuObjects {
    /// The device's counts now.
    pub fn of(device: &wgpu::Device) -> Self {
        let c = device.get_internal_counters().hal;
        Self {
            buffers: c.buffers.read(),
            textures: c.textures.read(),
            texture_views: c.texture_views.read(),
            bind_groups: c.bind_groups.read(),
            samplers: c.samplers.read(),
            render_pipelines: c.render_pipelines.read(),
            shader_modules: c.shader_modules.read(),
            query_sets: c.query_sets.read(),
            buffer_memory: c.buffer_memory.read(),
            texture_memory: c.texture_memory.read(),
            memory_allocations: c.memory_allocations.read(),
        }
    }
}

/// One frame of a scripted run.
#[derive(Serialize, Debug, Clone)]
pub struct FrameRecord {
    /// Frame index (0-based).
    pub frame: usize,
    /// Path time (seconds) when a path is replayed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub t: Option<f32>,
    /// Renderer frame time (its timer).
    pub ms: f64,
    /// CPU time of the whole loop iteration.
    pub cpu_ms: f64,
    /// Trees drawn per technique.
    pub trees_drawn: BTreeMap<String, u32>,
    /// Camera-pass triangles.
    pub triangles: u64,
    /// Draw calls over all passes.
    pub draw_calls: u32,
}

/// A snapshot of what was allocated: wgpu's live objects, plus the viewer's own count of
/// renderer rebuilds and presenter (surface, composite, bind group) re-creations.
#[derive(Serialize, Debug, Clone, Copy, PartialEq, Eq)]
pub struct Allocations {
    /// After this many frames.
    pub after_frames: usize,
    /// wgpu's live objects.
    pub gpu: GpuObjects,
    /// Renderers made.
    pub renderer_rebuilds: u64,
    /// Presenter re-creations.
    pub presenter_allocations: u64,
}

/// The `--stats` JSON of a scripted run.
#[derive(Serialize, Debug)]
pub struct ViewReport {
    /// Frames run.
    pub frames: usize,
    /// Window size in physical pixels.
    pub window: [u32; 2],
    /// Scene render size.
    pub render_size: [u32; 2],
    /// Surface colour format.
    pub surface_format: String,
    /// The adapter.
    pub adapter: String,
    /// `gpu` or `wall`.
    pub timer: &'static str,
    /// Mean renderer frame time (ms).
    pub mean_ms: f64,
    /// Mean CPU time per loop iteration (ms).
    pub mean_cpu_ms: f64,
    /// Every frame.
    pub per_frame: Vec<FrameRecord>,
    /// Allocation snapshots after warm-up and at the end: equal when nothing was allocated.
    pub allocations: Vec<Allocations>,
    /// ꟻLIP mean of the last "compare with reference", if one ran.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flip_mean: Option<f32>,
}
