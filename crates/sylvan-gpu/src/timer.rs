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

/// Most marks a [`FrameTimer`] records between its start and end in one frame.
pub const MAX_MARKS: usize = 12;

/// Timestamps a [`FrameTimer`] holds: start, the marks, end.
const SLOTS: usize = MAX_MARKS + 2;

/// Measures the GPU time of one encoder's work, and optionally its parts: [`FrameTimer::mark`]
/// between passes splits the frame (the split is empty with the wall clock). Create once,
/// reuse every frame.
pub struct FrameTimer {
    kind: TimerKind,
    queries: Option<(wgpu::QuerySet, wgpu::Buffer, wgpu::Buffer)>,
    period_ns: f64,
    started: Option<Instant>,
    /// Labels of the marks of the frame being recorded (or last ended), in order.
    marks: Vec<&'static str>,
    /// Between begin and end: marks are taken.
    open: bool,
    split: Vec<(&'static str, f64)>,
}

impl FrameTimer {
    /// A timer on `gpu`: GPU timestamps when available, unless `force_wall`.
    pub fn new(gpu: &Gpu, force_wall: bool) -> Self {
        let queries = (gpu.timestamps && !force_wall).then(|| {
            let set = gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("frame_timer"),
                ty: wgpu::QueryType::Timestamp,
                count: SLOTS as u32,
            });
            let bytes = (SLOTS * 8) as u64;
            let resolve = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("frame_timer_resolve"),
                size: bytes,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let read = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("frame_timer_read"),
                size: bytes,
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
            marks: Vec::with_capacity(MAX_MARKS),
            open: false,
            split: Vec::with_capacity(MAX_MARKS),
        }
    }

    /// Which clock this timer uses.
    pub fn kind(&self) -> TimerKind {
        self.kind
    }

    /// Marks the start of the timed work (call first in the encoder).
    pub fn begin(&mut self, encoder: &mut wgpu::CommandEncoder) {
        self.started = Some(Instant::now());
        self.marks.clear();
        self.open = true;
        if let Some((set, _, _)) = &self.queries {
            encoder.write_timestamp(set, 0);
        }
    }

    /// Ends the part of the frame called `label` (it began at [`FrameTimer::begin`] or at the
    /// previous mark); call between passes. Does nothing outside begin … end, with the wall
    /// clock, or past [`MAX_MARKS`] marks.
    pub fn mark(&mut self, encoder: &mut wgpu::CommandEncoder, label: &'static str) {
        let Some((set, _, _)) = &self.queries else {
            return;
        };
        if self.open && self.marks.len() < MAX_MARKS {
            self.marks.push(label);
            encoder.write_timestamp(set, self.marks.len() as u32);
        }
    }

    /// Marks the end of the timed work (call last in the encoder).
    pub fn end(&mut self, encoder: &mut wgpu::CommandEncoder) {
        self.open = false;
        if let Some((set, resolve, read)) = &self.queries {
            let n = self.marks.len() as u32 + 2;
            encoder.write_timestamp(set, n - 1);
            encoder.resolve_query_set(set, 0..n, resolve, 0);
            encoder.copy_buffer_to_buffer(resolve, 0, read, 0, n as u64 * 8);
        }
    }

    /// The parts of the frame last read by [`FrameTimer::read_ms`]: each mark's label and the
    /// milliseconds from the previous mark (or the start) to it. Empty with the wall clock or
    /// without marks; the time from the last mark to the end is not in it.
    pub fn split_ms(&self) -> &[(&'static str, f64)] {
        &self.split
    }

    /// After the encoder was submitted: waits for the GPU and returns the elapsed milliseconds.
    pub fn read_ms(&mut self, gpu: &Gpu) -> Result<f64, GpuError> {
        self.split.clear();
        let Some((_, _, read)) = &self.queries else {
            gpu.wait()?;
            let start = self.started.take().unwrap_or_else(Instant::now);
            return Ok(start.elapsed().as_secs_f64() * 1e3);
        };
        let n = self.marks.len() + 2;
        let slice = read.slice(..n as u64 * 8);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        gpu.wait()?;
        let mut ticks = [0u64; SLOTS];
        {
            let data = slice
                .get_mapped_range()
                .map_err(|e| GpuError::Wgpu(e.to_string()))?;
            for (t, c) in ticks.iter_mut().zip(data.chunks_exact(8)) {
                *t = u64::from_le_bytes(c.try_into().unwrap_or_default());
            }
        }
        read.unmap();
        let ms = |a: u64, b: u64| b.saturating_sub(a) as f64 * self.period_ns / 1e6;
        self.split.extend(
            self.marks
                .iter()
                .enumerate()
                .map(|(i, &label)| (label, ms(ticks[i], ticks[i + 1]))),
        );
        Ok(ms(ticks[0], ticks[n - 1]))
    }
}
