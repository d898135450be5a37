//! The window and the frame loop (winit 0.30 `ApplicationHandler`).
//!
//! One frame: camera update → [`Viewer::sync`] (reload, rebuild, settings, size) → the renderer
//! draws the scene into its output → the panel is built → scene blit, egui and the copy to the
//! surface are recorded in one encoder → present. Screenshots read the composite back. Scripted
//! runs (`--frames N`) count frames, snapshot allocations, write the screenshot and the report,
//! and leave the event loop.

use super::Config;
use super::camera::{self, Controller, Mode};
use super::panel::{self, Action, UiState};
use super::present::Presenter;
use super::stats::{Allocations, FrameClock, FrameRecord, GpuObjects, ViewReport};
use super::viewer::Viewer;
use anyhow::{Context, Result, anyhow};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;
use sylvan_gpu::{Gpu, OUTPUT_FORMAT};
use sylvan_scene::CameraPath;
use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, KeyEvent, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

/// Most frames in a row the surface may refuse before a scripted run gives up.
const MAX_SKIPPED: usize = 200;

/// Opens the window and runs until it closes (or the scripted frames are done).
pub fn run(config: Config) -> Result<()> {
    let event_loop = EventLoop::new().map_err(|e| {
        anyhow!(
            "cannot open a window ({}) — run on a desktop, or under a virtual X server: `xvfb-run -a sylvan view …` (apt-get install xvfb)",
            os_reason(&e)
        )
    })?;
    let desc = wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(
        event_loop.owned_display_handle(),
    ));
    let backends = backends_label(desc.backends);
    let instance = wgpu::Instance::new(desc);
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut app = App {
        config,
        instance: Some(instance),
        backends,
        running: None,
        error: None,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| anyhow!("the window's event loop failed: {e}"))?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// winit's OS errors read `os error at FILE.rs:LINE: reason`: keep the reason.
fn os_reason(e: &dyn std::fmt::Display) -> String {
    let text = e.to_string();
    match text.rfind(".rs:") {
        Some(i) => text[i..]
            .split_once(": ")
            .map_or(text.clone(), |(_, reason)| {
                reason.trim_end_matches('.').to_string()
            }),
        None => text,
    }
}

fn backends_label(b: wgpu::Backends) -> String {
    [
        (wgpu::Backends::VULKAN, "Vulkan"),
        (wgpu::Backends::GL, "GL"),
        (wgpu::Backends::METAL, "Metal"),
        (wgpu::Backends::DX12, "DX12"),
    ]
    .iter()
    .filter(|(k, _)| b.contains(*k))
    .map(|(_, n)| *n)
    .collect::<Vec<_>>()
    .join(", ")
}

struct App {
    config: Config,
    instance: Option<wgpu::Instance>,
    backends: String,
    running: Option<Running>,
    error: Option<anyhow::Error>,
}

