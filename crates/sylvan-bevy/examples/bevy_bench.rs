//! Frame time of a Sylvan forest inside Bevy, headless: the same scene, camera and size with
//! the forest and without it (Bevy's own frame), and the plugin's CPU per frame.
//!
//! ```text
//! cd crates/sylvan-bevy
//! cargo run --release --ignore-rust-version --example bevy_bench -- [SCENE.toml] [--technique NAME] [--size WxH] [--frames N]
//! ```
//!
//! Prints one line per configuration: the median wall-clock milliseconds of `App::update`
//! (pipelined rendering off, so an update is one whole frame: Bevy's systems, its passes and
//! Sylvan's work) followed by a wait for the device to finish the frame's GPU work,
//! and the plugin's median CPU milliseconds. Compare with
//! `sylvan bench SCENE --technique NAME --size WxH` in the same run.

use bevy::app::ScheduleRunnerPlugin;
use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy::window::ExitCondition;
use bevy::winit::WinitPlugin;
use std::time::Instant;
use sylvan_bevy::{Forest, ForestCamera, ForestLighting, ForestStats, SylvanPlugin};
use sylvan_render::Layers;

fn main() {
    let mut scene_path = None;
    let mut technique = "geometry".to_string();
    let (mut w, mut h, mut frames) = (640u32, 360u32, 20usize);
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        match a.as_str() {
            "--technique" => technique = it.next().unwrap_or(technique),
            "--frames" => frames = it.next().and_then(|v| v.parse().ok()).unwrap_or(frames),
            "--size" => {
                if let Some((a, b)) = it.next().as_deref().and_then(|v| v.split_once('x')) {
                    w = a.parse().unwrap_or(w);
                    h = b.parse().unwrap_or(h);
                }
            }
            s => scene_path = Some(s.to_string()),
        }
    }
    let forest = match &scene_path {
        Some(p) => Forest::load(p),
        None => Forest::from_scene(sylvan_scene::Scene::builtin_grove()),
    };
    let forest = match forest {
        Ok(f) => f
            .with_technique(&technique)
            .with_layers(Layers::ALL)
            .with_lighting(ForestLighting::Scene),
        Err(e) => {
            eprintln!("bevy_bench: {e}");
            std::process::exit(1);
        }
    };
    for (with_forest, msaa) in [
        (true, Msaa::Sample4),
        (true, Msaa::Off),
        (false, Msaa::Sample4),
    ] {
        let (ms, cpu) = run(&forest, with_forest, msaa, w, h, frames);
        println!(
            "bevy {}, {}x MSAA: {w}x{h}, technique {technique}, {frames} frames — median {ms:.1} ms/frame (wall), plugin CPU median {cpu:.3} ms/frame",
            if with_forest {
                "with the forest"
            } else {
                "without it (Bevy's own frame)"
            },
            msaa.samples()
        );
    }
}

/// Median wall ms per frame and median plugin CPU ms, after 5 warm-up frames, with the camera's
/// `msaa`.
fn run(
    forest: &Forest,
    with_forest: bool,
    msaa: Msaa,
    w: u32,
    h: u32,
    frames: usize,
) -> (f64, f64) {
    let mut app = App::new();
    app.add_plugins((
        DefaultPlugins
            .build()
            .disable::<WinitPlugin>()
            .disable::<bevy::render::pipelined_rendering::PipelinedRenderingPlugin>()
            .set(WindowPlugin {
                primary_window: None,
                exit_condition: ExitCondition::DontExit,
                ..default()
            }),
        ScheduleRunnerPlugin::default(),
        SylvanPlugin,
    ));
    let cam = forest.scene().camera;
    app.add_systems(
        Startup,
        move |mut commands: Commands, mut images: ResMut<Assets<Image>>| {
            let target = images.add(Image::new_target_texture(
                w,
                h,
                bevy::render::render_resource::TextureFormat::Rgba8UnormSrgb,
                None,
            ));
            commands.spawn((
                Camera3d::default(),
                RenderTarget::Image(target.into()),
                bevy::core_pipeline::tonemapping::Tonemapping::None,
                Projection::Perspective(PerspectiveProjection {
                    fov: cam.fov_deg.to_radians(),
                    near: 0.25,
                    ..default()
                }),
                Transform::from_translation(Vec3::from_array(cam.position.to_array()))
                    .looking_at(Vec3::from_array(cam.look_at.to_array()), Vec3::Y),
                ForestCamera,
                msaa,
            ));
        },
    );
    if with_forest {
        app.world_mut().spawn(forest.clone());
    }
    app.finish();
    app.cleanup();
    let (mut times, mut cpu) = (Vec::new(), Vec::new());
    for i in 0..frames + 5 {
        let start = Instant::now();
        app.update();
        // Wait for the frame's GPU work, so the time is the whole frame.
        let _ = app
            .sub_app(bevy::render::RenderApp)
            .world()
            .resource::<bevy::render::renderer::RenderDevice>()
            .wgpu_device()
            .poll(wgpu::PollType::wait_indefinitely());
        let ms = start.elapsed().as_secs_f64() * 1e3;
        if i >= 5 {
            times.push(ms);
            cpu.push(app.world().resource::<ForestStats>().last().cpu_ms);
        }
    }
    if let Some(e) = app.world().resource::<ForestStats>().last().error {
        eprintln!("bevy_bench: the forest was not drawn: {e}");
        std::process::exit(1);
    }
    (median(&mut times), median(&mut cpu))
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}
