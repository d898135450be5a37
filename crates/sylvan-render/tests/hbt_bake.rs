//! `hbt` (MNP01) bakes: the baked BTF holds lighting with self-shadowing, the reconstruction
//! weights are a partition of unity and the GPU's direction look-up and pair weights agree with
//! the CPU's, the level below gets its own BTFs, placements and
//! cube-maps, bakes are cached by their parameters, and species sharing a plant share images.

mod common;

use common::gpu;
use common::hbt::{HbtParams, isotropic_tree, params};
use glam::Vec3;
use sylvan_render::bake::Bake;
use sylvan_render::bake::CachePolicy;
use sylvan_render::bake::codec::Codec;
use sylvan_render::directions::{self, DIRECTIONS_WGSL, DirectionLut, DirectionSet};
use sylvan_render::technique::hbt::{self, HbtBake, HbtBaked};
use sylvan_scene::{Camera, TreeInstance};

fn srgb_to_linear(v: u8) -> f32 {
    let s = v as f32 / 255.0;
    if s <= 0.04045 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

/// Mean lit colour (luma of premultiplied colour / coverage) of rows `rows` of the finest mip
/// of one image, and its coverage.
fn mean_lit(b: &HbtBaked, image: &[Vec<u8>], rows: std::ops::Range<usize>) -> (f32, f32) {
    let n = b.tile as usize;
    let lin = srgb_to_linear;
    let (mut luma, mut cover) = (0.0, 0.0);
    for y in rows.clone() {
        for x in 0..n {
            let p = &image[0][(y * n + x) * 4..][..4];
            luma += 0.2126 * lin(p[0]) + 0.7152 * lin(p[1]) + 0.0722 * lin(p[2]);
            cover += p[3] as f32 / 255.0;
        }
    }
    (luma / cover.max(1e-6), cover / (rows.len() * n) as f32)
}

#[test]
fn baked_btf_is_lit_and_self_shadowed() {
    let gpu = gpu();
    let plant = isotropic_tree();
    let p = params();
    let start = std::time::Instant::now();
    let b = HbtBake::bake(&gpu, &plant, &p.bake(), &mut |_, _| {}).expect("bake");
    eprintln!(
        "test tree: {} + {} images of {}², {} bytes, baked in {:.0} ms",
        b.direct.len(),
        b.ambient.len(),
        b.tile,
        b.image_bytes().0,
        start.elapsed().as_secs_f64() * 1e3
    );
    // Samples 0..6 are +X, −X, +Y, −Y, +Z, −Z at every level.
    let lights = b.lights();
    let (view_pz, light_pz, light_nz) = (4, 4, 5);
    let n = b.tile as usize;
    let all = 0..n;
    let front = mean_lit(&b, &b.direct[view_pz * lights + light_pz], all.clone());
    let back = mean_lit(&b, &b.direct[view_pz * lights + light_nz], all.clone());
    eprintln!("seen from +Z: lit from the front {front:?}, from behind {back:?}");
    // Coverage does not depend on the light.
    assert!((front.1 - back.1).abs() < 0.01, "{front:?} {back:?}");
    assert!(front.1 > 0.1, "the tree is in the image");
    // Lit from behind, only transmission through shadowed leaves reaches the viewer. Measured
    // on lavapipe: front ≈ 0.10, back ≈ 0.025.
    assert!(
        back.0 < 0.5 * front.0,
        "back-lit {} must be much darker than front-lit {}",
        back.0,
        front.0
    );
    // Self-shadowing: seen from straight below and lit from straight above, only light
    // transmitted through the lowest leaves reaches the viewer, and it must first cross the
    // crown above them: under the middle of the crown (1.0–1.6 m from the axis: the trunk is
    // not in the way) there are far more leaves above than under its rim (2.2–3 m).
    let (view_ny, light_py) = (3, 2);
    let image = &b.direct[view_ny * lights + light_py];
    let frame = hbt::bake::view_frame(
        -Vec3::Y,
        Vec3::from(plant.bbox_min),
        Vec3::from(plant.bbox_max),
        b.tile,
    );
    let ring = |r0: f32, r1: f32| {
        let (mut sum, mut cover) = (0.0, 0.0);
        for y in 0..n {
            for x in 0..n {
                let p = frame.point((x as f32 + 0.5) / n as f32, (y as f32 + 0.5) / n as f32);
                let r = (p.x * p.x + p.z * p.z).sqrt();
                if (r0..r1).contains(&r) {
                    let t = &image[0][(y * n + x) * 4..][..4];
                    sum += srgb_to_linear(t[1]);
                    cover += t[3] as f32 / 255.0;
                }
            }
        }
        sum / cover.max(1e-6)
    };
    let (middle, rim) = (ring(1.0, 1.6), ring(2.2, 3.0));
    eprintln!(
        "seen from below, lit from above: green under the middle {middle}, under the rim {rim}"
    );
    // Measured on lavapipe: middle ≈ 0.015, rim ≈ 0.040 (without self-shadowing both would be
    // the unshadowed transmission, equal).
    assert!(
        middle < 0.6 * rim,
        "under the middle {middle} must be in the crown's shadow (rim {rim})"
    );
    // The encoded payload reads back identically.
    assert_eq!(HbtBaked::decode(&b.encode()).unwrap(), b);
}

/// xorshift64*: seeded uniform directions.
fn directions(seed: u64, n: usize) -> Vec<Vec3> {
    let mut s = seed;
    let mut f = move || {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        (s.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..n)
        .map(|_| {
            let z = 2.0 * f() - 1.0;
            let phi = std::f32::consts::TAU * f();
            let r = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

#[test]
fn reconstruction_weights_are_a_partition_of_unity() {
    for (vl, ll) in [(1, 1), (2, 1), (0, 3)] {
        let views = DirectionSet::new(vl).unwrap();
        let lights = DirectionSet::new(ll).unwrap();
        let (vd, ld) = (directions(7, 10_000), directions(11, 10_000));
        for (v, l) in vd.iter().zip(&ld) {
            let (_, vw) = views.nearest3(*v);
            let (_, lw) = lights.nearest3(*l);
            let w = hbt::reconstruction_weights(vw, lw, 0.05);
            let sum: f32 = w.iter().sum();
            assert!((sum - 1.0).abs() < 1e-5, "{v} {l}: {w:?}");
            assert!(w.iter().all(|&x| x == 0.0 || x >= 0.05), "{w:?}");
        }
    }
}

/// MNP01's 3×3 reconstruction, CPU and GPU: `DIRECTIONS_WGSL`'s `dir_lookup` (view and light)
/// and `dir_pair_weights`, run in a compute shader over 4,096 direction pairs on the adapter,
/// agree with `DirectionLut::lookup` and `directions::pair_weights` on the CPU: the same 3
/// samples (except at cell ties, where either cell is right) and the same 9 weights.
#[test]
fn gpu_reconstruction_agrees_with_the_cpu() {
    use wgpu::util::DeviceExt;
    let gpu = gpu();
    let set = DirectionSet::new(2).unwrap();
    let lut = DirectionLut::new(&set, DirectionLut::DEFAULT_RESOLUTION).unwrap();
    let n = 4096;
    let (vd, ld) = (directions(3, n), directions(5, n));
    // Scaled (the look-up normalises) and a min weight per pair, 0 to 0.3.
    let input: Vec<[f32; 4]> = (0..n)
        .flat_map(|i| {
            let m = 0.3 * (i % 7) as f32 / 6.0;
            [
                (vd[i] * 3.0).extend(m).to_array(),
                (ld[i] * 0.5).extend(0.0).to_array(),
            ]
        })
        .collect();
    const OUT: usize = 7;
    let source = format!(
        "{}{DIRECTIONS_WGSL}
@group(0) @binding(3) var<storage, read> input: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> output: array<vec4<f32>>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {{
    let i = id.x;
    if i >= arrayLength(&input) / 2u {{ return; }}
    let v = dir_lookup(input[2u * i].xyz);
    let l = dir_lookup(input[2u * i + 1u].xyz);
    let w = dir_pair_weights(v.weights, l.weights, input[2u * i].w);
    let o = {OUT}u * i;
    output[o] = vec4<f32>(vec3<f32>(v.indices), 0.0);
    output[o + 1u] = vec4<f32>(vec3<f32>(l.indices), 0.0);
    output[o + 2u] = vec4<f32>(v.weights, 0.0);
    output[o + 3u] = vec4<f32>(l.weights, 0.0);
    output[o + 4u] = vec4<f32>(w[0], w[1], w[2], w[3]);
    output[o + 5u] = vec4<f32>(w[4], w[5], w[6], w[7]);
    output[o + 6u] = vec4<f32>(w[8], 0.0, 0.0, 0.0);
}}
",
        DirectionLut::bindings_wgsl(0, 0)
    );
    let device = &gpu.device;
    let storage = |label: &str, bytes: &[u8], extra: wgpu::BufferUsages| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytes,
            usage: wgpu::BufferUsages::STORAGE | extra,
        })
    };
    let texels = storage("dir_texels", lut.as_bytes(), wgpu::BufferUsages::empty());
    let faces = storage(
        "dir_faces",
        bytemuck::cast_slice(&set.gpu_faces()),
        wgpu::BufferUsages::empty(),
    );
    let samples = storage(
        "dir_samples",
        bytemuck::cast_slice(&set.gpu_samples()),
        wgpu::BufferUsages::empty(),
    );
    let input_buf = storage(
        "input",
        bytemuck::cast_slice(&input),
        wgpu::BufferUsages::empty(),
    );
    let output = storage(
        "output",
        &vec![0u8; n * OUT * 16],
        wgpu::BufferUsages::COPY_SRC,
    );
    let module = sylvan_gpu::shader(&gpu, "reconstruction_test", &source);
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("reconstruction_test"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[&texels, &faces, &samples, &input_buf, &output]
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect::<Vec<_>>(),
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups((n as u32).div_ceil(64), 1, 1);
    }
    gpu.queue.submit([encoder.finish()]);
    let bytes = sylvan_gpu::read_buffer_bytes(&gpu, &output).unwrap();
    let out: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
    let (mut ties, mut compared) = (0, 0);
    for i in 0..n {
        let o = &out[OUT * i..OUT * (i + 1)];
        let (vi, vw) = lut.lookup(vd[i] * 3.0);
        let (li, lw) = lut.lookup(ld[i] * 0.5);
        let gpu_vi = [o[0][0], o[0][1], o[0][2]].map(|x| x as u32);
        let gpu_li = [o[1][0], o[1][1], o[1][2]].map(|x| x as u32);
        if gpu_vi != vi || gpu_li != li {
            // Only where a direction sits on a cell edge: the CPU's smallest weight is ~0.
            let edge = vw.iter().chain(&lw).fold(1.0f32, |a, &b| a.min(b));
            assert!(
                edge < 1e-4,
                "pair {i}: GPU {gpu_vi:?}/{gpu_li:?} CPU {vi:?}/{li:?}"
            );
            ties += 1;
            continue;
        }
        compared += 1;
        for k in 0..3 {
            assert!((o[2][k] - vw[k]).abs() < 1e-5, "pair {i} view weight {k}");
            assert!((o[3][k] - lw[k]).abs() < 1e-5, "pair {i} light weight {k}");
        }
        let gw = [
            o[4][0], o[4][1], o[4][2], o[4][3], o[5][0], o[5][1], o[5][2], o[5][3], o[6][0],
        ];
        // The GPU's own inputs, so the threshold cuts the same products.
        let cpu = directions::pair_weights(
            [o[2][0], o[2][1], o[2][2]],
            [o[3][0], o[3][1], o[3][2]],
            input[2 * i][3],
        );
        for k in 0..9 {
            assert!(
                (gw[k] - cpu[k]).abs() < 1e-5,
                "pair {i} weight {k}: GPU {gw:?} CPU {cpu:?}"
            );
        }
    }
    eprintln!("{compared} pairs agree, {ties} at cell ties");
    assert!(compared >= n * 99 / 100, "{ties} ties of {n}");
}

#[test]
fn the_level_below_gets_its_own_btfs_placements_and_cube_maps() {
    let gpu = gpu();
    let plant = sylvan_plant::preset("pine").unwrap();
    let branches = hbt::bake::main_branches(&plant);
    assert!(!branches.is_empty(), "the pine's root places main branches");
    let p = HbtParams {
        levels: 2,
        tile: 16,
        supersample: 2,
        shadow_resolution: 64,
        view_level: 0,
        light_level: 0,
        branch_view_level: 0,
        branch_light_level: 0,
        max_branch_objects: 4,
        cube_resolution: 4,
        ..Default::default()
    };
    let start = std::time::Instant::now();
    let b = HbtBake::bake(&gpu, &plant, &p.bake(), &mut |_, _| {}).expect("bake");
    let (tree_bytes, branch_bytes) = b.image_bytes();
    eprintln!(
        "pine, 2 levels (6 × 6 directions, 16²): {} objects for {} placements ({} distinct main branches), {tree_bytes} + {branch_bytes} image bytes, {} cube-map bytes, {:.0} ms",
        b.objects.len(),
        b.placements.len(),
        branches.len(),
        b.cubes.len(),
        start.elapsed().as_secs_f64() * 1e3
    );
    // At most 4 representatives, plus the rest (trunk and the leaves on it).
    assert!(
        b.objects.len() <= 5 && b.objects.len() >= 2,
        "{}",
        b.objects.len()
    );
    assert_eq!(
        b.objects.last().unwrap().object,
        hbt::bake::REST_OBJECT,
        "the rest comes last"
    );
    // Every main-branch placement of the root is drawn, plus the rest once.
    let main: u32 = branches.iter().map(|b| b.1).sum();
    assert_eq!(b.placements.len() as u32, main + 1);
    assert_eq!(
        b.objects.iter().map(|o| o.uses).sum::<u32>(),
        b.placements.len() as u32
    );
    let tree = Vec3::from(b.bbox_max) - Vec3::from(b.bbox_min);
    for o in &b.objects {
        // An object is no bigger than the tree, and is in its images (6 views × 6 lights).
        let size = Vec3::from(o.bbox_max) - Vec3::from(o.bbox_min);
        assert!(size.length() <= tree.length() * 1.001, "{size} vs {tree}");
        assert_eq!(o.direct.len(), 36);
        let cover = |img: &[Vec<u8>]| img[0].chunks(4).map(|t| t[3] as u32).sum::<u32>();
        let seen = (0..6).map(|v| cover(&o.direct[v * 6])).max().unwrap();
        assert!(seen > 0, "object {} is empty in every view", o.object);
        // Coverage does not depend on the light.
        for v in 0..6 {
            assert_eq!(cover(&o.direct[v * 6]), cover(&o.direct[v * 6 + 3]));
        }
    }
    // Placed objects stay inside the tree's box (a representative scaled to the branch it
    // stands for).
    for pl in &b.placements {
        let o = &b.objects[pl.object as usize];
        for k in 0..8 {
            let c = hbt::visibility::corner(Vec3::from(o.bbox_min), Vec3::from(o.bbox_max), k);
            let w = pl.affine().transform_point3(c);
            let (lo, hi) = (Vec3::from(b.bbox_min), Vec3::from(b.bbox_max));
            assert!(
                w.cmpge(lo - tree * 0.25).all() && w.cmple(hi + tree * 0.25).all(),
                "{w} outside {lo}..{hi}"
            );
        }
    }
    // The branch level's cube-maps: the rest of the tree hides part of every branch's sky.
    assert_eq!(b.cubes.len(), b.placements.len() * 8 * 6 * 16);
    let dirs = hbt::visibility::directions(4);
    let mean_sky: f32 = (0..b.placements.len())
        .flat_map(|p| (0..8).map(move |k| (p, k)))
        .map(|(p, k)| hbt::visibility::sky_transmittance(b.cube(p, k), &dirs))
        .sum::<f32>()
        / (b.placements.len() * 8) as f32;
    assert!(
        mean_sky > 0.2 && mean_sky < 0.98,
        "mean sky transmittance {mean_sky}"
    );
    assert_eq!(HbtBaked::decode(&b.encode()).unwrap(), b);
}

#[test]
fn cache_is_reused_and_keyed_by_the_bake_parameters() {
    use sylvan_render::bake::load_or_bake;
    let gpu = gpu();
    let dir = std::env::temp_dir().join(format!("sylvan-hbt-cache-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let policy = CachePolicy::Dir(dir.clone());
    let plant = common::test_tree();
    let p = HbtParams {
        tile: 16,
        supersample: 1,
        shadow_resolution: 64,
        view_level: 0,
        light_level: 0,
        ..Default::default()
    };
    let (a, first) =
        load_or_bake::<HbtBake>(&gpu, &plant, &p.bake(), &policy, &mut |_, _| {}).unwrap();
    let (b, second) =
        load_or_bake::<HbtBake>(&gpu, &plant, &p.bake(), &policy, &mut |_, _| {}).unwrap();
    assert!(!first.from_cache && second.from_cache);
    assert_eq!(a, b);
    // A draw-only parameter keeps the file; a bake parameter makes a new one.
    let drawn = HbtParams {
        min_weight: 0.2,
        projection: hbt::HbtProjection::Cross,
        ..p.clone()
    };
    let (_, r) =
        load_or_bake::<HbtBake>(&gpu, &plant, &drawn.bake(), &policy, &mut |_, _| {}).unwrap();
    assert!(r.from_cache);
    let finer = HbtParams {
        shadow_resolution: 128,
        ..p
    };
    let (_, r) =
        load_or_bake::<HbtBake>(&gpu, &plant, &finer.bake(), &policy, &mut |_, _| {}).unwrap();
    assert!(!r.from_cache);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn species_sharing_a_plant_share_its_images() {
    let gpu = gpu();
    let trees = vec![TreeInstance {
        position: Vec3::new(30.0, 0.0, 30.0),
        species: 0,
        seed: 0,
        height: 10.0,
        rotation: 0.0,
    }];
    let camera = Camera {
        position: Vec3::new(30.0, 5.0, 10.0),
        look_at: Vec3::new(30.0, 5.0, 30.0),
        fov_deg: 40.0,
    };
    let one = common::scene(
        common::terrain(60.0, 9, |_, _| 0.0),
        trees,
        camera,
        common::sun(140.0, 35.0),
    );
    let mut two = one.clone();
    two.species.push(two.species[0].clone());
    let options = sylvan_render::RenderOptions {
        width: 64,
        height: 64,
        technique: "hbt".into(),
        settings: HbtParams {
            view_level: 0,
            light_level: 0,
            tile: 16,
            ..Default::default()
        }
        .settings(),
        cache: CachePolicy::Off,
        ..Default::default()
    };
    let bytes = |scene: &sylvan_scene::Scene| {
        let plants = vec![common::test_tree(); scene.species.len()];
        let mut r = sylvan_render::Renderer::new(&gpu, scene, &plants, &options).unwrap();
        r.render(&gpu, &scene.camera, &scene.sun)
            .unwrap()
            .asset_bytes
    };
    let (a, b) = (bytes(&one), bytes(&two));
    // Only the second species' 64-byte record differs.
    assert!(
        b - a < 1024,
        "one species {a} bytes, two of the same plant {b}"
    );
}
