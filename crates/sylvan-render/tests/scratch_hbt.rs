mod common;
use glam::Vec3;
use sylvan_render::technique::hbt::{self, HbtParams};
/// The test tree with every leaf card turned to a random orientation about its centre, so the
/// crown looks alike from every side (the plain test tree's cards face only ±Y and ±Z).
fn isotropic_tree() -> sylvan_plant::Plant {
    let mut plant = common::test_tree();
    let mut state = 99u32;
    let mut rnd = move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1u32 << 24) as f32
    };
    let leaves = &mut plant.leaves;
    for quad in 0..leaves.positions.len() / 4 {
        let q = glam::Quat::from_euler(
            glam::EulerRot::YXZ,
            rnd() * std::f32::consts::TAU,
            rnd() * std::f32::consts::TAU,
            rnd() * std::f32::consts::TAU,
        );
        let vs = quad * 4..quad * 4 + 4;
        let centre = vs
            .clone()
            .map(|i| Vec3::from(leaves.positions[i]))
            .sum::<Vec3>()
            / 4.0;
        for i in vs {
            let p = Vec3::from(leaves.positions[i]) - centre;
            leaves.positions[i] = (centre + q * p).to_array();
            leaves.normals[i] = (q * Vec3::from(leaves.normals[i])).to_array();
        }
    }
    plant
}

#[test]
fn dump() {
    let gpu = common::gpu();
    let plant = if std::env::var("PINE").is_ok() {
        sylvan_plant::preset("pine").unwrap()
    } else {
        isotropic_tree()
    };
    let p = HbtParams {
        tile: 64,
        supersample: 2,
        shadow_resolution: 256,
        ..Default::default()
    };
    let b = hbt::bake::bake(&gpu, &plant, &p, |_, _| {}).unwrap();
    let n = b.tile;
    let l = b.lights();
    let mut img = image::RgbaImage::new(n * 8, n * 3);
    let pick = [
        (0usize, 0usize),
        (0, 1),
        (0, 2),
        (0, 4),
        (4, 0),
        (4, 4),
        (2, 2),
        (6, 6),
    ];
    for (k, &(v, li)) in pick.iter().enumerate() {
        for (row, data) in [
            &b.direct[v * l + li][0],
            &b.ambient[v][0],
            &b.ambient[b.views() + v][0],
        ]
        .iter()
        .enumerate()
        {
            for y in 0..n {
                for x in 0..n {
                    let i = ((y * n + x) * 4) as usize;
                    img.put_pixel(
                        k as u32 * n + x,
                        row as u32 * n + y,
                        image::Rgba([data[i], data[i + 1], data[i + 2], 255]),
                    );
                }
            }
        }
    }
    img.save("/tmp/hbt_tiles.png").unwrap();
    for v in 0..6 {
        let d = &b.direct[v * l][0];
        let a: f32 = d.chunks(4).map(|p| p[3] as f32 / 255.0).sum::<f32>() / (n * n) as f32;
        eprintln!("view {v} coverage {a}");
    }
}

fn render(
    gpu: &sylvan_gpu::Gpu,
    scene: &sylvan_scene::Scene,
    t: sylvan_render::TechniqueKind,
    hbt: HbtParams,
    spp: u32,
) -> image::RgbImage {
    let options = sylvan_render::RenderOptions {
        width: 160,
        height: 160,
        spp,
        technique: t,
        hbt,
        cache: sylvan_render::bake::CachePolicy::Off,
        ..Default::default()
    };
    let plants = vec![isotropic_tree()];
    let mut r = sylvan_render::Renderer::new(gpu, scene, &plants, &options).unwrap();
    r.render(gpu, &scene.camera, &scene.sun).unwrap();
    image::DynamicImage::ImageRgba8(r.read_image(gpu).unwrap()).into_rgb8()
}

#[test]
fn coverage() {
    let gpu = common::gpu();
    let trees = vec![sylvan_scene::TreeInstance {
        position: Vec3::new(60.0, 0.0, 60.0),
        species: 0,
        height: 10.0,
        rotation: 0.3,
    }];
    let camera = sylvan_scene::Camera {
        position: Vec3::new(60.0, 7.0, 30.0),
        look_at: Vec3::new(60.0, 7.0, 60.0),
        fov_deg: 30.0,
    };
    let mut scene = common::scene(
        common::terrain(120.0, 9, |_, _| -100.0),
        trees,
        camera,
        common::sun(0.0, 40.0),
    );
    scene.sky = sylvan_scene::Sky {
        zenith: [0.0; 3],
        horizon: [0.0; 3],
        ground: [0.0; 3],
    };
    let g = render(
        &gpu,
        &scene,
        sylvan_render::TechniqueKind::Geometry,
        HbtParams::default(),
        16,
    );
    g.save("/tmp/c_geo.png").unwrap();
    let lum =
        |im: &image::RgbImage| im.pixels().map(|p| p[1] as f32).sum::<f32>() / (160.0 * 160.0);
    eprintln!("geometry {}", lum(&g));
    for mw in [0.05f32, 0.45] {
        let h = render(
            &gpu,
            &scene,
            sylvan_render::TechniqueKind::Hbt,
            HbtParams {
                min_weight: mw,
                ..Default::default()
            },
            1,
        );
        h.save(format!("/tmp/c_hbt{mw}.png")).unwrap();
        eprintln!("hbt min weight {mw}: {}", lum(&h));
    }
}