/// Everything that exists while the window is open.
struct Running {
    window: Arc<Window>,
    gpu: Arc<Gpu>,
    presenter: Presenter,
    egui_ctx: egui::Context,
    egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
    viewer: Viewer,
    ui: UiState,
    clock: FrameClock,
    last_frame: Instant,
    cursor: Option<PhysicalPosition<f64>>,
    looking: bool,
    frames: usize,
    skipped: usize,
    want_screenshot: bool,
    screenshots: usize,
    records: Vec<FrameRecord>,
    allocations: Vec<Allocations>,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        match self.open(event_loop) {
            Ok(r) => {
                r.window.request_redraw();
                self.running = Some(r);
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(r) = self.running.as_mut() else {
            return;
        };
        let response = r.egui_state.on_window_event(&r.window, &event);
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if let Err(e) = r.presenter.resize(&r.gpu, size.width, size.height) {
                    r.viewer.error = Some(super::one_line(&e));
                }
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.frame(event_loop) {
                    self.fail(event_loop, e);
                }
            }
            WindowEvent::KeyboardInput {
                event:
                    KeyEvent {
                        physical_key: PhysicalKey::Code(code),
                        state,
                        repeat,
                        ..
                    },
                ..
            } => {
                let pressed = state == ElementState::Pressed;
                // Releases always count, so a key held while focus moved does not stick.
                if (!pressed || !response.consumed) && r.key(code, pressed, repeat) {
                    event_loop.exit();
                }
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let pressed = state == ElementState::Pressed;
                if pressed && response.consumed {
                    return;
                }
                match button {
                    MouseButton::Right | MouseButton::Left => r.looking = pressed,
                    MouseButton::Middle if pressed => r.pick_at_cursor(),
                    _ => {}
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                if let Some(last) = r.cursor
                    && r.looking
                {
                    let (dx, dy) = (position.x - last.x, position.y - last.y);
                    r.viewer.camera.mouse_drag(dx as f32, dy as f32);
                }
                r.cursor = Some(position);
            }
            WindowEvent::CursorLeft { .. } => {
                r.cursor = None;
                r.looking = false;
            }
            WindowEvent::MouseWheel { delta, .. } if !response.consumed => {
                let notches = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 50.0,
                };
                r.viewer.camera.wheel(notches);
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(r) = &self.running {
            r.window.request_redraw();
        }
    }
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: anyhow::Error) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        event_loop.exit();
    }

    /// Window, surface, device, presenter, viewer and egui.
    fn open(&mut self, event_loop: &ActiveEventLoop) -> Result<Running> {
        let c = &self.config;
        let o = &c.resolved.options;
        let attrs = Window::default_attributes()
            .with_title("Sylvan")
            .with_inner_size(PhysicalSize::new(o.width, o.height));
        let window =
            Arc::new(event_loop.create_window(attrs).map_err(|e| {
                anyhow!("cannot open a window ({}) — check DISPLAY", os_reason(&e))
            })?);
        let instance = self
            .instance
            .take()
            .ok_or_else(|| anyhow!("the window was opened twice"))?;
        let surface = instance.create_surface(window.clone()).map_err(|e| {
            anyhow!(
                "cannot draw into the window ({e}) — try WGPU_BACKEND=vulkan or WGPU_BACKEND=gl"
            )
        })?;
        let gpu = Arc::new(Gpu::with_instance(
            instance,
            Some(&surface),
            self.backends.clone(),
        )?);
        let size = window.inner_size();
        let presenter = Presenter::new(&gpu, surface, size.width, size.height, c.vsync)?;
        let (w, h) = presenter.size();
        let mut options = o.clone();
        options.width = ((w as f32 * c.render_scale).round() as u32).max(1);
        options.height = ((h as f32 * c.render_scale).round() as u32).max(1);
        let mut controller = Controller::new(c.resolved.camera);
        if let Some(p) = &c.path {
            controller.path = Some(p.clone());
            controller.set_mode(Mode::Path);
        }
        let mut viewer = Viewer::new(
            &gpu,
            c.resolved.scene.clone(),
            options,
            c.resolved.sun,
            controller,
        )?;
        viewer.overrides = c.resolved.overrides.clone();
        viewer.settings.render_scale = c.render_scale;
        viewer.settings.vsync = c.vsync;
        viewer.settings.debug = c.debug;

        let egui_ctx = egui::Context::default();
        let max_side = gpu.device.limits().max_texture_dimension_2d as usize;
        let egui_state = egui_winit::State::new(
            egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(max_side),
        );
        let egui_renderer = egui_wgpu::Renderer::new(
            &gpu.device,
            OUTPUT_FORMAT,
            egui_wgpu::RendererOptions::default(),
        );
        let path_file = c
            .path_file
            .as_ref()
            .map_or("camera-path.toml".into(), |p| p.display().to_string());
        let mut ui = UiState::new(gpu.info.name.clone(), path_file);
        ui.show_panel = c.panel;
        gpu.check()?;
        Ok(Running {
            window,
            gpu,
            presenter,
            egui_ctx,
            egui_state,
            egui_renderer,
            viewer,
            ui,
            clock: FrameClock::default(),
            last_frame: Instant::now(),
            cursor: None,
            looking: false,
            frames: 0,
            skipped: 0,
            want_screenshot: false,
            screenshots: 0,
            records: Vec::new(),
            allocations: Vec::new(),
        })
    }

    fn frame(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let Some(r) = self.running.as_mut() else {
            return Ok(());
        };
        let c = &self.config;
        let now = Instant::now();
        let dt = now.duration_since(r.last_frame).as_secs_f64();
        r.last_frame = now;

        // Camera: a scripted run with a path samples it evenly; otherwise real time.
        let scripted_t = match (c.frames, &c.path) {
            (Some(n), Some(p)) => {
                let t = super::super::common::path_time(r.frames, n, p.duration());
                r.viewer.camera.path_time = t;
                Some(t)
            }
            _ => {
                r.viewer.camera.update(dt as f32);
                None
            }
        };
        r.presenter.set_vsync(&r.gpu, r.viewer.settings.vsync);
        let (w, h) = r.presenter.size();
        r.viewer.sync(&r.gpu, w, h);
        if r.viewer.output_changed {
            if let Some(out) = r.viewer.renderer.output() {
                r.presenter.bind_scene(&r.gpu, &out.color_view);
            }
            r.viewer.output_changed = false;
        }
        let camera = r.viewer.camera.camera();
        let sun = r.viewer.settings.sun;
        match r.viewer.renderer.render(&r.gpu, &camera, &sun) {
            Ok(stats) => {
                if c.frames.is_some() {
                    r.records.push(FrameRecord {
                        frame: r.frames,
                        t: scripted_t,
                        ms: stats.frame_ms,
                        cpu_ms: dt * 1e3,
                        trees_drawn: stats.trees_drawn.clone(),
                        triangles: stats.triangles,
                        draw_calls: stats.draw_calls,
                    });
                }
                r.clock.push(stats, dt * 1e3);
            }
            Err(e) => r.viewer.error = Some(e.to_string()),
        }
        let last = c.frames.is_some_and(|n| r.frames + 1 >= n);
        if c.compare && r.frames == 0 {
            r.viewer.start_comparison(&r.gpu);
        }
        let finished = if last {
            r.viewer.comparison.wait()
        } else {
            r.viewer.comparison.poll()
        };
        if let Some(Err(e)) = finished {
            r.viewer.error = Some(e);
        }

        // The panel.
        let input = r.egui_state.take_egui_input(&r.window);
        let (viewer, ui, clock) = (&mut r.viewer, &mut r.ui, &r.clock);
        let full = r
            .egui_ctx
            .run_ui(input, |root| panel::show(root, viewer, ui, clock));
        r.egui_state
            .handle_platform_output(&r.window, full.platform_output);
        let jobs = r.egui_ctx.tessellate(full.shapes, full.pixels_per_point);
        // egui insists every texture delta is applied (it panics on drop otherwise).
        let mut textures = full.textures_delta;
        for (id, deltas) in textures.set.drain() {
            for delta in &deltas {
                r.egui_renderer
                    .update_texture(&r.gpu.device, &r.gpu.queue, id, delta);
            }
        }
        let freed = std::mem::take(&mut textures.free);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [w, h],
            pixels_per_point: full.pixels_per_point,
        };

        // Scene, panel, window.
        let presented = match r.presenter.acquire(&r.gpu) {
            Some(frame) => {
                let mut encoder =
                    r.gpu
                        .device
                        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                            label: Some("view_frame"),
                        });
                r.presenter.encode_scene(&mut encoder);
                let extra = r.egui_renderer.update_buffers(
                    &r.gpu.device,
                    &r.gpu.queue,
                    &mut encoder,
                    &jobs,
                    &screen,
                );
                {
                    let mut pass = encoder
                        .begin_render_pass(&wgpu::RenderPassDescriptor {
                            label: Some("egui_pass"),
                            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                                view: r.presenter.composite_view(),
                                depth_slice: None,
                                resolve_target: None,
                                ops: wgpu::Operations {
                                    load: wgpu::LoadOp::Load,
                                    store: wgpu::StoreOp::Store,
                                },
                            })],
                            depth_stencil_attachment: None,
                            timestamp_writes: None,
                            occlusion_query_set: None,
                            multiview_mask: None,
                        })
                        .forget_lifetime();
                    r.egui_renderer.render(&mut pass, &jobs, &screen);
                }
                r.presenter.encode_present(&mut encoder, &frame);
                r.gpu
                    .queue
                    .submit(extra.into_iter().chain([encoder.finish()]));
                r.window.pre_present_notify();
                r.gpu.queue.present(frame);
                true
            }
            None => false,
        };
        for id in &freed {
            r.egui_renderer.free_texture(id);
        }
        r.gpu.check()?;

        let actions = std::mem::take(&mut r.ui.actions);
        for a in actions {
            r.act(a);
        }
        if !presented {
            r.skipped += 1;
            if c.frames.is_some() && r.skipped > MAX_SKIPPED {
                return Err(anyhow!(
                    "the window surface gave no image for {MAX_SKIPPED} frames in a row — is the window visible? try WGPU_BACKEND=gl"
                ));
            }
            return Ok(());
        }
        r.skipped = 0;
        if r.want_screenshot {
            r.want_screenshot = false;
            let file = c
                .screenshot
                .clone()
                .unwrap_or_else(|| next_screenshot_name(&mut r.screenshots));
            match r.screenshot(&file) {
                Ok(()) => r.viewer.notice = Some(format!("wrote {}", file.display())),
                Err(e) => r.viewer.error = Some(super::one_line(&e)),
            }
        }
        r.frames += 1;
        let Some(n) = c.frames else {
            return Ok(());
        };
        // Allocation snapshots: after warm-up (egui's font atlas and buffers exist by then) and
        // at the end. Waiting first lets wgpu free the finished frames' staging buffers.
        let warmup = (n / 3).clamp(1, 10);
        if r.frames == warmup || r.frames == n {
            r.gpu.wait()?;
            r.allocations.push(Allocations {
                after_frames: r.frames,
                gpu: GpuObjects::of(&r.gpu.device),
                renderer_rebuilds: r.viewer.rebuilds,
                presenter_allocations: r.presenter.allocations,
            });
        }
        if r.frames >= n {
            self.finish()?;
            event_loop.exit();
        }
        Ok(())
    }

    /// The end of a scripted run: screenshot, report, one summary line.
    fn finish(&mut self) -> Result<()> {
        let Some(r) = self.running.as_mut() else {
            return Ok(());
        };
        let c = &self.config;
        if let Some(e) = &r.viewer.error {
            // A scripted run must not hide a failure behind a screenshot.
            return Err(anyhow!("{e}"));
        }
        if let Some(file) = &c.screenshot {
            r.screenshot(file)?;
        }
        let mean = |f: fn(&FrameRecord) -> f64| {
            r.records.iter().map(f).sum::<f64>() / r.records.len().max(1) as f64
        };
        let (mean_ms, mean_cpu_ms) = (mean(|f| f.ms), mean(|f| f.cpu_ms));
        let out = r.viewer.renderer.options();
        let report = ViewReport {
            frames: r.frames,
            window: [r.presenter.size().0, r.presenter.size().1],
            render_size: [out.width, out.height],
            surface_format: format!("{:?}", r.presenter.surface_format()),
            adapter: r.gpu.adapter_label(),
            timer: r.clock.last.as_ref().map_or("wall", |s| s.timer.as_str()),
            mean_ms,
            mean_cpu_ms,
            per_frame: std::mem::take(&mut r.records),
            allocations: r.allocations.clone(),
            flip_mean: r.viewer.comparison.result.as_ref().map(|x| x.flip_mean),
        };
        if let Some(file) = &c.stats {
            std::fs::write(file, serde_json::to_string_pretty(&report)? + "\n").with_context(
                || {
                    format!(
                        "{}: cannot write stats — check the folder is writable",
                        file.display()
                    )
                },
            )?;
        }
        eprintln!(
            "view: {} frames {}x{} — renderer {:.1} ms ({}), loop {:.1} ms per frame on {}{}",
            report.frames,
            report.window[0],
            report.window[1],
            mean_ms,
            report.timer,
            mean_cpu_ms,
            report.adapter,
            c.screenshot
                .as_ref()
                .map_or(String::new(), |f| format!(", wrote {}", f.display()))
        );
        Ok(())
    }
}

