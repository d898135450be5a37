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

#[test]
fn the_field_is_where_the_trees_are() {
    // The stand's west half only (x < 300 m), seen from above across the edge: the field takes
    // the local density (`density.rs`), so over the bare half it equals the bare field
    // (`density_scale = 0`, itself the plain terrain: the test above) and over the forest it
    // does not. One density for the whole terrain fails the first, none fails the second.
    let gpu = gpu();
    let mut scene = stand();
    scene.trees.retain(|t| t.position.x < 300.0);
    scene.camera = Camera {
        position: Vec3::new(300.0, 400.0, 200.0),
        look_at: Vec3::new(300.0, 0.0, 300.0),
        fov_deg: 60.0,
    };
    let plants = vec![common::test_tree()];
    let frame = |extra: Option<&str>| {
        let mut settings = settings();
        settings.extend(extra.map(|a| Setting::from_arg(a).unwrap()));
        let options = RenderOptions {
            width: 48,
            height: 48,
            technique: "shadermap".into(),
            settings,
            shadows: false,
            cache: CachePolicy::Off,
            ..Default::default()
        };
        let mut r = Renderer::new(&gpu, &scene, &plants, &options).expect("renderer");
        r.render(&gpu, &scene.camera, &scene.sun).expect("frame");
        image::DynamicImage::ImageRgba8(r.read_image(&gpu).expect("readback")).into_rgb8()
    };
    let (forest, bare) = (frame(None), frame(Some("shadermap.density_scale=0")));
    // Per column quarter (the image's x runs along the world's x, one way or the other): the
    // largest and the mean per-channel difference.
    let quarter = |q: u32| {
        let (mut worst, mut sum, mut n) = (0i32, 0.0f64, 0.0f64);
        for y in 8..40 {
            for x in q * 12..q * 12 + 10 {
                let (a, b) = (forest.get_pixel(x + 1, y), bare.get_pixel(x + 1, y));
                for c in 0..3 {
                    let d = (a[c] as i32 - b[c] as i32).abs();
                    worst = worst.max(d);
                    sum += d as f64;
                    n += 1.0;
                }
            }
        }
        (worst, sum / n)
    };
    let (left, right) = (quarter(0), quarter(3));
    eprintln!("forest vs bare field (largest, mean per channel): left {left:?}, right {right:?}");
    let (bare_side, forest_side) = if left.1 < right.1 {
        (left, right)
    } else {
        (right, left)
    };
    assert!(
        bare_side.0 <= 1,
        "where no tree grows the field must be bare: {bare_side:?}"
    );
    assert!(
        forest_side.1 >= 8.0,
        "where the trees grow the field must show them: {forest_side:?}"
    );
}

/// The stand with species 1 (the same plant; `east_height` metres tall if given) in its east
/// half, seen from above across the edge.
fn halves_scene(east_height: Option<f32>) -> sylvan_scene::Scene {
    let mut scene = stand();
    for t in &mut scene.trees {
        if t.position.x >= 300.0 {
            t.species = 1;
            t.height = east_height.unwrap_or(t.height);
        }
    }
    scene.species.push(scene.species[0].clone());
    scene.camera = Camera {
        position: Vec3::new(300.0, 500.0, 290.0),
        look_at: Vec3::new(300.0, 0.0, 300.0),
        fov_deg: 40.0,
    };
    scene
}

/// The mean linear radiance of the left and right thirds of a 64² frame of `scene` drawn by
/// `technique` (no shadows, no cache), in `debug` view.
fn halves_means(
    gpu: &sylvan_gpu::Gpu,
    scene: &sylvan_scene::Scene,
    plants: &[sylvan_plant::Plant],
    technique: &str,
    debug: sylvan_render::DebugView,
) -> ([f32; 3], [f32; 3]) {
    let options = RenderOptions {
        width: 64,
        height: 64,
        technique: technique.into(),
        settings: settings(),
        shadows: false,
        cache: CachePolicy::Off,
        debug,
        ..Default::default()
    };
    let mut r = Renderer::new(gpu, scene, plants, &options).expect("renderer");
    r.render(gpu, &scene.camera, &scene.sun).expect("frame");
    let side = |x: u32| r.radiance_mean(gpu, [x, 8, 20, 48]).expect("radiance");
    (side(2), side(42))
}

