//! One place that turns "this shader, these buffers, this pass" into a render pipeline, so each
//! technique states only what differs.

use sylvan_gpu::{DEPTH_FORMAT, Gpu};

/// HDR colour format of the main pass (linear radiance, tone-mapped in the resolve).
pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// Which pass a pipeline draws in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PassKind {
    /// The main view: HDR colour + reversed-Z depth (compare Greater).
    Main,
    /// A shadow cascade: depth only, standard Z (compare Less), with slope-scaled bias.
    Shadow,
}

/// What differs between Sylvan's render pipelines.
pub struct PipelineSpec<'a> {
    /// Debug label.
    pub label: &'a str,
    /// Bind group layouts, group 0 first.
    pub layouts: &'a [&'a wgpu::BindGroupLayout],
    /// Shader module holding both entry points.
    pub module: &'a wgpu::ShaderModule,
    /// Vertex entry point.
    pub vs: &'a str,
    /// Fragment entry point (`None`: depth only).
    pub fs: Option<&'a str>,
    /// Vertex buffers.
    pub buffers: &'a [Option<wgpu::VertexBufferLayout<'a>>],
    /// Pass kind.
    pub pass: PassKind,
    /// Face culling (`None`: two-sided).
    pub cull: Option<wgpu::Face>,
    /// Whether the pipeline writes depth.
    pub depth_write: bool,
    /// Colour blending in the main pass (`None`: replace).
    pub blend: Option<wgpu::BlendState>,
}

/// Builds the pipeline described by `spec`.
pub fn build(gpu: &Gpu, spec: &PipelineSpec) -> wgpu::RenderPipeline {
    let layouts: Vec<Option<&wgpu::BindGroupLayout>> =
        spec.layouts.iter().map(|l| Some(*l)).collect();
    let layout = gpu
        .device
        .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(spec.label),
            bind_group_layouts: &layouts,
            immediate_size: 0,
        });
    let (compare, bias) = match spec.pass {
        PassKind::Main => (
            wgpu::CompareFunction::GreaterEqual,
            wgpu::DepthBiasState::default(),
        ),
        PassKind::Shadow => (
            wgpu::CompareFunction::LessEqual,
            wgpu::DepthBiasState {
                constant: 2,
                slope_scale: 2.0,
                clamp: 0.0,
            },
        ),
    };
    let targets = [Some(wgpu::ColorTargetState {
        format: HDR_FORMAT,
        blend: spec.blend,
        write_mask: wgpu::ColorWrites::ALL,
    })];
    gpu.device
        .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(spec.label),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: spec.module,
                entry_point: Some(spec.vs),
                compilation_options: Default::default(),
                buffers: spec.buffers,
            },
            fragment: spec.fs.map(|fs| wgpu::FragmentState {
                module: spec.module,
                entry_point: Some(fs),
                compilation_options: Default::default(),
                targets: if spec.pass == PassKind::Main {
                    &targets
                } else {
                    &[]
                },
            }),
            primitive: wgpu::PrimitiveState {
                cull_mode: spec.cull,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(spec.depth_write),
                depth_compare: Some(compare),
                stencil: Default::default(),
                bias,
            }),
            multisample: Default::default(),
            multiview_mask: None,
            cache: None,
        })
}

/// Concatenates the registry's technique ids, the shared frame bindings and a shader's own
/// source.
pub fn with_frame(source: &str) -> String {
    format!(
        "{}\n{}\n{}",
        crate::technique::registry::wgsl_prelude(),
        include_str!("shaders/frame.wgsl"),
        source
    )
}

/// Every WGSL module the renderer builds, as compiled (frame bindings prepended), by label.
/// Tests parse and validate each with naga, without a GPU.
pub fn shader_sources() -> Vec<(&'static str, String)> {
    let mut out = vec![
        ("sky", with_frame(include_str!("shaders/sky.wgsl"))),
        ("terrain", with_frame(include_str!("shaders/terrain.wgsl"))),
        ("bake", crate::bake::shader_source()),
    ];
    for e in crate::technique::registry::REGISTRY {
        out.extend((e.shaders)());
    }
    out
}
