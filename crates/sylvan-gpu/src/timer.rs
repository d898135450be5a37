//! Frame timing: GPU timestamp queries where the adapter has them, wall clock otherwise.

use crate::{Gpu, GpuError};
use std::time::Instant;

/// How a [`FrameTimer`] measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimerKind {
    /// GPU timestamps written at the start and end of the frame's command encoder.
    Gpu,
    /// Wall-clock time from submit to completion.
    Wall,
}

impl TimerKind {
    /// `"gpu"` or `"wall"` (the `timer` field of `bench --json`).
    pub fn as_str(self) -> &'static str {
        match self {
            TimerKind::Gpu => "gpu",
            TimerKind::Wall => "wall",
        }
    }
}

/// Measures the GPU time of one encoder's work. Create once, reuse every frame.
pub struct FrameTimer {
    kind: TimerKind,
    queries: Option<(wgpu::QuerySet, wgpu::Buffer, wgpu::Buffer)>,
    period_ns: f64,
    started: Option<Instant>,
}

impl FrameTimer {
    /// A timer on `gpu`: GPU timestamps when available, unless `force_wall`.
    pub fn new(gpu: &Gpu, force_wall: bool) -> Self {
        let queries = (gpu.timestamps && !force_wall).then(|| {
            let set = gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("frame_timer"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            });
            let resolve = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("frame_timer_resolve"),
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let read = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("frame_timer_read"),
                size: 16,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            });
            (set, resolve, read)
        });
        let kind = if queries.is_some() {
            TimerKind::Gpu
        } else {
            TimerKind::Wall
        };
        Self {
            kind,
            queries,
            period_ns: gpu.queue.get_timestamp_period() as f64,
            started: None,
        }
    }

    /// Which clock this timer uses.
    pub fn kind(&self) -> TimerKind {
        self.kind
    }

    /// Marks the start of the timed work (call first in the encoder).
    pub fn begin(&mut self, encoder: &mut wgpu::CommandEncoder) {
        self.started = Some(Instant::now());
        if let Some((set, _, _)) = &self.queries {
            encoder.write_timestamp(set, 0);
        }
    }

    /// Marks the end of the timed work (call last in the encoder).
    pub fn end(&mut self, encoder: &mut wgpu::CommandEncoder) {
        if let Some((set, resolve, read)) = &self.queries {
            encoder.write_timestamp(set, 1);
            encoder.resolve_query_set(set, 0..2, resolve, 0);
            encoder.copy_buffer_to_buffer(resolve, 0, read, 0, 16);
        }
    }

    /// After the encoder was submitted: waits for the GPU and returns the elapsed milliseconds.
    pub fn read_ms(&mut self, gpu: &Gpu) -> Result<f64, GpuError> {
        let Some((_, _, read)) = &self.queries else {
            gpu.wait()?;
            let start = self.started.take().unwrap_or_else(Instant::now);
            return Ok(start.elapsed().as_secs_f64() * 1e3);
        };
        let slice = read.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        gpu.wait()?;
        let ticks: [u64; 2] = {
            let data = slice
                .get_mapped_range()
                .map_err(|e| GpuError::Wgpu(e.to_string()))?;
            let mut t = [0u64; 2];
            t[0] = u64::from_le_bytes(data[0..8].try_into().unwrap_or_default());
            t[1] = u64::from_le_bytes(data[8..16].try_into().unwrap_or_default());
            t
        };
        read.unmap();
        Ok(ticks[1].saturating_sub(ticks[0]) as f64 * self.period_ns / 1e6)
    }
}
