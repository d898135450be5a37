//! `shadermap` drawn alone (BN12 §6, eq. 2–5 and 13–21): the terrain carries the forest as a
//! field from the measured tables, and shows BN12's effects on a flat stand seen from far:
//! radiance peaks at the backscatter direction in the principal plane (the hotspot) and the
//! forest is darker facing the sun than with the sun behind the viewer. Tiny targets.

mod common;

use common::gpu;
use glam::Vec3;
use sylvan_render::bake::CachePolicy;
use sylvan_render::{RenderOptions, Renderer};
use sylvan_scene::{Camera, Setting, TreeInstance};

fn stand() -> sylvan_scene::Scene {
    // A jittered 7 m grid of the 10 m test tree over 600 m: 0.02 trees/m².
    let mut trees = Vec::new();
    for i in 0..86 {
        for j in 0..86 {
            let h = ((i * 7919 + j * 104_729) % 1000) as f32 / 1000.0;
            trees.push(TreeInstance {
                position: Vec3::new(
                    3.0 + 7.0 * i as f32 + 2.0 * h,
                    0.0,
                    3.0 + 7.0 * j as f32 + 2.0 * (1.0 - h),
                ),
                species: 0,
                seed: 0,
                height: 10.0,
                rotation: h * std::f32::consts::TAU,
            });
        }
    }
    common::scene(
        common::terrain(600.0, 9, |_, _| 0.0),
        trees,
        Camera {
            position: Vec3::new(300.0, 100.0, 100.0),
            look_at: Vec3::new(300.0, 0.0, 300.0),
            fov_deg: 4.0,
        },
        common::sun(180.0, 45.0),
    )
}

fn settings() -> Vec<Setting> {
    [
        "zfield.order=3",
        "zfield.tile=32",
        "shadermap.theta=16",
        "shadermap.phi=5",
        "shadermap.lambda=3",
        "shadermap.patch_px=64",
    ]
    .iter()
    .map(|a| Setting::from_arg(a).unwrap())
    .collect()
}

#[test]
fn the_field_peaks_at_backscatter_and_is_darker_facing_the_sun() {
    let gpu = gpu();
    let scene = stand();
    let options = RenderOptions {
        width: 32,
        height: 32,
        technique: "shadermap".into(),
        settings: settings(),
        cache: CachePolicy::Off,
        ..Default::default()
    };
    let plants = vec![common::test_tree()];
    let mut r = Renderer::new(&gpu, &scene, &plants, &options).expect("renderer");
    let centre = Vec3::new(300.0, 0.0, 300.0);
    let l = scene.sun.direction();
    let across = Vec3::new(l.x, 0.0, l.z).normalize();
    let mut luma_at = |zenith_deg: f32, towards_sun: bool| {
        let t = zenith_deg.to_radians();
        let h = if towards_sun { across } else { -across };
        let camera = Camera {
            position: centre + 150.0 * (h * t.sin() + Vec3::Y * t.cos()),
            look_at: centre,
            fov_deg: 4.0,
        };
        r.render(&gpu, &camera, &scene.sun).expect("frame");
        let img =
            image::DynamicImage::ImageRgba8(r.read_image(&gpu).expect("readback")).into_rgb8();
        common::mean_luma(&img, 12, 12, 20, 20)
    };
    // The principal plane on the sun's side: θv from 33° to 57° around the sun's 45°.
    let sweep: Vec<(f32, f32)> = (33..=57)
        .map(|d| (d as f32, luma_at(d as f32, true)))
        .collect();
    let peak = sweep.iter().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    eprintln!("principal plane, sun side (θv, luma): {sweep:?}");
    assert!(
        (peak.0 - 45.0).abs() <= 2.0,
        "the field peaks at θv = {}°, the sun is at 45°: {sweep:?}",
        peak.0
    );
    // Facing the sun the visible trees show their shaded sides and the ground seen is in
    // their shadows.
    let (behind, facing) = (luma_at(60.0, true), luma_at(60.0, false));
    assert!(
        facing < 0.9 * behind,
        "60° with the sun behind: luma {behind}; facing it: {facing}"
    );
}

#[test]
fn without_trees_the_field_is_the_plain_terrain() {
    let gpu = gpu();
    // The stand's trees stay where they are (the tables are measured for them), the camera
    // looks at a corner of the terrain from which none is in view, shadows off: `geometry`
    // draws only the terrain there, and the field at density 0 must equal it.
    let mut scene = stand();
    scene
        .trees
        .retain(|t| t.position.x > 450.0 && t.position.z > 450.0);
    scene.camera = Camera {
        position: Vec3::new(300.0, 30.0, 300.0),
        look_at: Vec3::new(150.0, 0.0, 170.0),
        fov_deg: 50.0,
    };
    let base = RenderOptions {
        width: 48,
        height: 48,
        shadows: false,
        cache: CachePolicy::Off,
        ..Default::default()
    };
    let plants = vec![common::test_tree()];
    let mut field_settings = settings();
    field_settings.push(Setting::from_arg("shadermap.density_scale=0").unwrap());
    let frame = |options: RenderOptions| {
        let mut r = Renderer::new(&gpu, &scene, &plants, &options).expect("renderer");
        let stats = r.render(&gpu, &scene.camera, &scene.sun).expect("frame");
        let img =
            image::DynamicImage::ImageRgba8(r.read_image(&gpu).expect("readback")).into_rgb8();
        (img, stats)
    };
    let (field, _) = frame(RenderOptions {
        technique: "shadermap".into(),
        settings: field_settings,
        ..base.clone()
    });
    let (plain, stats) = frame(RenderOptions {
        technique: "geometry".into(),
        ..base
    });
    assert_eq!(
        stats.trees_drawn.values().sum::<u32>(),
        0,
        "no tree in view"
    );
    let worst = field
        .pixels()
        .zip(plain.pixels())
        .flat_map(|(a, b)| (0..3).map(move |c| (a[c] as i32 - b[c] as i32).abs()))
        .max()
        .unwrap();
    assert!(
        worst <= 1,
        "the bare field differs from the terrain by {worst}/255"
    );
}
