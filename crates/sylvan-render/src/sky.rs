//! The sky background (`shaders/sky.wgsl`), drawn first behind everything.

use crate::frame::FrameResources;
use crate::pipeline::{self, PassKind, PipelineSpec};
use sylvan_gpu::Gpu;

/// The sky pipeline.
pub struct SkyPass {
    pipeline: wgpu::RenderPipeline,
}

impl SkyPass {
    /// Creates the pipeline.
    pub fn new(gpu: &Gpu, frame: &FrameResources) -> Self {
        let module = sylvan_gpu::shader(
            gpu,
            "sky",
            &pipeline::with_frame(include_str!("shaders/sky.wgsl")),
        );
        let pipeline = pipeline::build(
            gpu,
            &PipelineSpec {
                label: "sky_pipeline",
                layouts: &[&frame.main_layout],
                module: &module,
                vs: "vs_sky",
                fs: Some("fs_sky"),
                buffers: &[],
                pass: PassKind::Main,
                frame,
                cull: None,
                depth_write: false,
                blend: None,
            },
        );
        Self { pipeline }
    }

    /// Records the sky; returns draw calls.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) -> u32 {
        pass.set_pipeline(&self.pipeline);
        pass.draw(0..3, 0..1);
        1
    }
}
