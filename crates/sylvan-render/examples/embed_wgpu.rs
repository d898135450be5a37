//! A plain wgpu program that draws its own ground and a Sylvan forest in one render pass.
//!
//! The program owns everything a game renderer owns: the device (opened with the adapter's
//! limits), the command encoder, a 4× multisampled `Rgba8UnormSrgb` target with a
//! standard-Z (`LessEqual`) `Depth32Float` buffer, the camera's view and projection matrices,
//! its sky (a clear colour) and its ground: a checkered mesh over the scene's terrain heights,
//! lit by its own shader. Sylvan records its culling, level-of-detail work and shadow maps
//! into the program's encoder ([`Renderer::prepare`]) and its trees into the program's pass
//! ([`Renderer::draw`]), depth-tested against the ground.
//!
//! ```text
//! cargo run --release -p sylvan-render --example embed_wgpu -- [SCENE.toml] [--technique NAME] [--size WxH] [--out PNG]
//! ```
//!
//! With no scene it draws the built-in grove (`Scene::builtin_grove`) with the `auto` chain and
//! writes `out/embed_wgpu.png`.

use glam::{Mat4, Vec3};
use std::path::PathBuf;
use sylvan_gpu::Gpu;
use sylvan_render::{
    CameraMatrices, ColorOutput, DepthConvention, Layers, MainTarget, RenderOptions, Renderer,
};
use sylvan_scene::Scene;

const COLOR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
const SAMPLES: u32 = 4;

/// The program's ground shader: its own lighting, nothing of Sylvan's.
const GROUND_WGSL: &str = r#"
struct Globals { view_proj: mat4x4<f32>, sun: vec4<f32> };
@group(0) @binding(0) var<uniform> g: Globals;
struct Out {
    @builtin(position) pos: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
};
@vertex fn vs(@location(0) p: vec3<f32>, @location(1) n: vec3<f32>) -> Out {
    return Out(g.view_proj * vec4<f32>(p, 1.0), p, n);
}
@fragment fn fs(in: Out) -> @location(0) vec4<f32> {
    let cell = vec2<i32>(floor(in.world.xz / 8.0));
    let checker = select(0.75, 1.0, ((cell.x + cell.y) & 1) == 0);
    let albedo = vec3<f32>(0.30, 0.27, 0.18) * checker;
    let light = max(dot(normalize(in.normal), g.sun.xyz), 0.0) * 0.8 + 0.25;
    return vec4<f32>(albedo * light, 1.0);
}
"#;

struct Args {
    scene: Option<PathBuf>,
    technique: String,
    size: (u32, u32),
    out: PathBuf,
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        scene: None,
        technique: "auto".into(),
        size: (1280, 720),
        out: PathBuf::from("out/embed_wgpu.png"),
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = || it.next().ok_or(format!("{arg} needs a value"));
        match arg.as_str() {
            "--technique" => a.technique = value()?,
            "--out" => a.out = PathBuf::from(value()?),
            "--size" => {
                let v = value()?;
                let (w, h) = v
                    .split_once('x')
                    .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
                    .filter(|&(w, h): &(u32, u32)| {
                        (1..=8192).contains(&w) && (1..=8192).contains(&h)
                    })
                    .ok_or(format!("--size {v}: expected WxH, e.g. 1280x720"))?;
                a.size = (w, h);
            }
            s if s.starts_with('-') => return Err(format!("unknown option {s}")),
            s => a.scene = Some(PathBuf::from(s)),
        }
    }
    Ok(a)
}

