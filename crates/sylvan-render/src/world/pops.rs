//! The pop audit (#15's "no tree appears or vanishes inside the view between consecutive
//! frames"): with [`crate::RenderOptions::count_pops`] (`sylvan bench --count-pops`), the cull
//! adds each tree's drawn camera presence into a per-pool-slot buffer, and one more dispatch
//! (`pops.wgsl`) compares it with the last frame's, counting the trees wholly inside the view
//! in both frames that appeared, vanished, or whose presence changed by more than the world's
//! fades allow in one frame: `1.5 × (eye displacement) / (narrowest fade)` — smoothstep's
//! steepest slope over the tree-distance fade or a band window's ramp — plus 0.01. The counts
//! are read back after each frame (a wait: a measurement mode, not for timing).
//!
//! Memory: 36 bytes per pool slot while on; nothing while off (the cull binds a 256-byte
//! placeholder).

use super::cull::MAX_SPECIES;
use crate::RenderError;
use crate::frame::Frustum;
use crate::technique::common::{LateReadback, storage};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use sylvan_gpu::{Gpu, layout};

/// Added to the fades' largest change per frame before a change counts (rounding of the
/// 1/65536 sums, and the fades' own small non-linearities).
const TOLERANCE: f32 = 0.01;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    now_planes: [[f32; 4]; 6],
    prev_planes: [[f32; 4]; 6],
    info: [u32; 4],
    step: [f32; 4],
    species: [[f32; 4]; MAX_SPECIES],
}

/// What the audit counted in the last frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PopCounts {
    /// Trees inside the view in both frames drawn now and not before (or with a presence jump
    /// from 0 beyond the step).
    pub appeared: u32,
    /// Trees inside the view in both frames drawn before and not now.
    pub vanished: u32,
    /// Trees drawn in both frames whose presence changed by more than the step.
    pub jumped: u32,
    /// The largest of those changes.
    pub largest: f32,
    /// The step the frame allowed.
    pub step: f32,
}

/// The audit's buffers and pipeline.
pub(crate) struct PopAudit {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    /// This frame's drawn presence per slot (the cull writes it).
    pub drawn: wgpu::Buffer,
    prev: wgpu::Buffer,
    counts: wgpu::Buffer,
    readback: LateReadback,
    slots: u32,
    species: [[f32; 4]; MAX_SPECIES],
    last: Option<([[f32; 4]; 6], Vec3)>,
    bind: Option<(wgpu::BindGroup, wgpu::Buffer)>,
    /// The last frame's counts.
    pub counts_read: PopCounts,
    step: f32,
}

impl PopAudit {
    /// For a pool of `slots` trees and the species' bounding spheres (as the cull's).
    pub fn new(gpu: &Gpu, slots: u32, species: [[f32; 4]; MAX_SPECIES]) -> Self {
        let device = &gpu.device;
        let c = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("pops_layout"),
            entries: &[
                layout::uniform(0, c),
                layout::storage(1, c),
                layout::storage_rw(2, c),
                layout::storage_rw(3, c),
                layout::storage_rw(4, c),
            ],
        });
        let module = sylvan_gpu::shader(gpu, "pops", include_str!("pops.wgsl"));
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("pops_pipeline_layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("pops_audit"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("audit"),
            compilation_options: Default::default(),
            cache: None,
        });
        let (drawn, prev) = slot_buffers(gpu, slots);
        Self {
            layout,
            pipeline,
            params: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("pops_params"),
                size: std::mem::size_of::<Params>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            drawn,
            prev,
            counts: storage(
                gpu,
                "pops_counts",
                wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                16,
            ),
            readback: LateReadback::new(gpu, 16),
            slots,
            species,
            last: None,
            bind: None,
            counts_read: PopCounts::default(),
            step: 0.0,
        }
    }

    /// Follows the pool to `slots` trees (it grew): the last frame's state is copied, slot
    /// for slot, into the larger buffers.
    pub fn resize(&mut self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, slots: u32) {
        if slots <= self.slots {
            return;
        }
        let (drawn, prev) = slot_buffers(gpu, slots);
        encoder.copy_buffer_to_buffer(&self.prev, 0, &prev, 0, self.prev.size());
        (self.drawn, self.prev, self.slots) = (drawn, prev, slots);
        self.bind = None;
    }

    /// Records the comparison of this frame's drawn presence with the last frame's, after the
    /// culls. `camera`: this frame's camera frustum and eye; `fade`: the narrowest fade the
    /// presence follows (metres).
    pub fn record(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        pool: &wgpu::Buffer,
        camera: Option<(&Frustum, Vec3)>,
        fade: f32,
    ) {
        let planes = camera.map_or([[0.0; 4]; 6], |(f, _)| f.planes().map(|p| p.to_array()));
        let eye = camera.map_or(Vec3::ZERO, |(_, e)| e);
        let (prev_planes, comparable) = match self.last {
            Some((p, _)) if camera.is_some() => (p, 1),
            _ => ([[0.0; 4]; 6], 0),
        };
        let moved = self.last.map_or(0.0, |(_, e)| e.distance(eye));
        self.step = 1.5 * moved / fade.max(1e-3) + TOLERANCE;
        self.last = camera.map(|_| (planes, eye));
        let params = Params {
            now_planes: planes,
            prev_planes,
            info: [self.slots, comparable, 0, 0],
            step: [self.step, 0.0, 0.0, 0.0],
            species: self.species,
        };
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        if self.bind.as_ref().is_none_or(|b| &b.1 != pool) {
            let bind = crate::technique::common::bind_group(
                gpu,
                "pops_bind",
                &self.layout,
                &[
                    self.params.as_entire_binding(),
                    pool.as_entire_binding(),
                    self.drawn.as_entire_binding(),
                    self.prev.as_entire_binding(),
                    self.counts.as_entire_binding(),
                ],
            );
            self.bind = Some((bind, pool.clone()));
        }
        encoder.clear_buffer(&self.counts, 0, None);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("pops_audit"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.bind.as_ref().expect("made above").0, &[]);
            let groups = self.slots.div_ceil(64);
            pass.dispatch_workgroups(groups.min(65535), groups.div_ceil(65535), 1);
        }
        self.readback.copy(encoder, &self.counts);
    }

    /// After the frame's submission completed: its counts (waiting for them).
    pub fn finish(&mut self, gpu: &Gpu) -> Result<PopCounts, RenderError> {
        if let Some(w) = self.readback.finish(gpu)? {
            self.counts_read = PopCounts {
                appeared: w[0],
                vanished: w[1],
                jumped: w[2],
                largest: w[3] as f32 / 65536.0,
                step: self.step,
            };
        }
        Ok(self.counts_read)
    }
}