#[test]
fn the_field_covers_the_ground_as_the_local_species_do() {
    // The stand with 10 m trees in its west half and 4 m ones (the same plant, species 1) in
    // its east half, seen from above across the edge: the tables are measured for the 50/50
    // mix, so with the summed density alone both halves would get the mix's coverage; with the
    // local crown areas (`density.rs`) each half's field coverage follows the drawn trees'.
    let gpu = gpu();
    let scene = halves_scene(Some(4.0));
    let plants = vec![common::test_tree(), common::test_tree()];
    let coverage = |technique: &str| {
        let (a, b) = halves_means(
            &gpu,
            &scene,
            &plants,
            technique,
            sylvan_render::DebugView::Coverage,
        );
        (a[0], b[0])
    };
    let (drawn, field) = (coverage("zfield"), coverage("shadermap"));
    eprintln!("covered share (left, right): drawn {drawn:?}, field {field:?}");
    let (tall, short) = if drawn.0 > drawn.1 { (0, 1) } else { (1, 0) };
    let pick = |v: (f32, f32), i: usize| if i == 0 { v.0 } else { v.1 };
    assert!(
        pick(drawn, tall) > 2.0 * pick(drawn, short),
        "the tall trees must cover more: {drawn:?}"
    );
    for i in [tall, short] {
        let (d, f) = (pick(drawn, i), pick(field, i));
        assert!(
            (f - d).abs() <= 0.2 * d + 0.01,
            "side {i}: the field covers {f}, the trees {d}"
        );
    }
}

#[test]
fn the_field_takes_the_local_species_colour() {
    // The stand with green trees in its west half and the same trees with red leaves (species
    // 1) in its east half, seen from above across the edge. The tables are measured for the
    // 50/50 mix, whose mean albedo ρ̄ is the same on both sides: with it alone both halves'
    // trees have one colour (the ground is the same too, so the red/green ratio of the halves
    // is equal). With the local species' albedo (`density.rs`) the east half is redder, as the
    // drawn trees are.
    let gpu = gpu();
    let scene = halves_scene(None);
    let mut red = common::test_tree();
    red.name = "test-tree-red".into();
    for c in &mut red.leaves.colors {
        *c = [0.4, 0.1, 0.05];
    }
    let plants = vec![common::test_tree(), red];
    let halves = |technique: &str| {
        let (a, b) = halves_means(
            &gpu,
            &scene,
            &plants,
            technique,
            sylvan_render::DebugView::None,
        );
        let ratio = |c: [f32; 3]| c[0] / c[1].max(1e-6);
        (ratio(a), ratio(b))
    };
    let (drawn, field) = (halves("zfield"), halves("shadermap"));
    eprintln!("red/green per half (left, right): drawn {drawn:?}, field {field:?}");
    let redder = |v: (f32, f32)| v.0.max(v.1) / v.0.min(v.1);
    assert!(redder(drawn) > 1.3, "the red trees must show: {drawn:?}");
    // The same half is the redder one, and by a like amount.
    assert_eq!(
        drawn.0 > drawn.1,
        field.0 > field.1,
        "{drawn:?} vs {field:?}"
    );
    let (d, f) = (redder(drawn).ln(), redder(field).ln());
    assert!(
        f >= 0.5 * d && f <= 1.5 * d,
        "the field's halves differ by {f:.3} in log red/green, the trees' by {d:.3}"
    );
}

