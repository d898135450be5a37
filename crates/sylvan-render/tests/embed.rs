//! The embedding API: Sylvan drawing into a caller's device, encoder, render pass and
//! attachments (their formats, sample count and depth convention) with the caller's view and
//! projection matrices.
//!
//! - An embedded frame into an LDR target matches Sylvan's own render of the same view.
//! - Standard depth with 4× MSAA matches reversed depth with one sample.
//! - The caller's own geometry and Sylvan's trees hide each other by depth.
//! - A target Sylvan cannot draw into is refused with a one-line reason.
//!
//! The "caller" here opens its own device (wgpu, adapter limits, no timestamps) and hands it
//! to Sylvan with `Gpu::from_parts`, as a wgpu program or Bevy does.

mod common;

use glam::{Mat4, Vec3};
use sylvan_gpu::Gpu;
use sylvan_render::frame::View;
use sylvan_render::{
    CameraMatrices, ColorOutput, DepthConvention, Layers, MainTarget, RenderOptions, Renderer,
};
use sylvan_scene::{Camera, Scene, TreeInstance};

const W: u32 = 160;
const H: u32 = 120;
const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// A device opened the way a plain wgpu program opens one.
fn caller_gpu() -> Gpu {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        force_fallback_adapter: false,
        compatible_surface: None,
        apply_limit_buckets: false,
    }))
    .unwrap_or_else(|e| {
        panic!(
            "this test needs a GPU adapter ({e}) — {}",
            sylvan_gpu::INSTALL_HINT
        )
    });
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("caller"),
        required_features: wgpu::Features::empty(),
        required_limits: adapter.limits(),
        experimental_features: wgpu::ExperimentalFeatures::disabled(),
        memory_hints: wgpu::MemoryHints::Performance,
        trace: wgpu::Trace::Off,
    }))
    .expect("device");
    Gpu::from_parts(instance, adapter, device, queue)
}

fn grove() -> Scene {
    let trees = (0..3)
        .map(|i| TreeInstance {
            position: Vec3::new(50.0 + 9.0 * i as f32, 0.0, 60.0 + 5.0 * (i % 2) as f32),
            species: 0,
            seed: 0,
            height: 10.0,
            rotation: i as f32 * 1.7,
        })
        .collect();
    let camera = Camera {
        position: Vec3::new(60.0, 8.0, 32.0),
        look_at: Vec3::new(58.0, 6.0, 62.0),
        fov_deg: 45.0,
    };
    common::scene(
        common::terrain(120.0, 17, |x, z| 0.02 * (x + z)),
        trees,
        camera,
        common::sun(150.0, 40.0),
    )
}

fn options(technique: &str) -> RenderOptions {
    RenderOptions {
        width: W,
        height: H,
        technique: technique.into(),
        ..Default::default()
    }
}

/// The view Sylvan's own renderer uses for `camera` (reversed Z, finite far plane).
fn own_view(renderer: &Renderer, camera: &Camera) -> View {
    let mut v = renderer.view(camera);
    v.aspect = W as f32 / H as f32;
    v
}

/// A caller's frame: its attachments, its own wall pipeline, and what it drew.
struct Host {
    color: wgpu::Texture,
    msaa: Option<wgpu::Texture>,
    depth: wgpu::Texture,
    target: MainTarget,
    walls: wgpu::RenderPipeline,
    uniforms: wgpu::Buffer,
    bind: wgpu::BindGroup,
}

const WALL_WGSL: &str = r#"
@group(0) @binding(0) var<uniform> view_proj: mat4x4<f32>;
struct Out { @builtin(position) pos: vec4<f32>, @location(0) color: vec3<f32> };
@vertex fn vs(@location(0) p: vec3<f32>, @location(1) c: vec3<f32>) -> Out {
    return Out(view_proj * vec4<f32>(p, 1.0), c);
}
@fragment fn fs(in: Out) -> @location(0) vec4<f32> { return vec4<f32>(in.color, 1.0); }
"#;

