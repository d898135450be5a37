//! One place that turns "this shader, these buffers, this pass" into a render pipeline, so each
//! technique states only what differs.

use sylvan_gpu::{DEPTH_FORMAT, Gpu};

/// HDR colour format of the main pass (linear radiance, tone-mapped in the resolve).
pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// Which way depth runs in the main pass's depth buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DepthConvention {
    /// 1 at the near plane, 0 at the far plane (or infinitely far); compare `GreaterEqual`.
    /// Sylvan's own and Bevy's.
    Reversed,
    /// 0 at the near plane, 1 at the far plane; compare `LessEqual`.
    Standard,
}

/// What the main pass's fragment shaders write to the colour attachment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColorOutput {
    /// Scene-referred linear radiance, exposure not applied: Sylvan's own HDR target, which
    /// its resolve exposes and tone-maps.
    Radiance,
    /// Linear radiance × exposure, for a caller's HDR target that the caller tone-maps.
    Exposed,
    /// Exposure and Sylvan's tone curve (ACES fit, as its resolve) applied per fragment, for
    /// an LDR target (`Rgba8UnormSrgb`, `Bgra8UnormSrgb`, …). Blending happens after the curve,
    /// so translucent edges differ slightly from Sylvan's own resolve.
    ToneMapped,
}

impl ColorOutput {
    /// The code `frame.wgsl` reads (`Frame::main_target.x`).
    pub(crate) fn code(self) -> f32 {
        match self {
            ColorOutput::Radiance => 0.0,
            ColorOutput::Exposed => 1.0,
            ColorOutput::ToneMapped => 2.0,
        }
    }
}

/// The attachments the main pass draws into: Sylvan's own offscreen target, or a caller's
/// (the embedding API). Every main-pass pipeline is built for it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MainTarget {
    /// Colour attachment format.
    pub color_format: wgpu::TextureFormat,
    /// Depth attachment format (a depth format with a 32- or 24-bit depth aspect).
    pub depth_format: wgpu::TextureFormat,
    /// Multisample count of both attachments (1, or 4 as Bevy's default).
    pub sample_count: u32,
    /// Depth direction of the caller's projection.
    pub depth: DepthConvention,
    /// What the shaders write.
    pub output: ColorOutput,
}

impl MainTarget {
    /// Sylvan's own main target: HDR radiance, reversed-Z `Depth32Float`, one sample.
    pub const OWN: MainTarget = MainTarget {
        color_format: HDR_FORMAT,
        depth_format: DEPTH_FORMAT,
        sample_count: 1,
        depth: DepthConvention::Reversed,
        output: ColorOutput::Radiance,
    };

    /// The depth comparison of main-pass pipelines.
    pub fn compare(&self) -> wgpu::CompareFunction {
        match self.depth {
            DepthConvention::Reversed => wgpu::CompareFunction::GreaterEqual,
            DepthConvention::Standard => wgpu::CompareFunction::LessEqual,
        }
    }

    /// The depth value of the far plane (what a depth buffer is cleared to).
    pub fn far_depth(&self) -> f32 {
        match self.depth {
            DepthConvention::Reversed => 0.0,
            DepthConvention::Standard => 1.0,
        }
    }

    /// Checks the target against what Sylvan's shaders and the device can draw into.
    pub fn check(&self, gpu: &Gpu) -> Result<(), crate::RenderError> {
        let bad = |why: String| Err(crate::RenderError::Option(why));
        let f = self.color_format;
        if f.is_depth_stencil_format() || f.is_compressed() {
            return bad(format!(
                "main target colour format {f:?} is not a colour render format — use an RGBA/BGRA 8-bit or 16-bit float format"
            ));
        }
        if !matches!(
            f.sample_type(None, None),
            Some(wgpu::TextureSampleType::Float { .. })
        ) {
            return bad(format!(
                "main target colour format {f:?} is an integer format; Sylvan's shaders write floats — use Rgba16Float or an sRGB 8-bit format"
            ));
        }
        if !self.depth_format.has_depth_aspect() {
            return bad(format!(
                "main target depth format {:?} has no depth — use Depth32Float",
                self.depth_format
            ));
        }
        for format in [f, self.depth_format] {
            let flags = gpu.adapter.get_texture_format_features(format).flags;
            if !flags.sample_count_supported(self.sample_count) {
                return bad(format!(
                    "main target {format:?} with {} samples is not supported by '{}' — use 1 or 4 samples",
                    self.sample_count, gpu.info.name
                ));
            }
        }
        Ok(())
    }
}