/// The mean linear radiance over the central half of a 64² frame of the stand (or of
/// `trees`) drawn by the chain `zfield` to `s_max`, the field beyond, from `camera`, with
/// `extra` settings. Bakes are shared through `cache`.
fn chain_radiance(
    s_max: f32,
    trees: Option<&[TreeInstance]>,
    camera: &Camera,
    extra: &[&str],
    shadows: bool,
    cache: &std::path::Path,
) -> [f32; 3] {
    let mut scene = stand();
    if let Some(t) = trees {
        scene.trees = t.to_vec();
    }
    let view = ChainView {
        camera,
        shadows,
        debug: sylvan_render::DebugView::None,
    };
    chain_mean(&scene, s_max, &view, extra, cache)
}

/// How [`chain_mean`] looks at a scene.
struct ChainView<'a> {
    camera: &'a Camera,
    shadows: bool,
    debug: sylvan_render::DebugView,
}

/// [`chain_radiance`] of any `scene` (one test tree per species), in `view.debug`.
fn chain_mean(
    scene: &sylvan_scene::Scene,
    s_max: f32,
    view: &ChainView<'_>,
    extra: &[&str],
    cache: &std::path::Path,
) -> [f32; 3] {
    let gpu = gpu();
    let mut scene = scene.clone();
    scene.lod_chain = vec![format!("zfield:0-{s_max}"), format!("shadermap:{s_max}-")];
    let mut settings = settings();
    settings.extend(extra.iter().map(|a| Setting::from_arg(a).unwrap()));
    let options = RenderOptions {
        width: 64,
        height: 64,
        technique: "auto".into(),
        settings,
        shadows: view.shadows,
        cache: CachePolicy::Dir(cache.to_path_buf()),
        debug: view.debug,
        ..Default::default()
    };
    let plants = vec![common::test_tree(); scene.species.len()];
    let mut r = Renderer::new(&gpu, &scene, &plants, &options).expect("renderer");
    r.render(&gpu, view.camera, &scene.sun).expect("frame");
    r.radiance_mean(&gpu, [16, 16, 32, 32]).expect("radiance")
}

/// Pixels per metre at one metre of a 64-pixel-high frame `fov_deg` wide (as the renderer
/// computes it).
fn pixels_per_metre(fov_deg: f32) -> f32 {
    64.0 / (2.0 * (fov_deg.to_radians() * 0.5).tan())
}