impl Host {
    fn new(gpu: &Gpu, samples: u32, depth: DepthConvention) -> Self {
        let tex = |format, samples, usage| {
            gpu.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("caller_target"),
                size: wgpu::Extent3d {
                    width: W,
                    height: H,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: samples,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let attach = wgpu::TextureUsages::RENDER_ATTACHMENT;
        let target = MainTarget {
            color_format: FORMAT,
            depth_format: DEPTH,
            sample_count: samples,
            depth,
            output: ColorOutput::ToneMapped,
        };
        let layout = gpu
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: None,
                entries: &[sylvan_gpu::layout::uniform(0, wgpu::ShaderStages::VERTEX)],
            });
        let uniforms = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: 64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            }],
        });
        let module = sylvan_gpu::shader(gpu, "walls", WALL_WGSL);
        let pl = gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: None,
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        let walls = gpu
            .device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("walls"),
                layout: Some(&pl),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs"),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: 24,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3],
                    })],
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs"),
                    compilation_options: Default::default(),
                    targets: &[Some(FORMAT.into())],
                }),
                primitive: Default::default(),
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(target.compare()),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: wgpu::MultisampleState {
                    count: samples,
                    ..Default::default()
                },
                multiview_mask: None,
                cache: None,
            });
        Self {
            color: tex(FORMAT, 1, attach | wgpu::TextureUsages::COPY_SRC),
            msaa: (samples > 1).then(|| tex(FORMAT, samples, attach)),
            depth: tex(DEPTH, samples, attach),
            target,
            walls,
            uniforms,
            bind,
        }
    }

    /// One caller frame: clear to `clear`, draw `walls` (world-space triangles with colours)
    /// and Sylvan's `layers`, in one pass; returns the resolved picture.
    #[allow(clippy::too_many_arguments)] // a test helper: every argument is one knob
    fn frame(
        &self,
        gpu: &Gpu,
        renderer: &mut Renderer,
        camera: CameraMatrices,
        sun: &sylvan_scene::Sun,
        layers: Layers,
        walls: &[[f32; 6]],
        clear: wgpu::Color,
    ) -> image::RgbImage {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        renderer
            .prepare(gpu, &mut encoder, &camera, sun)
            .expect("prepare");
        gpu.queue.write_buffer(
            &self.uniforms,
            0,
            bytemuck::cast_slice(&(camera.proj * camera.view).to_cols_array()),
        );
        let vertices = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: (walls.len().max(1) * 24) as u64,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        gpu.queue
            .write_buffer(&vertices, 0, bytemuck::cast_slice(walls));
        let resolved = self.color.create_view(&Default::default());
        let msaa = self
            .msaa
            .as_ref()
            .map(|t| t.create_view(&Default::default()));
        let depth = self.depth.create_view(&Default::default());
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("caller_main"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: msaa.as_ref().unwrap_or(&resolved),
                    depth_slice: None,
                    resolve_target: msaa.as_ref().map(|_| &resolved),
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(clear),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &depth,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(self.target.far_depth()),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            // Sylvan first when it draws its sky (at the far plane); the caller's walls, then
            // the trees, otherwise: depth decides either way.
            if layers.sky {
                renderer.draw(&mut pass, layers);
            }
            if !walls.is_empty() {
                pass.set_pipeline(&self.walls);
                pass.set_bind_group(0, &self.bind, &[]);
                pass.set_vertex_buffer(0, vertices.slice(..));
                pass.draw(0..walls.len() as u32, 0..1);
            }
            if !layers.sky {
                renderer.draw(&mut pass, layers);
            }
        }
        gpu.queue.submit([encoder.finish()]);
        let rgba = sylvan_gpu::read_rgba8(gpu, &self.color).expect("readback");
        image::DynamicImage::ImageRgba8(rgba).into_rgb8()
    }
}

fn flip(a: &image::RgbImage, b: &image::RgbImage) -> f32 {
    sylvan_eval::flip(a, b).expect("flip").mean
}

/// The camera matrices of `view` with a standard-Z projection (0 near, 1 far).
fn standard(view: &View) -> CameraMatrices {
    CameraMatrices {
        view: view.view(),
        proj: Mat4::perspective_rh(view.fov_y, view.aspect, view.near, view.far),
        width: W,
        height: H,
    }
}

fn reversed(view: &View) -> CameraMatrices {
    CameraMatrices {
        view: view.view(),
        proj: view.proj(),
        width: W,
        height: H,
    }
}

