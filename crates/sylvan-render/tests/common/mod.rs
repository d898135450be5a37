//! Fixtures for render tests: a tiny test tree, flat or tilted terrains, and a GPU that fails
//! loudly (with the install hint) when no adapter exists.

#![allow(dead_code)]

pub mod hbt;

use glam::Vec3;
use sylvan_gpu::Gpu;
use sylvan_plant::{LeafTexture, Mesh, Plant};
use sylvan_render::{RenderOptions, Renderer};
use sylvan_scene::{Camera, Fog, PlantSource, Scene, Sky, Species, Sun, Terrain, TreeInstance};

/// Opens the GPU or fails the test with the message that says what to install.
pub fn gpu() -> Gpu {
    match Gpu::new() {
        Ok(g) => g,
        Err(e) => panic!("this test needs a GPU adapter: {e}"),
    }
}

fn push_quad(m: &mut Mesh, corners: [Vec3; 4], normal: Vec3, color: [f32; 3]) {
    let base = m.positions.len() as u32;
    for (c, uv) in corners
        .iter()
        .zip([[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]])
    {
        m.positions.push(c.to_array());
        m.normals.push(normal.to_array());
        m.uvs.push(uv);
        m.colors.push(color);
    }
    m.indices
        .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
}

/// A 10 m test tree: a square trunk and a dense crown of horizontal and vertical leaf cards
/// (a ball of radius 3 m centred 7 m up). Deterministic.
pub fn test_tree() -> Plant {
    let mut wood = Mesh::default();
    let (w, h) = (0.2, 8.0);
    let bark = [0.25, 0.17, 0.1];
    for (n, a, b) in [
        (Vec3::Z, Vec3::new(-w, 0.0, w), Vec3::new(w, 0.0, w)),
        (Vec3::X, Vec3::new(w, 0.0, w), Vec3::new(w, 0.0, -w)),
        (Vec3::NEG_Z, Vec3::new(w, 0.0, -w), Vec3::new(-w, 0.0, -w)),
        (Vec3::NEG_X, Vec3::new(-w, 0.0, -w), Vec3::new(-w, 0.0, w)),
    ] {
        push_quad(&mut wood, [a, b, b + Vec3::Y * h, a + Vec3::Y * h], n, bark);
    }
    let mut leaves = Mesh::default();
    let mut state = 12345u32;
    let mut rnd = || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1u32 << 24) as f32
    };
    let centre = Vec3::new(0.0, 7.0, 0.0);
    for _ in 0..600 {
        let p = Vec3::new(rnd() * 2.0 - 1.0, rnd() * 2.0 - 1.0, rnd() * 2.0 - 1.0);
        if p.length() > 1.0 {
            continue;
        }
        let c = centre + p * 3.0;
        let s = 0.35;
        let green = [0.12, 0.3, 0.06];
        if rnd() < 0.5 {
            push_quad(
                &mut leaves,
                [
                    c + Vec3::new(-s, 0.0, s),
                    c + Vec3::new(s, 0.0, s),
                    c + Vec3::new(s, 0.0, -s),
                    c + Vec3::new(-s, 0.0, -s),
                ],
                Vec3::Y,
                green,
            );
        } else {
            push_quad(
                &mut leaves,
                [
                    c + Vec3::new(-s, -s, 0.0),
                    c + Vec3::new(s, -s, 0.0),
                    c + Vec3::new(s, s, 0.0),
                    c + Vec3::new(-s, s, 0.0),
                ],
                Vec3::Z,
                green,
            );
        }
    }
    Plant {
        name: "test-tree".into(),
        wood,
        leaves,
        // An opaque disc.
        leaf_texture: leaf_texture(|x, y| {
            let (dx, dy) = (x as f32 - 15.5, y as f32 - 15.5);
            dx * dx + dy * dy < 15.0 * 15.0
        }),
        bbox_min: [-3.0, 0.0, -3.0],
        bbox_max: [3.0, 10.0, 3.0],
        hierarchy: Default::default(),
        instancing: Default::default(),
        internodes: 1,
        leaf_count: 0,
        ..Default::default()
    }
}

/// A 32² leaf texture, opaque (a pale green) where `opaque(x, y)`, transparent elsewhere.
fn leaf_texture(opaque: impl Fn(u32, u32) -> bool) -> LeafTexture {
    let n = 32u32;
    let mut rgba = vec![0u8; (n * n * 4) as usize];
    for y in 0..n {
        for x in 0..n {
            if opaque(x, y) {
                rgba[((y * n + x) * 4) as usize..][..4].copy_from_slice(&[200, 230, 180, 255]);
            }
        }
    }
    LeafTexture {
        width: n,
        height: n,
        rgba,
    }
}

/// A 7 m "veil": one horizontal 6 m leaf card 7 m up and nothing else, its texture opaque on
/// one texel of every 2 × 2 (a quarter of it), so any image of it is a quarter opaque.
pub fn veil_plant() -> Plant {
    let mut leaves = Mesh::default();
    let (s, y) = (3.0, 7.0);
    push_quad(
        &mut leaves,
        [
            Vec3::new(-s, y, s),
            Vec3::new(s, y, s),
            Vec3::new(s, y, -s),
            Vec3::new(-s, y, -s),
        ],
        Vec3::Y,
        [0.12, 0.3, 0.06],
    );
    Plant {
        name: "veil".into(),
        leaves,
        leaf_texture: leaf_texture(|x, y| x % 2 == 0 && y % 2 == 0),
        bbox_min: [-3.0, 0.0, -3.0],
        bbox_max: [3.0, 7.0, 3.0],
        internodes: 1,
        ..Default::default()
    }
}

