//! Sylvan inside Bevy, headless: no window, the camera renders into an image, a screenshot
//! observer reads it back.
//!
//! - The Bevy frame of a small forest matches `sylvan render` (Sylvan's own renderer) of the
//!   same scene and camera within a measured ꟻLIP bound.
//! - A Bevy cube standing among the trees hides the tree behind it, and the tree in front of
//!   it hides part of the cube.
//! - The plugin reports its CPU cost and the technique drawing.
//!
//! Needs a GPU adapter (lavapipe here): without one Bevy cannot start, and the test fails
//! with the install hint.

use bevy::app::ScheduleRunnerPlugin;
use bevy::camera::RenderTarget;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy::render::{RenderPlugin, settings::WgpuSettings};
use bevy::window::ExitCondition;
use bevy::winit::WinitPlugin;
use std::sync::{Arc, Mutex};
use sylvan_bevy::{Forest, ForestCamera, ForestLighting, ForestStats, SylvanPlugin};
use sylvan_render::{Layers, RenderOptions, Renderer};
use sylvan_scene::{
    Camera as SylvanCamera, Fog, PlantSource, Scene, Sky, Species, Sun, TreeInstance,
};

const W: u32 = 256;
const H: u32 = 192;

/// The built-in pine: dense and green, so "a tree is here" is a colour test.
fn test_tree() -> sylvan_plant::Plant {
    sylvan_plant::preset("pine").expect("preset")
}

/// Three trees on a gentle slope: one in front of where the cube stands (overlapping its
/// left edge on screen), one behind it, one beside it. Looking along +Z, +X is to the left.
fn scene() -> Scene {
    let size = 120.0;
    let res = 17u32;
    let mut heights = Vec::new();
    for r in 0..res {
        for c in 0..res {
            let (x, z) = (
                size * c as f32 / (res - 1) as f32,
                size * r as f32 / (res - 1) as f32,
            );
            heights.push(0.02 * (x + z));
        }
    }
    let terrain = sylvan_scene::Terrain {
        size: [size, size],
        resolution: [res, res],
        heights,
    };
    let place = |x: f32, z: f32, seed: u32| TreeInstance {
        position: glam::Vec3::new(x, terrain.height_at(x, z), z),
        species: 0,
        seed,
        height: 9.0,
        rotation: seed as f32 * 1.3,
    };
    let trees = vec![
        place(59.0, 48.0, 1),
        place(50.0, 72.0, 2),
        place(40.0, 80.0, 3),
    ];
    Scene {
        species: vec![Species {
            name: "pine".into(),
            plant: PlantSource::Preset("pine".into()),
            height_m: [9.0, 9.0],
        }],
        trees,
        seeded: None,
        world: Default::default(),
        sun: Sun {
            azimuth_deg: 150.0,
            elevation_deg: 40.0,
            color: [3.0, 2.85, 2.6],
        },
        sky: Sky {
            zenith: [0.3, 0.5, 0.95],
            horizon: [0.78, 0.85, 0.95],
            ground: [0.24, 0.23, 0.15],
            ..Sky::default()
        },
        fog: Fog {
            half_distance_m: 0.0,
        },
        camera: SylvanCamera {
            position: glam::Vec3::new(62.0, 7.0, 36.0),
            look_at: glam::Vec3::new(57.0, 5.0, 62.0),
            fov_deg: 45.0,
        },
        lod_chain: Vec::new(),
        lod_bands: Vec::new(),
        technique_params: Vec::new(),
        source: None,
        terrain,
    }
}

/// Where the cube stands: between the front tree and the one behind it.
const CUBE: [f32; 3] = [54.0, 0.0, 60.0];
const CUBE_SIZE: f32 = 5.0;

/// Sylvan's own frame of `scene` with `technique` (what `sylvan render` draws).
fn sylvan_frame(scene: &Scene, technique: &str) -> image::RgbImage {
    let gpu =
        sylvan_gpu::Gpu::new().unwrap_or_else(|e| panic!("this test needs a GPU adapter: {e}"));
    let options = RenderOptions {
        width: W,
        height: H,
        technique: technique.into(),
        ..Default::default()
    };
    let mut r = Renderer::new(&gpu, scene, &[test_tree()], &options).expect("renderer");
    r.render(&gpu, &scene.camera, &scene.sun).expect("frame");
    image::DynamicImage::ImageRgba8(r.read_image(&gpu).expect("readback")).into_rgb8()
}