#[test]
fn embedded_frame_matches_own_frame() {
    let gpu = caller_gpu();
    let scene = grove();
    let plants = [common::test_tree()];
    // Opaque geometry matches to 8-bit rounding (measured 0.0036); octahedral's translucent
    // texels blend after the tone curve in an LDR target, not before it as in Sylvan's own
    // resolve (measured 0.031).
    for (technique, bound) in [("geometry", 0.01), ("octahedral", 0.04)] {
        let (own, r) = common::render_with_options(&gpu, &scene, &plants, &options(technique));
        let view = own_view(&r, &scene.camera);
        let host = Host::new(&gpu, 1, DepthConvention::Reversed);
        let mut e = Renderer::for_target(
            &gpu,
            &scene,
            &plants,
            &options(technique),
            host.target,
            &mut |_, _, _| {},
        )
        .expect("embedded renderer");
        let got = host.frame(
            &gpu,
            &mut e,
            reversed(&view),
            &scene.sun,
            Layers::ALL,
            &[],
            wgpu::Color::BLACK,
        );
        let drawn: u32 = e.trees_drawn(&gpu).expect("counts").values().sum();
        let f = flip(&own, &got);
        eprintln!("{technique}: embedded vs own ꟻLIP {f:.4}, {drawn} trees drawn");
        let _ = std::fs::create_dir_all("../../out/tests");
        let _ = got.save(format!("../../out/tests/embed-{technique}.png"));
        let _ = own.save(format!("../../out/tests/embed-{technique}-own.png"));
        assert_eq!(
            drawn, 3,
            "{technique}: the embedded frame drew {drawn} of 3 trees"
        );
        assert!(
            f < bound,
            "{technique}: embedded frame differs from Sylvan's own (ꟻLIP {f:.4} ≥ {bound})"
        );
    }
}

#[test]
fn standard_depth_with_msaa_matches_reversed_depth() {
    let gpu = caller_gpu();
    let scene = grove();
    let plants = [common::test_tree()];
    let mut pictures = Vec::new();
    for (samples, depth) in [
        (1, DepthConvention::Reversed),
        (4, DepthConvention::Standard),
    ] {
        let host = Host::new(&gpu, samples, depth);
        let (mut r, camera) = embedded_geometry(&gpu, &scene, &plants, &host, depth);
        pictures.push(host.frame(
            &gpu,
            &mut r,
            camera,
            &scene.sun,
            Layers::ALL,
            &[],
            wgpu::Color::BLACK,
        ));
    }
    let f = flip(&pictures[0], &pictures[1]);
    eprintln!("standard Z + 4× MSAA vs reversed Z, 1 sample: ꟻLIP {f:.4}");
    // Only antialiased edges may differ.
    assert!(f < 0.05, "standard-Z MSAA frame differs: ꟻLIP {f:.4}");
}

/// A `geometry` renderer for `host`'s target, and the scene camera's matrices in `depth`'s
/// convention.
fn embedded_geometry(
    gpu: &Gpu,
    scene: &Scene,
    plants: &[sylvan_plant::Plant],
    host: &Host,
    depth: DepthConvention,
) -> (Renderer, CameraMatrices) {
    let r = Renderer::for_target(
        gpu,
        scene,
        plants,
        &options("geometry"),
        host.target,
        &mut |_, _, _| {},
    )
    .expect("embedded renderer");
    let view = own_view(&r, &scene.camera);
    let camera = match depth {
        DepthConvention::Reversed => reversed(&view),
        DepthConvention::Standard => standard(&view),
    };
    (r, camera)
}

/// World-space triangles of an axis-aligned vertical wall `z = z0` over `x0..x1`, `y0..y1`.
fn wall(x0: f32, x1: f32, y0: f32, y1: f32, z0: f32, rgb: [f32; 3]) -> Vec<[f32; 6]> {
    let v = |x: f32, y: f32| [x, y, z0, rgb[0], rgb[1], rgb[2]];
    vec![
        v(x0, y0),
        v(x1, y0),
        v(x1, y1),
        v(x0, y0),
        v(x1, y1),
        v(x0, y1),
    ]
}

