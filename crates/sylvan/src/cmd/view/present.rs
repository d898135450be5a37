//! From the renderer's output to the window: the window surface (sRGB, vsync on or off), a
//! window-sized *composite* image (`OUTPUT_FORMAT`) that holds the scene with the panel on top
//! (and is what screenshots read back), and a tiny blit shader between them.
//!
//! Per frame: blit the renderer's output (any size: the render scale) into the composite, draw
//! egui onto the composite, then copy (same format) or blit (other format) the composite onto the
//! surface texture. Every texture, bind group and pipeline is made at start, on resize, or when
//! the renderer is rebuilt — never in the frame loop; `allocations` counts those events.

use anyhow::{Result, anyhow};
use sylvan_gpu::{Gpu, OUTPUT_FORMAT, layout};

/// The blit shader source.
pub const BLIT_WGSL: &str = include_str!("blit.wgsl");

/// The window surface, the composite image and the blits between them.
pub struct Presenter {
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    /// Format of the views drawn into on the surface (the sRGB form of the surface format).
    surface_view_format: wgpu::TextureFormat,
    /// Copy the composite onto the surface (same format, COPY_DST allowed) instead of a blit.
    copy_to_surface: bool,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    to_composite: wgpu::RenderPipeline,
    to_surface: wgpu::RenderPipeline,
    composite: wgpu::Texture,
    composite_view: wgpu::TextureView,
    composite_bind: wgpu::BindGroup,
    scene_bind: Option<wgpu::BindGroup>,
    /// GPU objects created by the presenter since start (textures, bind groups, surface
    /// configurations): constant while nothing changes.
    pub allocations: u64,
}

impl Presenter {
    /// Configures `surface` for a `width × height` window and builds the blits.
    pub fn new(
        gpu: &Gpu,
        surface: wgpu::Surface<'static>,
        width: u32,
        height: u32,
        vsync: bool,
    ) -> Result<Self> {
        let caps = surface.get_capabilities(&gpu.adapter);
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| f.is_srgb())
            .or_else(|| caps.formats.first().copied())
            .ok_or_else(|| {
                anyhow!(
                    "the window surface offers no colour format on '{}' — try another backend with WGPU_BACKEND=vulkan|gl",
                    gpu.info.name
                )
            })?;
        let surface_view_format = format.add_srgb_suffix();
        let copy_to_surface =
            format == OUTPUT_FORMAT && caps.usages.contains(wgpu::TextureUsages::COPY_DST);
        let mut usage = wgpu::TextureUsages::RENDER_ATTACHMENT;
        if copy_to_surface {
            usage |= wgpu::TextureUsages::COPY_DST;
        }
        let config = wgpu::SurfaceConfiguration {
            usage,
            format,
            width: width.max(1),
            height: height.max(1),
            present_mode: present_mode(vsync),
            desired_maximum_frame_latency: 2,
            color_space: wgpu::SurfaceColorSpace::Auto,
            alpha_mode: caps
                .alpha_modes
                .first()
                .copied()
                .unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: if surface_view_format == format {
                vec![]
            } else {
                vec![surface_view_format]
            },
        };
        surface.configure(&gpu.device, &config);