/// Bevy's frame: the forest (Sylvan's sky, terrain and trees, the scene's light) seen by a
/// Bevy camera at the scene's camera, with an unlit red cube when `cube`.
fn bevy_frame(
    scene: &Scene,
    technique: &str,
    cube: bool,
) -> (image::RgbImage, sylvan_bevy::ForestFrame) {
    let captured: Arc<Mutex<Option<Image>>> = Arc::default();
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
            })
            .set(RenderPlugin {
                render_creation: WgpuSettings::default().into(),
                ..default()
            }),
        ScheduleRunnerPlugin::default(),
        SylvanPlugin,
    ));
    let forest = Forest::with_plants(scene.clone(), vec![test_tree()])
        .with_technique(technique)
        .with_layers(Layers::ALL)
        .with_lighting(ForestLighting::Scene);
    let cam = scene.camera;
    let ground = forest.height_at(CUBE[0], CUBE[2]);
    app.add_systems(
        Startup,
        move |mut commands: Commands,
              mut images: ResMut<Assets<Image>>,
              mut meshes: ResMut<Assets<Mesh>>,
              mut materials: ResMut<Assets<StandardMaterial>>| {
            let target = images.add(Image::new_target_texture(
                W,
                H,
                bevy::render::render_resource::TextureFormat::Rgba8UnormSrgb,
                None,
            ));
            commands.spawn((
                Camera3d::default(),
                RenderTarget::Image(target.clone().into()),
                Tonemapping::None,
                Projection::Perspective(PerspectiveProjection {
                    fov: cam.fov_deg.to_radians(),
                    near: 0.25,
                    ..default()
                }),
                Transform::from_translation(Vec3::from_array(cam.position.to_array()))
                    .looking_at(Vec3::from_array(cam.look_at.to_array()), Vec3::Y),
                ForestCamera,
            ));
            commands.insert_resource(ShotTarget(target));
            if cube {
                commands.spawn((
                    Mesh3d(meshes.add(Cuboid::new(CUBE_SIZE, CUBE_SIZE, CUBE_SIZE))),
                    MeshMaterial3d(materials.add(StandardMaterial {
                        base_color: Color::srgb(1.0, 0.0, 0.0),
                        unlit: true,
                        ..default()
                    })),
                    Transform::from_xyz(CUBE[0], ground + CUBE_SIZE * 0.5, CUBE[2]),
                ));
            }
        },
    );
    app.world_mut().spawn(forest);
    let sink = captured.clone();
    app.add_systems(
        Update,
        move |mut commands: Commands, mut frame: Local<u32>, target: Option<Res<ShotTarget>>| {
            *frame += 1;
            // Let Bevy compile its pipelines first; then one screenshot.
            if *frame == 12
                && let Some(t) = target
            {
                let sink = sink.clone();
                commands.spawn(Screenshot::image(t.0.clone())).observe(
                    move |shot: On<ScreenshotCaptured>| {
                        if let Ok(mut s) = sink.lock() {
                            *s = Some(shot.image.clone());
                        }
                    },
                );
            }
        },
    );
    app.finish();
    app.cleanup();
    for _ in 0..200 {
        app.update();
        if captured.lock().map(|c| c.is_some()).unwrap_or(false) {
            break;
        }
    }
    let stats = app.world().resource::<ForestStats>().last();
    let img = captured
        .lock()
        .unwrap()
        .take()
        .expect("Bevy produced no screenshot in 200 frames");
    let (w, h) = (img.width(), img.height());
    let data = img.data.expect("screenshot data");
    let rgba = image::RgbaImage::from_raw(w, h, data).expect("RGBA8 screenshot");
    (image::DynamicImage::ImageRgba8(rgba).into_rgb8(), stats)
}

#[derive(Resource)]
struct ShotTarget(Handle<Image>);

/// The scene camera's view at the test's size (as Sylvan's renderer makes it).
fn scene_view(scene: &Scene) -> sylvan_render::frame::View {
    sylvan_render::frame::View {
        eye: scene.camera.position,
        target: scene.camera.look_at,
        fov_y: scene.camera.fov_deg.to_radians(),
        aspect: W as f32 / H as f32,
        near: 0.25,
        far: 5000.0,
    }
}

fn pixel_of(scene: &Scene, p: glam::Vec3) -> (u32, u32) {
    let view = scene_view(scene);
    let c = view.view_proj() * p.extend(1.0);
    let x = ((c.x / c.w * 0.5 + 0.5) * W as f32) as u32;
    let y = ((0.5 - c.y / c.w * 0.5) * H as f32) as u32;
    (x.min(W - 1), y.min(H - 1))
}

/// Whether the ray through pixel (x, y)'s centre meets the cube (slab test).
fn ray_hits_cube(scene: &Scene, x: u32, y: u32) -> bool {
    let view = scene_view(scene);
    let inv = view.view_proj().inverse();
    let ndc = glam::Vec2::new(
        (x as f32 + 0.5) / W as f32 * 2.0 - 1.0,
        1.0 - (y as f32 + 0.5) / H as f32 * 2.0,
    );
    let far = inv.project_point3(ndc.extend(0.5));
    let o = view.eye;
    let d = (far - o).normalize();
    let g = scene.terrain.height_at(CUBE[0], CUBE[2]);
    let h = CUBE_SIZE * 0.5;
    let min = glam::Vec3::new(CUBE[0] - h, g, CUBE[2] - h);
    let max = glam::Vec3::new(CUBE[0] + h, g + CUBE_SIZE, CUBE[2] + h);
    let (t1, t2) = ((min - o) / d, (max - o) / d);
    let (near, far) = (t1.min(t2).max_element(), t1.max(t2).min_element());
    near <= far && far > 0.0
}