#[test]
fn caller_geometry_and_trees_hide_each_other() {
    let gpu = caller_gpu();
    let scene = grove();
    let plants = [common::test_tree()];
    let color = |r, g, b| wgpu::Color { r, g, b, a: 1.0 };
    let (magenta, cyan) = (color(1.0, 0.0, 1.0), color(0.0, 1.0, 1.0));
    let near = |a: &image::Rgb<u8>, b: [u8; 3], tol: u8| {
        a.0.iter().zip(b).all(|(x, y)| x.abs_diff(y) <= tol)
    };
    for depth in [DepthConvention::Reversed, DepthConvention::Standard] {
        let host = Host::new(&gpu, 4, depth);
        let (mut r, camera) = embedded_geometry(&gpu, &scene, &plants, &host, depth);
        // Trees alone over two clear colours: a pixel equal in both is wholly a tree's, one
        // that keeps its clear colour in both is background.
        let over_magenta = host.frame(
            &gpu,
            &mut r,
            camera,
            &scene.sun,
            Layers::TREES,
            &[],
            magenta,
        );
        let over_cyan = host.frame(&gpu, &mut r, camera, &scene.sun, Layers::TREES, &[], cyan);
        // A red wall between the camera and the trees over the left of the view, and a blue
        // wall far behind them everywhere.
        let mut walls = wall(30.0, 57.0, -5.0, 30.0, 50.0, [1.0, 0.0, 0.0]);
        walls.extend(wall(0.0, 120.0, -40.0, 60.0, 90.0, [0.0, 0.0, 1.0]));
        let got = host.frame(
            &gpu,
            &mut r,
            camera,
            &scene.sun,
            Layers::TREES,
            &walls,
            magenta,
        );
        let _ = std::fs::create_dir_all("../../out/tests");
        let _ = got.save(format!("../../out/tests/embed-walls-{depth:?}.png"));
        let edge = pixel_x(&camera, Vec3::new(57.0, 5.0, 50.0));
        let (mut red_region, mut red, mut tree_px, mut tree_kept, mut bg_px, mut bg_blue) =
            (0, 0, 0, 0, 0, 0);
        for (x, y, p) in got.enumerate_pixels() {
            let (m, c) = (over_magenta.get_pixel(x, y), over_cyan.get_pixel(x, y));
            // Looking along +Z, +X is to the left: the red wall (x < 57) is on the right.
            if (x as f32) > edge + 2.0 {
                red_region += 1;
                red += near(p, [255, 0, 0], 2) as u32;
            } else if (x as f32) < edge - 2.0 {
                if near(m, c.0, 2) {
                    tree_px += 1;
                    tree_kept += near(p, m.0, 3) as u32;
                } else if near(m, [255, 0, 255], 0) && near(c, [0, 255, 255], 0) {
                    bg_px += 1;
                    bg_blue += near(p, [0, 0, 255], 2) as u32;
                }
            }
        }
        eprintln!(
            "{depth:?}: red wall {red}/{red_region} px, trees before the blue wall {tree_kept}/{tree_px}, background turned blue {bg_blue}/{bg_px}"
        );
        assert!(
            red_region > 500 && red == red_region,
            "{depth:?}: trees drew through the caller's nearer wall ({red}/{red_region} px red)"
        );
        assert!(
            tree_px > 300 && tree_kept == tree_px,
            "{depth:?}: the caller's farther wall hid trees ({tree_kept}/{tree_px} tree pixels kept)"
        );
        assert!(
            bg_px > 300 && bg_blue == bg_px,
            "{depth:?}: the farther wall is missing where no tree hides it ({bg_blue}/{bg_px})"
        );
    }
}

/// The pixel column where `p` lands.
fn pixel_x(camera: &CameraMatrices, p: Vec3) -> f32 {
    let c = camera.proj * camera.view * p.extend(1.0);
    (c.x / c.w * 0.5 + 0.5) * camera.width as f32
}

#[test]
fn unusable_targets_are_refused_with_a_reason() {
    let gpu = caller_gpu();
    let scene = grove();
    let plants = [common::test_tree()];
    let mut target = MainTarget {
        color_format: wgpu::TextureFormat::Rgba8Uint,
        depth_format: DEPTH,
        sample_count: 1,
        depth: DepthConvention::Reversed,
        output: ColorOutput::ToneMapped,
    };
    let err = |t: MainTarget| {
        Renderer::for_target(
            &gpu,
            &scene,
            &plants,
            &options("geometry"),
            t,
            &mut |_, _, _| {},
        )
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default()
    };
    let e = err(target);
    assert!(e.contains("Rgba8Uint") && e.contains("use"), "{e}");
    target.color_format = FORMAT;
    target.depth_format = wgpu::TextureFormat::Rgba8Unorm;
    let e = err(target);
    assert!(e.contains("has no depth"), "{e}");
    target.depth_format = DEPTH;
    target.sample_count = 3;
    let e = err(target);
    assert!(e.contains("3 samples"), "{e}");
    // A renderer for a caller's target refuses Sylvan's own frame and camera mistakes.
    target.sample_count = 1;
    let mut r = Renderer::for_target(
        &gpu,
        &scene,
        &plants,
        &options("geometry"),
        target,
        &mut |_, _, _| {},
    )
    .expect("renderer");
    let e = r
        .render(&gpu, &scene.camera, &scene.sun)
        .unwrap_err()
        .to_string();
    assert!(e.contains("prepare and draw"), "{e}");
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    let ortho = CameraMatrices {
        view: Mat4::IDENTITY,
        proj: Mat4::orthographic_rh(-1.0, 1.0, -1.0, 1.0, 0.1, 100.0),
        width: W,
        height: H,
    };
    let e = r
        .prepare(&gpu, &mut encoder, &ortho, &scene.sun)
        .unwrap_err()
        .to_string();
    assert!(e.contains("perspective"), "{e}");
}