fn main() {
    if let Err(e) = run() {
        eprintln!("embed_wgpu: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args = parse_args()?;
    let scene = match &args.scene {
        Some(p) => Scene::load(p)?,
        None => Scene::builtin_grove(),
    };
    let (width, height) = args.size;

    // 1. The program's own device, as any wgpu program opens one.
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))
        .map_err(|e| format!("no GPU adapter ({e}) — {}", sylvan_gpu::INSTALL_HINT))?;
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_limits: adapter.limits(),
        ..Default::default()
    }))?;

    // 2. Sylvan on that device, built for the program's attachments and depth convention.
    let gpu = Gpu::from_parts(instance, adapter, device.clone(), queue.clone());
    let target = MainTarget {
        color_format: COLOR,
        depth_format: DEPTH,
        sample_count: SAMPLES,
        depth: DepthConvention::Standard,
        output: ColorOutput::ToneMapped,
    };
    let plants = sylvan_render::load_plants(&scene)?;
    let options = RenderOptions {
        technique: args.technique.clone(),
        ..Default::default()
    };
    let mut forest =
        Renderer::for_target(&gpu, &scene, &plants, &options, target, &mut |_, _, _| {})?;

    // 3. The program's own ground mesh, pipeline and attachments.
    let ground = Ground::new(&device, &scene);
    let texture = |samples, format, usage| {
        device.create_texture(&wgpu::TextureDescriptor {
            label: None,
            size: wgpu::Extent3d {
                width,
                height,
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
    let msaa = texture(SAMPLES, COLOR, attach).create_view(&Default::default());
    let resolved = texture(1, COLOR, attach | wgpu::TextureUsages::COPY_SRC);
    let resolved_view = resolved.create_view(&Default::default());
    let depth = texture(SAMPLES, DEPTH, attach).create_view(&Default::default());

    // 4. The program's camera: standard-Z perspective, its own near and far planes.
    let cam = &scene.camera;
    let view = Mat4::look_at_rh(cam.position, cam.look_at, Vec3::Y);
    let proj = Mat4::perspective_rh(
        cam.fov_deg.to_radians(),
        width as f32 / height as f32,
        0.5,
        20_000.0,
    );
    let camera = CameraMatrices {
        view,
        proj,
        width,
        height,
    };

    // 5. One frame: Sylvan's preparation, then one pass with the ground and the trees.
    let start = std::time::Instant::now();
    let mut encoder = device.create_command_encoder(&Default::default());
    let prepared = forest.prepare(&gpu, &mut encoder, &camera, &scene.sun)?;
    ground.update(&queue, proj * view, scene.sun.direction());
    let counts = {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("program_main_pass"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &msaa,
                depth_slice: None,
                resolve_target: Some(&resolved_view),
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color {
                        r: 0.55,
                        g: 0.7,
                        b: 0.9,
                        a: 1.0,
                    }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        ground.draw(&mut pass);
        forest.draw(&mut pass, Layers::TREES)
    };
    queue.submit([encoder.finish()]);
    let image = sylvan_gpu::read_rgba8(&gpu, &resolved)?;
    let wall_ms = start.elapsed().as_secs_f64() * 1e3;
    let drawn = forest.trees_drawn(&gpu)?;
    if let Some(dir) = args.out.parent() {
        std::fs::create_dir_all(dir)?;
    }
    image.save(&args.out)?;
    println!(
        "{}: {width}x{height}, {SAMPLES}x MSAA, standard Z, technique {} — {:.1} ms wall (first frame), {:.2} ms Sylvan CPU, {} tree draw calls, trees drawn {:?}",
        args.out.display(),
        forest.technique_name(),
        wall_ms,
        prepared.cpu_ms,
        counts.draw_calls,
        drawn
    );
    Ok(())
}

/// The program's ground: a grid mesh over the scene's terrain heights.
struct Ground {
    pipeline: wgpu::RenderPipeline,
    globals: wgpu::Buffer,
    bind: wgpu::BindGroup,
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
}

impl Ground {
    fn new(device: &wgpu::Device, scene: &Scene) -> Self {
        use wgpu::util::DeviceExt;
        let t = &scene.terrain;
        let n = 256u32;
        let mut vertices: Vec<[f32; 6]> = Vec::with_capacity((n * n) as usize);
        for r in 0..n {
            for c in 0..n {
                let x = t.size[0] * c as f32 / (n - 1) as f32;
                let z = t.size[1] * r as f32 / (n - 1) as f32;
                let normal = t.normal_at(x, z);
                vertices.push([x, t.height_at(x, z), z, normal.x, normal.y, normal.z]);
            }
        }
        let mut indices = Vec::with_capacity(((n - 1) * (n - 1) * 6) as usize);
        for r in 0..n - 1 {
            for c in 0..n - 1 {
                let i = r * n + c;
                indices.extend_from_slice(&[i, i + n, i + 1, i + 1, i + n, i + n + 1]);
            }
        }
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("ground"),
            source: wgpu::ShaderSource::Wgsl(GROUND_WGSL.into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: None,
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let globals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("ground_globals"),
            size: 80,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: globals.as_entire_binding(),
            }],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: None,
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("ground"),
            layout: Some(&pipeline_layout),
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
                targets: &[Some(COLOR.into())],
            }),
            primitive: Default::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::LessEqual),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: wgpu::MultisampleState {
                count: SAMPLES,
                ..Default::default()
            },
            multiview_mask: None,
            cache: None,
        });
        Self {
            pipeline,
            globals,
            bind,
            vertices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("ground_vertices"),
                contents: bytemuck::cast_slice(&vertices),
                usage: wgpu::BufferUsages::VERTEX,
            }),
            indices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("ground_indices"),
                contents: bytemuck::cast_slice(&indices),
                usage: wgpu::BufferUsages::INDEX,
            }),
            index_count: indices.len() as u32,
        }
    }

    fn update(&self, queue: &wgpu::Queue, view_proj: Mat4, sun: Vec3) {
        let mut data = [0f32; 20];
        data[..16].copy_from_slice(&view_proj.to_cols_array());
        data[16..19].copy_from_slice(&sun.to_array());
        queue.write_buffer(&self.globals, 0, bytemuck::cast_slice(&data));
    }

    fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind, &[]);
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..self.index_count, 0, 0..1);
    }
}