fn temp_cache(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("sylvan-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A camera `s` metres from `target` at view zenith `zenith_deg` (on the side away from the
/// sun), `fov_deg` wide.
fn camera_at(target: Vec3, zenith_deg: f32, s: f32, fov_deg: f32) -> Camera {
    let t = zenith_deg.to_radians();
    Camera {
        position: target + s * Vec3::new(0.0, t.cos(), -t.sin()),
        look_at: target,
        fov_deg,
    }
}

/// The largest per-channel relative change from `b` to `a`.
fn step(a: [f32; 3], b: [f32; 3]) -> f32 {
    (0..3)
        .map(|c| (a[c] - b[c]).abs() / b[c].max(1e-6))
        .fold(0.0, f32::max)
}

#[test]
fn the_handover_to_the_field_is_continuous() {
    // BN12 §7 (plan test 12d): one view of one patch of the stand, 160 m away, drawn by chains
    // whose s_max puts the patch at 0.79/0.81 and 0.99/1.01 of it — across the start of the
    // trees' fade and across s_max itself: the patch's mean radiance changes by under 1 %.
    // With the hard switch (`shadermap.handover=false`, the negative control) the step at
    // s_max is larger than that.
    let cache = temp_cache("handover");
    // Steep and narrow, so the trees in the measured half of the frame lie within ±1 % of d.
    let d = 160.0;
    let camera = camera_at(Vec3::new(300.0, 0.0, 300.0), 30.0, d, 4.0);
    let at = |k: f32, extra: &[&str]| chain_radiance(d / k, None, &camera, extra, true, &cache);
    let fade_start = step(at(0.79, &[]), at(0.81, &[]));
    let at_s_max = step(at(0.99, &[]), at(1.01, &[]));
    let hard = ["shadermap.handover=false"];
    let hard_step = step(at(0.99, &hard), at(1.01, &hard));
    eprintln!(
        "largest per-channel change: 0.79→0.81 s_max {:.2} %, 0.99→1.01 s_max {:.2} %, hard switch {:.2} %",
        100.0 * fade_start,
        100.0 * at_s_max,
        100.0 * hard_step
    );
    let _ = std::fs::remove_dir_all(&cache);
    assert!(fade_start < 0.01, "0.79 → 0.81 s_max: {fade_start}");
    assert!(at_s_max < 0.01, "0.99 → 1.01 s_max: {at_s_max}");
    assert!(
        hard_step > 0.01,
        "the hard switch should step at s_max (the metric must see a pop): {hard_step}"
    );
}

/// One 10 m tree, and a camera 100 m from it at 70° from the zenith, `fov_deg` wide.
fn lone_tree(fov_deg: f32) -> ([TreeInstance; 1], Camera) {
    let tree = [TreeInstance {
        position: Vec3::new(300.0, 0.0, 300.0),
        species: 0,
        seed: 0,
        height: 10.0,
        rotation: 0.0,
    }];
    (
        tree,
        camera_at(Vec3::new(300.0, 5.0, 300.0), 70.0, 100.0, fov_deg),
    )
}

/// The channel where the tree (`near`) differs most from the bare ground (`gone`), and the
/// share of that difference `v` keeps: its coverage against the ground, in linear radiance.
fn coverage_share(near: [f32; 3], gone: [f32; 3]) -> (usize, impl Fn([f32; 3]) -> f32) {
    let c = (0..3)
        .max_by(|&a, &b| {
            (near[a] - gone[a])
                .abs()
                .total_cmp(&(near[b] - gone[b]).abs())
        })
        .unwrap();
    (c, move |v: [f32; 3]| (v[c] - gone[c]) / (near[c] - gone[c]))
}

#[test]
fn zfield_trees_fade_linearly_into_the_field() {
    // BN12 §7 (plan test 12f): a tree (its trunk base) at 0.9 s_max covers (1 − smoothstep(0.8, 1, 0.9)) = ½ of
    // what it covers nearer, in linear radiance against the bare ground, from one camera (the
    // chain's s_max moves). The field's density is 0 and ν is forced to 0, so neither the
    // ground nor the tree's lighting changes; no shadows.
    let cache = temp_cache("fade");
    let (tree, camera) = lone_tree(5.0);
    // The fade goes by the tree's own distance (its trunk base), as the chain's bands do.
    let d = camera.position.distance(tree[0].position);
    let extra = ["shadermap.density_scale=0", "shadermap.nu=0"];
    let at = |k: f32| chain_radiance(d / k, Some(&tree), &camera, &extra, false, &cache);
    let (near, faded, gone) = (at(0.5), at(0.9), at(1.2));
    let _ = std::fs::remove_dir_all(&cache);
    let (c, share_of) = coverage_share(near, gone);
    let share = share_of(faded);
    eprintln!("near {near:?}, at 0.9 s_max {faded:?}, beyond {gone:?}: coverage share {share:.4}");
    assert!(
        (near[c] - gone[c]).abs() > 0.2 * gone[c],
        "the tree must show against the ground: {near:?} vs {gone:?}"
    );
    assert!(
        (share - 0.5).abs() <= 0.02,
        "coverage share at 0.9 s_max: {share}"
    );
}

#[test]
fn a_tree_is_left_to_the_field_where_it_is_handover_px_tall() {
    // BN12 §4's "trees under 3 px are never drawn": with the field's start far beyond it, one
    // tree fades over [0.8, 1] of where it is `handover_px` tall — at 0.9 of that distance it
    // covers ½ of what it covers nearer, and beyond it nothing (the field's density is 0 and ν
    // is forced to 0, as in the test above). With `handover_px = 0` (the negative control) it is
    // drawn whole wherever the pixel rule would have dropped it.
    let cache = temp_cache("pixel-rule");
    let fov = 5.0;
    let (tree, camera) = lone_tree(fov);
    let d = camera.position.distance(tree[0].position);
    let s_max = 4.0 * d;
    // The tree ends at 10 m × ppm / px: at d / k for px = 10 ppm k / d.
    let px = |k: f32| 10.0 * pixels_per_metre(fov) * k / d;
    let at = |px: f32| {
        let extra = [
            "shadermap.density_scale=0".to_string(),
            "shadermap.nu=0".to_string(),
            format!("shadermap.handover_px={px}"),
        ];
        let extra: Vec<&str> = extra.iter().map(String::as_str).collect();
        chain_radiance(s_max, Some(&tree), &camera, &extra, false, &cache)
    };
    let (near, faded, gone, off) = (at(px(0.5)), at(px(0.9)), at(px(1.2)), at(0.0));
    let _ = std::fs::remove_dir_all(&cache);
    let (c, share) = coverage_share(near, gone);
    eprintln!(
        "near {near:?}, at 0.9 of its end {faded:?}, beyond {gone:?}, no pixel rule {off:?}: shares {:.4} / {:.4}",
        share(faded),
        share(off)
    );
    assert!(
        (near[c] - gone[c]).abs() > 0.2 * gone[c],
        "the tree must show against the ground: {near:?} vs {gone:?}"
    );
    assert!(
        (share(faded) - 0.5).abs() <= 0.02,
        "coverage share at 0.9 of its end: {}",
        share(faded)
    );
    assert!(
        share(off) > 0.98,
        "without the rule the tree is drawn whole: {}",
        share(off)
    );
}

#[test]
fn the_field_takes_each_species_share_from_its_own_end() {
    species_share_from_its_own_end(1);
}

#[test]
fn the_field_weighs_the_fourteenth_species_too() {
    // The same with the short trees as species 13 of 14: their weights are in the density
    // raster's sixth layer — a square texture of 6 layers, which wgpu's GL backend would make
    // a cube map sampled black (the field then pads it to 7).
    species_share_from_its_own_end(13);
}

/// [`the_field_takes_each_species_share_from_its_own_end`] with the short trees as species
/// `short` (the species before it present, without trees).
fn species_share_from_its_own_end(short: u32) {
    // A stand of 10 m trees and 6 m ones (the same plant, species 1) mixed at random, seen
    // 400 m away, the field's start far beyond: with the pixel rule set so the short trees end
    // at 320 m (`handover_px` ≈ 6.9 at this view) they are gone, and the field must cover the
    // ground with their share — `field_handover_at` weighs each species' own fade by its crown
    // area. The covered fraction (`--debug coverage`) stays within a third of what removing the
    // short trees costs (the negative control: the field taking nothing for them), and is
    // continuous where they start fading and where they end (under 1 % a step of 2 %).
    let cache = temp_cache(&format!("species-ends-{short}"));
    let mut scene = stand();
    for (i, t) in scene.trees.iter_mut().enumerate() {
        if (i * 2_654_435_761) % 1000 < 500 {
            t.species = short;
            t.height = 6.0;
        }
    }
    while scene.species.len() <= short as usize {
        scene.species.push(scene.species[0].clone());
    }
    // Wide enough for a few dozen trees in the measured half of the frame.
    let fov = 10.0;
    let d = 400.0;
    let camera = camera_at(Vec3::new(300.0, 0.0, 300.0), 30.0, d, fov);
    let view = ChainView {
        camera: &camera,
        shadows: false,
        debug: sylvan_render::DebugView::Coverage,
    };
    // The short trees end at 6 m × ppm / px: at d / k for px = 6 ppm k / d.
    let px = |k: f32| 6.0 * pixels_per_metre(fov) * k / d;
    let covered = |scene: &sylvan_scene::Scene, px: f32| {
        let setting = format!("shadermap.handover_px={px}");
        chain_mean(scene, 1000.0, &view, &[setting.as_str()], &cache)[0]
    };
    let all = covered(&scene, px(0.5));
    let handed = covered(&scene, px(1.25));
    let mut tall_only = scene.clone();
    tall_only.trees.retain(|t| t.species == 0);
    let control = covered(&tall_only, px(0.5));
    let steps = [(0.79, 0.81), (0.99, 1.01)].map(|(a, b)| {
        let (x, y) = (covered(&scene, px(a)), covered(&scene, px(b)));
        (x - y).abs() / y.max(1e-6)
    });
    let _ = std::fs::remove_dir_all(&cache);
    eprintln!(
        "covered: all drawn {all:.4}, short trees in the field {handed:.4}, short trees removed {control:.4}; steps {steps:?}"
    );
    assert!(
        all - control > 0.03,
        "the short trees must cover a visible share: {all} vs {control}"
    );
    assert!(
        (handed - all).abs() <= (all - control) / 3.0,
        "the field must take the short trees' share: {handed} (all drawn {all}, removed {control})"
    );
    for s in steps {
        assert!(
            s < 0.01,
            "the short trees' handover must be continuous: {steps:?}"
        );
    }
}

/// The field alone over the stand thinned to every other column of trees (along X: 14 m
/// apart), seen from straight above, in the coverage view: the mean covered share of each
/// 4-pixel column band of the frame's middle rows.
fn banded_columns(gpu: &sylvan_gpu::Gpu, cover: bool) -> Vec<f32> {
    let mut scene = stand();
    scene
        .trees
        .retain(|t| (t.position.x / 7.0).floor() as i32 % 2 == 0);
    scene.sky.ground_occlusion = cover;
    scene.camera = Camera {
        position: Vec3::new(300.0, 200.0, 299.0),
        look_at: Vec3::new(300.0, 0.0, 300.0),
        fov_deg: 20.0,
    };
    let options = RenderOptions {
        width: 64,
        height: 64,
        technique: "shadermap".into(),
        settings: settings(),
        shadows: false,
        cache: CachePolicy::Off,
        debug: sylvan_render::DebugView::Coverage,
        ..Default::default()
    };
    let plants = vec![common::test_tree()];
    let mut r = Renderer::new(gpu, &scene, &plants, &options).expect("renderer");
    r.render(gpu, &scene.camera, &scene.sun).expect("frame");
    (0..16)
        .map(|i| r.radiance_mean(gpu, [4 * i, 16, 4, 32]).expect("radiance")[0])
        .collect()
}

#[test]
fn the_fields_trees_lie_where_the_crowns_are() {
    // BN12 §4 and §7 ("Γ/A replacing Λ"), mean-preserving (the tree share × Γ/Γ̄): over every
    // other column of trees (14 m apart — finer than the density raster's 25 m cells, so the
    // field of the density alone is nearly even across them, and than Γ̄'s ±32 m support) the
    // field's covered share follows the crowns' cover from above (`world/cover.rs`, read at the
    // pixel's footprint), and its mean is the density's. Negative control: with the ground cover off
    // (`[sky] ground_occlusion = false`) the share is even.
    let gpu = gpu();
    let (with, without) = (banded_columns(&gpu, true), banded_columns(&gpu, false));
    let spread = |v: &[f32]| {
        let (lo, hi) = v
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
        hi - lo
    };
    let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len() as f32;
    eprintln!("covered per column band, with the cover {with:.3?}, without {without:.3?}");
    assert!(
        spread(&without) < 0.1,
        "the density alone is nearly even across the bands: {without:?}"
    );
    assert!(
        spread(&with) > 0.3,
        "the field's trees must follow the bands: {with:?}"
    );
    assert!(
        (mean(&with) - mean(&without)).abs() <= 0.1 * mean(&without),
        "the mean share stays the density's: {} vs {}",
        mean(&with),
        mean(&without)
    );
}