fn is_red(p: &image::Rgb<u8>) -> bool {
    p[0] > 240 && p[1] < 15 && p[2] < 15
}

#[test]
fn bevy_draws_the_forest_as_sylvan_does_and_depth_tests_against_its_meshes() {
    let scene = scene();
    let technique = "geometry";
    let own = sylvan_frame(&scene, technique);
    let (plain, stats) = bevy_frame(&scene, technique, false);
    let (with_cube, _) = bevy_frame(&scene, technique, true);
    let out = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../out/tests");
    let _ = std::fs::create_dir_all(&out);
    let _ = own.save(out.join("bevy-sylvan-own.png"));
    let _ = plain.save(out.join("bevy-forest.png"));
    let _ = with_cube.save(out.join("bevy-forest-cube.png"));
    let flip = sylvan_eval::flip(&own, &plain).expect("flip").mean;
    eprintln!(
        "Bevy vs sylvan render ({technique}): ꟻLIP {flip:.4}; plugin CPU {:.2} ms/frame over {} frames, build {:.0} ms, technique {}",
        stats.cpu_ms, stats.frames, stats.build_ms, stats.technique
    );
    assert_eq!(stats.error, None, "the plugin reported an error");
    assert!(stats.frames > 0, "the plugin drew no frame");
    // Bevy's 4× MSAA resolves the trees' and the terrain's edges; Sylvan's own frame has
    // one sample: only edges may differ.
    assert!(
        flip < 0.04,
        "Bevy's frame differs from sylvan render: ꟻLIP {flip:.4}"
    );

    // The cube hides the tree behind it: that tree's crown centre is a tree in the plain
    // frame and the cube in the cube frame.
    let behind = pixel_of(
        &scene,
        glam::Vec3::new(50.0, scene.terrain.height_at(50.0, 72.0) + 3.0, 72.0),
    );
    let p = plain.get_pixel(behind.0, behind.1);
    let c = with_cube.get_pixel(behind.0, behind.1);
    eprintln!("behind-tree pixel {behind:?}: plain {p:?}, with cube {c:?}");
    let green = |p: &image::Rgb<u8>| p[1] > p[0] && p[1] >= p[2];
    assert!(
        green(p) && is_red(c),
        "the cube does not hide the tree behind it"
    );
    // The tree in front hides part of the cube: of the pixels whose ray meets the cube,
    // those not red show what the plain frame shows there (the front tree), and they exist.
    let (mut red, mut kept, mut inside) = (0, 0, 0);
    for (x, y, c) in with_cube.enumerate_pixels() {
        if !ray_hits_cube(&scene, x, y) {
            continue;
        }
        inside += 1;
        if is_red(c) {
            red += 1;
        } else if c
            .0
            .iter()
            .zip(plain.get_pixel(x, y).0)
            .all(|(a, b)| a.abs_diff(b) <= 3)
        {
            kept += 1;
        }
    }
    eprintln!(
        "cube silhouette: {red} red, {kept} drawn as without the cube (trees in front), of {inside}"
    );
    assert!(
        red > inside / 5,
        "the cube is hidden almost everywhere ({red} of {inside} red)"
    );
    assert!(
        kept > inside / 20,
        "no tree stands in front of the cube ({kept} of {inside} pixels)"
    );
    // Edge pixels (MSAA-resolved mixes of cube and tree) are neither.
    assert!(
        red + kept > inside * 9 / 10,
        "pixels neither cube nor tree: {} of {inside}",
        inside - red - kept
    );
}

#[test]
fn a_forest_described_from_the_bevy_side_is_seeded_over_its_terrain() {
    let forest =
        sylvan_bevy::ForestBuilder::new([1000.0, 800.0], [65, 65], |x, z| 0.01 * x + 0.02 * z)
            .species("pine", "pine", [14.0, 20.0], 100.0)
            .species("bush", "bush", [1.0, 2.0], 20.0)
            .build()
            .expect("forest");
    let scene = forest.scene();
    assert_eq!(scene.species.len(), 2);
    // 80 ha × 120 trees/ha, as the tiled placement expects it.
    let expected = scene.estimated_trees();
    assert!((8_000.0..11_500.0).contains(&expected), "{expected} trees");
    assert!((forest.height_at(500.0, 400.0) - 13.0).abs() < 0.01);
    let err = sylvan_bevy::ForestBuilder::new([10.0, 10.0], [2, 2], |_, _| 0.0)
        .build()
        .err()
        .expect("no species");
    assert!(err.to_string().contains("at least one species"), "{err}");
}
