//! Resolving a supersampled HDR render (`factor × factor` samples per pixel, box filter) into a
//! tone-mapped sRGB image. `--spp N` renders at `√N` times the size in each direction.

use crate::{Gpu, GpuError, RenderTarget};
use bytemuck::{Pod, Zeroable};

/// The resolve shader source (exported so tests can validate it without a GPU).
pub const RESOLVE_WGSL: &str = include_str!("resolve.wgsl");

/// Colour format of the resolved, displayable image.
pub const OUTPUT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuResolveParams {
    factor: u32,
    exposure: f32,
    _pad: [f32; 2],
}

/// The resolve pass: pipeline and uniform buffer created once.
pub struct Resolver {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
}

impl Resolver {
    /// Creates the pipeline.
    pub fn new(gpu: &Gpu) -> Self {
        let module = crate::shader(gpu, "resolve", RESOLVE_WGSL);
        let layout = gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("resolve_layout"),
                entries: &[
                    crate::layout::texture(
                        0,
                        wgpu::ShaderStages::FRAGMENT,
                        wgpu::TextureSampleType::Float { filterable: false },
                        wgpu::TextureViewDimension::D2,
                    ),
                    crate::layout::uniform(1, wgpu::ShaderStages::FRAGMENT),
                ],
            });
        let pipeline_layout = gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("resolve_pipeline_layout"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        let pipeline = gpu
            .device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("resolve_pipeline"),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[Some(OUTPUT_FORMAT.into())],
                }),
                primitive: Default::default(),
                depth_stencil: None,
                multisample: Default::default(),
                multiview_mask: None,
                cache: None,
            });
        let params = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("resolve_params"),
            size: std::mem::size_of::<GpuResolveParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            pipeline,
            layout,
            params,
        }
    }

    /// Binds `src` as a resolve source. Make it once per target, not per frame.
    pub fn bind_source(&self, gpu: &Gpu, src: &RenderTarget) -> wgpu::BindGroup {
        gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("resolve_bind"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&src.color_view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: self.params.as_entire_binding(),
                },
            ],
        })
    }

    /// Records the resolve of the source bound in `source` (`factor`× the output size) into
    /// `dst`, an [`OUTPUT_FORMAT`] target.
    pub fn encode(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        source: &wgpu::BindGroup,
        dst: &RenderTarget,
        factor: u32,
        exposure: f32,
    ) -> Result<(), GpuError> {
        if dst.format != OUTPUT_FORMAT || factor == 0 {
            return Err(GpuError::Wgpu(format!(
                "resolve: target must be {OUTPUT_FORMAT:?} and factor ≥ 1"
            )));
        }
        let raw = GpuResolveParams {
            factor,
            exposure,
            _pad: [0.0; 2],
        };
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&raw));
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("resolve_pass"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &dst.color_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, source, &[]);
        pass.draw(0..3, 0..1);
        Ok(())
    }
}