impl Running {
    /// A key; returns true to quit.
    fn key(&mut self, code: KeyCode, pressed: bool, repeat: bool) -> bool {
        let held = &mut self.viewer.camera.held;
        match code {
            KeyCode::KeyW => held.forward = pressed,
            KeyCode::KeyS => held.back = pressed,
            KeyCode::KeyA => held.left = pressed,
            KeyCode::KeyD => held.right = pressed,
            KeyCode::KeyE => held.up = pressed,
            KeyCode::KeyQ => held.down = pressed,
            KeyCode::ShiftLeft | KeyCode::ShiftRight => held.fast = pressed,
            _ if !pressed || repeat => {}
            KeyCode::Escape => return true,
            KeyCode::F1 => self.ui.show_panel = !self.ui.show_panel,
            KeyCode::F12 => self.want_screenshot = true,
            KeyCode::KeyV => self.viewer.settings.vsync = !self.viewer.settings.vsync,
            KeyCode::KeyO => self.act(Action::OrbitCentre),
            KeyCode::KeyR => self.act(Action::ToggleRecording),
            KeyCode::KeyP => {
                let cam = &mut self.viewer.camera;
                let next = if cam.mode == Mode::Path {
                    Mode::Fly
                } else {
                    Mode::Path
                };
                cam.set_mode(next);
            }
            _ => {}
        }
        false
    }