/// The per-slot buffers (wgpu zero-initialises them): drawn presence (one word) and the last
/// frame's state (two vec4).
fn slot_buffers(gpu: &Gpu, slots: u32) -> (wgpu::Buffer, wgpu::Buffer) {
    let drawn = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("pops_drawn"),
        size: (slots as u64 * 4).max(256).next_multiple_of(256),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let prev = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("pops_prev"),
        size: (slots as u64 * 32).max(256).next_multiple_of(256),
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    (drawn, prev)
}

#[cfg(test)]
mod tests {
    use super::super::PoolTree;
    use super::*;
    use glam::Mat4;
    use wgpu::util::DeviceExt;

    fn gpu() -> Gpu {
        Gpu::new().unwrap_or_else(|e| panic!("{e}\n{}", sylvan_gpu::INSTALL_HINT))
    }

    fn tree(x: f32) -> PoolTree {
        PoolTree {
            base_scale: [x, 0.0, -20.0, 1.0],
            rot: [1.0, 0.0, 0.5, f32::from_bits(0)],
        }
    }

    /// Four slots: three trees in front of the camera, one far to its side (outside the view).
    /// Each frame writes the slots' drawn presence as the cull would and runs the audit.
    #[test]
    fn the_audit_counts_what_appears_vanishes_or_jumps_inside_the_view_only() {
        let gpu = gpu();
        let mut spheres = [[0.0; 4]; MAX_SPECIES];
        spheres[0] = [0.0, 1.0, 0.0, 1.0];
        let mut trees = vec![tree(0.0), tree(2.0), tree(-2.0), tree(60.0)];
        let pool = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("test_pool"),
                contents: bytemuck::cast_slice(&trees),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            });
        let mut audit = PopAudit::new(&gpu, 4, spheres);
        let frame = |audit: &mut PopAudit, drawn: [f32; 4], eye: Vec3| {
            let words = drawn.map(|p| (p * 65536.0) as u32);
            gpu.queue
                .write_buffer(&audit.drawn, 0, bytemuck::cast_slice(&words));
            let view = Mat4::look_at_rh(eye, eye - Vec3::Z, Vec3::Y);
            let proj = Mat4::perspective_rh(60f32.to_radians(), 1.0, 0.1, 1000.0);
            let frustum = Frustum::from_matrix(proj * view);
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            audit.record(&gpu, &mut encoder, &pool, Some((&frustum, eye)), 20.0);
            gpu.queue.submit([encoder.finish()]);
            gpu.wait().expect("wait");
            let c = audit.finish(&gpu).expect("counts");
            (c.appeared, c.vanished, c.jumped, c.largest)
        };
        let eye = Vec3::new(0.0, 1.0, 0.0);
        // The first frame has nothing to compare with.
        assert_eq!(frame(&mut audit, [1.0, 1.0, 0.0, 1.0], eye), (0, 0, 0, 0.0));
        // Still eye: slot 1 halves (a jump), slot 2 appears, slot 3 vanishes out of view.
        assert_eq!(frame(&mut audit, [1.0, 0.5, 1.0, 0.0], eye), (1, 0, 1, 1.0));
        // Slot 0 now holds another tree (its tile evicted, another inserted): the old one
        // vanished and the new one appeared.
        trees[0] = tree(0.5);
        gpu.queue
            .write_buffer(&pool, 0, bytemuck::cast_slice(&trees[..1]));
        assert_eq!(frame(&mut audit, [1.0, 0.5, 1.0, 0.0], eye), (1, 1, 0, 1.0));
        // The eye moved 10 m: a fade 20 m wide may change a presence by 1.5 × 10 / 20 = 0.75
        // in one frame, so slot 1's 0.5 → 1 is no pop; slot 2's 1 → 0 is.
        let back = eye + Vec3::Z * 10.0;
        assert_eq!(
            frame(&mut audit, [1.0, 1.0, 0.0, 0.0], back),
            (0, 1, 0, 1.0)
        );
        // Unchanged: nothing.
        assert_eq!(
            frame(&mut audit, [1.0, 1.0, 0.0, 0.0], back),
            (0, 0, 0, 0.0)
        );
    }
}