        let device = &gpu.device;
        let module = sylvan_gpu::shader(gpu, "blit", BLIT_WGSL);
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("blit_layout"),
            entries: &[
                layout::texture(
                    0,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::TextureSampleType::Float { filterable: true },
                    wgpu::TextureViewDimension::D2,
                ),
                layout::sampler(
                    1,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::SamplerBindingType::Filtering,
                ),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("blit_pipeline_layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |label: &str, target: wgpu::TextureFormat| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_blit"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_blit"),
                    compilation_options: Default::default(),
                    targets: &[Some(target.into())],
                }),
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                multiview_mask: None,
                cache: None,
            })
        };
        let to_composite = pipeline("blit_to_composite", OUTPUT_FORMAT);
        let to_surface = pipeline("blit_to_surface", surface_view_format);
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("blit_sampler"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let (composite, composite_view, composite_bind) =
            make_composite(gpu, &layout, &sampler, config.width, config.height)?;
        Ok(Self {
            surface,
            config,
            surface_view_format,
            copy_to_surface,
            layout,
            sampler,
            to_composite,
            to_surface,
            composite,
            composite_view,
            composite_bind,
            scene_bind: None,
            allocations: 1,
        })
    }

    /// The window size in physical pixels (the composite's size).
    pub fn size(&self) -> (u32, u32) {
        (self.config.width, self.config.height)
    }

    /// The surface's colour format (for the stats line).
    pub fn surface_format(&self) -> wgpu::TextureFormat {
        self.config.format
    }

    /// The composite image: the scene with the panel, as last presented (screenshots read it).
    pub fn composite(&self) -> &wgpu::Texture {
        &self.composite
    }

    /// The composite's view (egui draws into it).
    pub fn composite_view(&self) -> &wgpu::TextureView {
        &self.composite_view
    }

    /// Re-configures the surface and re-creates the composite for a new window size.
    pub fn resize(&mut self, gpu: &Gpu, width: u32, height: u32) -> Result<()> {
        let (width, height) = (width.max(1), height.max(1));
        if (width, height) == self.size() {
            return Ok(());
        }
        self.config.width = width;
        self.config.height = height;
        self.surface.configure(&gpu.device, &self.config);
        let (t, v, b) = make_composite(gpu, &self.layout, &self.sampler, width, height)?;
        self.composite = t;
        self.composite_view = v;
        self.composite_bind = b;
        self.allocations += 1;
        Ok(())
    }

    /// Vsync on (`Fifo`-like) or off (`Immediate`/`Mailbox` where offered).
    pub fn set_vsync(&mut self, gpu: &Gpu, vsync: bool) {
        let mode = present_mode(vsync);
        if mode != self.config.present_mode {
            self.config.present_mode = mode;
            self.surface.configure(&gpu.device, &self.config);
            self.allocations += 1;
        }
    }

    /// Re-configures the surface as it is (after `Outdated`/`Lost`).
    pub fn reconfigure(&mut self, gpu: &Gpu) {
        self.surface.configure(&gpu.device, &self.config);
        self.allocations += 1;
    }

    /// Points the scene blit at the renderer's output (after the renderer was rebuilt or resized).
    pub fn bind_scene(&mut self, gpu: &Gpu, output: &wgpu::TextureView) {
        self.scene_bind = Some(bind(gpu, &self.layout, &self.sampler, output, "blit_scene"));
        self.allocations += 1;
    }

    /// Records the blit of the renderer's output into the composite (cleared first).
    pub fn encode_scene(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = begin(encoder, &self.composite_view, "composite_scene_pass");
        if let Some(b) = &self.scene_bind {
            pass.set_pipeline(&self.to_composite);
            pass.set_bind_group(0, b, &[]);
            pass.draw(0..3, 0..1);
        }
    }

    /// Acquires the next surface texture; `None` when this frame cannot be shown (skip it).
    pub fn acquire(&mut self, gpu: &Gpu) -> Option<wgpu::SurfaceTexture> {
        match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) => Some(t),
            wgpu::CurrentSurfaceTexture::Suboptimal(t) => {
                // Shown this time; configured afresh for the next frame.
                self.reconfigure(gpu);
                Some(t)
            }
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.reconfigure(gpu);
                None
            }
            _ => None,
        }
    }

    /// Records the composite → surface copy or blit.
    pub fn encode_present(&self, encoder: &mut wgpu::CommandEncoder, frame: &wgpu::SurfaceTexture) {
        let size = frame.texture.size();
        if self.copy_to_surface && (size.width, size.height) == self.size() {
            encoder.copy_texture_to_texture(
                self.composite.as_image_copy(),
                frame.texture.as_image_copy(),
                size,
            );
            return;
        }
        let view = frame.texture.create_view(&wgpu::TextureViewDescriptor {
            format: Some(self.surface_view_format),
            ..Default::default()
        });
        let mut pass = begin(encoder, &view, "surface_pass");
        pass.set_pipeline(&self.to_surface);
        pass.set_bind_group(0, &self.composite_bind, &[]);
        pass.draw(0..3, 0..1);
    }
}

fn present_mode(vsync: bool) -> wgpu::PresentMode {
    if vsync {
        wgpu::PresentMode::AutoVsync
    } else {
        wgpu::PresentMode::AutoNoVsync
    }
}

fn begin<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    view: &wgpu::TextureView,
    label: &str,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view,
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
    })
}

fn bind(
    gpu: &Gpu,
    layout: &wgpu::BindGroupLayout,
    sampler: &wgpu::Sampler,
    view: &wgpu::TextureView,
    label: &str,
) -> wgpu::BindGroup {
    gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(view),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::Sampler(sampler),
            },
        ],
    })
}

fn make_composite(
    gpu: &Gpu,
    layout: &wgpu::BindGroupLayout,
    sampler: &wgpu::Sampler,
    width: u32,
    height: u32,
) -> Result<(wgpu::Texture, wgpu::TextureView, wgpu::BindGroup)> {
    gpu.check_texture_size("window", width, height)?;
    let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("composite"),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: OUTPUT_FORMAT,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let view = texture.create_view(&Default::default());
    let bind = bind(gpu, layout, sampler, &view, "blit_composite");
    Ok((texture, view, bind))
}