    fn act(&mut self, action: Action) {
        let v = &mut self.viewer;
        match action {
            Action::Screenshot => self.want_screenshot = true,
            Action::Compare => v.start_comparison(&self.gpu),
            Action::OrbitCentre => self.pick(0.5, 0.5),
            Action::ToggleRecording => {
                if v.camera.recording_keys().is_none() {
                    v.camera.start_recording();
                    v.notice = Some("recording the camera…".into());
                } else {
                    match v.camera.stop_recording() {
                        Some(path) => {
                            let file = PathBuf::from(&self.ui.path_file);
                            match path.save(&file) {
                                Ok(()) => {
                                    v.notice = Some(format!(
                                        "saved {} keys to {} (replay: sylvan bench --path {})",
                                        path.keys.len(),
                                        file.display(),
                                        file.display()
                                    ));
                                    v.camera.path = Some(path);
                                }
                                Err(e) => v.error = Some(e.to_string()),
                            }
                        }
                        None => {
                            v.error = Some(
                                "record: too short — move the camera for a moment before stopping"
                                    .into(),
                            )
                        }
                    }
                }
            }
            Action::LoadPath => match CameraPath::load(std::path::Path::new(&self.ui.path_file)) {
                Ok(p) => {
                    v.camera.path = Some(p);
                    v.camera.set_mode(Mode::Fly);
                    v.camera.set_mode(Mode::Path);
                    v.error = None;
                }
                Err(e) => v.error = Some(e.to_string()),
            },
        }
    }