/// A terrain of `size` metres with heights from `f(x, z)`.
pub fn terrain(size: f32, res: u32, f: impl Fn(f32, f32) -> f32) -> Terrain {
    let mut heights = Vec::with_capacity((res * res) as usize);
    for r in 0..res {
        for c in 0..res {
            let x = size * c as f32 / (res - 1) as f32;
            let z = size * r as f32 / (res - 1) as f32;
            heights.push(f(x, z));
        }
    }
    Terrain {
        size: [size, size],
        resolution: [res, res],
        heights,
    }
}

/// A scene over `terrain` with `trees` of the test tree, seen from `camera`.
pub fn scene(terrain: Terrain, mut trees: Vec<TreeInstance>, camera: Camera, sun: Sun) -> Scene {
    for (i, t) in trees.iter_mut().enumerate() {
        t.seed = i as u32;
    }
    Scene {
        terrain,
        species: vec![Species {
            name: "test".into(),
            plant: PlantSource::Preset("test".into()),
            height_m: [10.0, 10.0],
        }],
        trees,
        seeded: None,
        world: Default::default(),
        sun,
        sky: Sky {
            zenith: [0.3, 0.5, 0.95],
            horizon: [0.78, 0.85, 0.95],
            ground: [0.24, 0.23, 0.15],
            ..Sky::default()
        },
        fog: Fog {
            half_distance_m: 0.0,
        },
        camera,
        lod_chain: Vec::new(),
        lod_bands: Vec::new(),
        technique_params: Vec::new(),
        source: None,
    }
}

/// A sun at `azimuth`, `elevation` degrees with the default colour.
pub fn sun(azimuth_deg: f32, elevation_deg: f32) -> Sun {
    Sun {
        azimuth_deg,
        elevation_deg,
        color: [3.0, 2.85, 2.6],
    }
}

/// Renders `scene` from its camera under `sun` at `size`² with `spp`.
pub fn render(gpu: &Gpu, scene: &Scene, sun: &Sun, size: u32, spp: u32) -> image::RgbImage {
    let plants = vec![test_tree(); scene.species.len()];
    let options = RenderOptions {
        width: size,
        height: size,
        spp,
        ..Default::default()
    };
    let mut r = Renderer::new(gpu, scene, &plants, &options).expect("renderer");
    r.render(gpu, &scene.camera, sun).expect("frame");
    image::DynamicImage::ImageRgba8(r.read_image(gpu).expect("readback")).into_rgb8()
}

/// One frame of `scene` (its camera and sun) with `plants` and `options`: the image, and the
/// renderer for its statistics.
pub fn render_with_options(
    gpu: &Gpu,
    scene: &Scene,
    plants: &[Plant],
    options: &RenderOptions,
) -> (image::RgbImage, Renderer) {
    let mut r = Renderer::new(gpu, scene, plants, options).expect("renderer");
    r.render(gpu, &scene.camera, &scene.sun).expect("frame");
    let img = image::DynamicImage::ImageRgba8(r.read_image(gpu).expect("readback")).into_rgb8();
    (img, r)
}

/// Mean luma (0–255) of the pixels in `[x0, x1) × [y0, y1)`.
pub fn mean_luma(img: &image::RgbImage, x0: u32, y0: u32, x1: u32, y1: u32) -> f32 {
    let mut sum = 0.0;
    for y in y0..y1 {
        for x in x0..x1 {
            let p = img.get_pixel(x, y);
            sum += 0.2126 * p[0] as f32 + 0.7152 * p[1] as f32 + 0.0722 * p[2] as f32;
        }
    }
    sum / ((x1 - x0) * (y1 - y0)) as f32
}

/// Camera straight above `(x, z)` at `height`, image up = +Z... (looking down, -Y).
pub fn top_down(x: f32, z: f32, height: f32, fov_deg: f32) -> Camera {
    // A tiny offset in Z keeps look_at_rh well defined; `View` picks +Z as up when looking down.
    Camera {
        position: Vec3::new(x, height, z),
        look_at: Vec3::new(x, 0.0, z + 1e-3),
        fov_deg,
    }
}

/// Pixel (x, y) where world point `p` lands for `camera` on a `size`² image.
pub fn pixel_of(camera: &Camera, size: u32, p: Vec3) -> (u32, u32) {
    let view = sylvan_render::frame::View {
        eye: camera.position,
        target: camera.look_at,
        fov_y: camera.fov_deg.to_radians(),
        aspect: 1.0,
        near: 0.25,
        far: 5000.0,
    };
    let clip = view.view_proj() * p.extend(1.0);
    let ndc = clip.truncate() / clip.w;
    let x = ((ndc.x * 0.5 + 0.5) * size as f32) as u32;
    let y = ((0.5 - ndc.y * 0.5) * size as f32) as u32;
    (x.min(size - 1), y.min(size - 1))
}

/// Mean luma of a `(2r+1)²` window around the pixel where `p` lands.
pub fn luma_at(img: &image::RgbImage, camera: &Camera, p: Vec3, r: u32) -> f32 {
    let (x, y) = pixel_of(camera, img.width(), p);
    let (x0, y0) = (x.saturating_sub(r), y.saturating_sub(r));
    mean_luma(
        img,
        x0,
        y0,
        (x + r + 1).min(img.width()),
        (y + r + 1).min(img.height()),
    )
}