/// Which pass a pipeline draws in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PassKind {
    /// The main view, into the renderer's [`MainTarget`] (Sylvan's own: HDR colour and
    /// reversed-Z depth).
    Main,
    /// A shadow cascade, an opaque caster: depth, standard Z (compare LessEqual), with
    /// slope-scaled bias; the translucent layer (`frame::SHADOW_TRANSLUCENT_FORMAT`) is
    /// attached but not written.
    Shadow,
    /// A shadow cascade, a translucent caster (BN12 §5's soft shadows): depth-tested against
    /// the opaque casters, not written; the fragment entry returns `TranslucentFragment`
    /// (`frame.wgsl`): its optical depth σ, σz and 1 (blended `Add`) and its depth (alpha,
    /// blended `Min`), so overlapping crowns accumulate in any order.
    ShadowTranslucent,
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
    /// Fragment entry point (`None`: depth only — in a shadow pass, an opaque caster).
    pub fs: Option<&'a str>,
    /// Vertex buffers.
    pub buffers: &'a [Option<wgpu::VertexBufferLayout<'a>>],
    /// Pass kind.
    pub pass: PassKind,
    /// The frame the pipeline draws in: the main pass's attachments (`FrameResources::target`)
    /// and whether the shadow passes have the translucent layer.
    pub frame: &'a crate::frame::FrameResources,
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
    let target = &spec.frame.target;
    let (compare, bias) = match spec.pass {
        PassKind::Main => (target.compare(), wgpu::DepthBiasState::default()),
        PassKind::Shadow | PassKind::ShadowTranslucent => (
            wgpu::CompareFunction::LessEqual,
            wgpu::DepthBiasState {
                constant: 2,
                slope_scale: 2.0,
                clamp: 0.0,
            },
        ),
    };
    let written = |format, blend, write_mask| {
        Some(wgpu::ColorTargetState {
            format,
            blend,
            write_mask,
        })
    };
    // The translucent layer: Σσ, Σσz, n summed, the nearest depth kept.
    let component = |operation| wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation,
    };
    let accumulate = wgpu::BlendState {
        color: component(wgpu::BlendOperation::Add),
        alpha: component(wgpu::BlendOperation::Min),
    };
    let layer = crate::frame::SHADOW_TRANSLUCENT_FORMAT;
    let translucent = spec.frame.translucent();
    let targets: Vec<Option<wgpu::ColorTargetState>> = match spec.pass {
        PassKind::Main => vec![written(
            target.color_format,
            spec.blend,
            wgpu::ColorWrites::ALL,
        )],
        // Opaque casters leave the translucent layer alone (the depth test keeps them).
        PassKind::Shadow if translucent => vec![written(layer, None, wgpu::ColorWrites::empty())],
        PassKind::Shadow => Vec::new(),
        PassKind::ShadowTranslucent => {
            assert!(
                translucent && spec.fs.is_some(),
                "a translucent caster needs the frame's translucent layer and a fragment entry"
            );
            vec![written(layer, Some(accumulate), wgpu::ColorWrites::ALL)]
        }
    };
    // A shadow pass with the translucent layer has a colour attachment, so every caster has a
    // fragment stage: depth-only casters get `fs_shadow_opaque` (frame.wgsl), which writes
    // nothing but depth. Without it they stay depth only.
    let fs = match spec.pass {
        PassKind::Shadow if translucent => Some(spec.fs.unwrap_or("fs_shadow_opaque")),
        _ => spec.fs,
    };
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
            fragment: fs.map(|fs| wgpu::FragmentState {
                module: spec.module,
                entry_point: Some(fs),
                compilation_options: Default::default(),
                targets: &targets,
            }),
            primitive: wgpu::PrimitiveState {
                cull_mode: spec.cull,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: match spec.pass {
                    PassKind::Main => target.depth_format,
                    PassKind::Shadow | PassKind::ShadowTranslucent => DEPTH_FORMAT,
                },
                depth_write_enabled: Some(
                    spec.depth_write && spec.pass != PassKind::ShadowTranslucent,
                ),
                depth_compare: Some(compare),
                stencil: Default::default(),
                bias,
            }),
            multisample: wgpu::MultisampleState {
                count: match spec.pass {
                    PassKind::Main => target.sample_count,
                    PassKind::Shadow | PassKind::ShadowTranslucent => 1,
                },
                ..Default::default()
            },
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