    fn pick_at_cursor(&mut self) {
        let Some(p) = self.cursor else {
            return;
        };
        let (w, h) = self.presenter.size();
        self.pick(p.x as f32 / w as f32, p.y as f32 / h as f32);
    }

    /// Orbits the tree under window position (`x`, `y` in [0, 1]).
    fn pick(&mut self, x: f32, y: f32) {
        let v = &mut self.viewer;
        let view_proj = v.renderer.view(&v.camera.camera()).view_proj();
        let (origin, dir) = camera::ray_through(view_proj, x, y);
        match camera::pick_tree(origin, dir, &v.scene.trees) {
            Some(i) => {
                let crown = camera::crown(&v.scene.trees[i]);
                v.camera.orbit_around(crown, Some(i));
                v.notice = Some(format!("orbiting tree {i}"));
            }
            None => v.notice = Some("no tree there to orbit".into()),
        }
    }

    /// Writes the composite (scene and panel) as an RGB PNG.
    fn screenshot(&self, file: &std::path::Path) -> Result<()> {
        let image = sylvan_gpu::read_rgba8(&self.gpu, self.presenter.composite())?;
        image::DynamicImage::ImageRgba8(image)
            .into_rgb8()
            .save(file)
            .with_context(|| {
                format!(
                    "{}: cannot write PNG — check the folder exists and is writable",
                    file.display()
                )
            })
    }
}

/// `sylvan-view-000.png`, `…-001.png`, …: the first name not taken in the current folder.
fn next_screenshot_name(counter: &mut usize) -> PathBuf {
    loop {
        let p = PathBuf::from(format!("sylvan-view-{:03}.png", *counter));
        *counter += 1;
        if !p.exists() {
            return p;
        }
    }
}
