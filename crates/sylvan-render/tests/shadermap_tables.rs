//! `shadermap`'s ground tables (BN12 §6, eq. 14–15, 18–19), measured by rendering z-field
//! forest patches: on opaque spheres (a synthetic z-field of known shape) the top view sees
//! `1 − λA` of the ground, looking into the sun sees less lit ground than with the sun behind
//! (the hotspot), view and light swap without changing 𝔾, everything falls with density and
//! zenith, and 𝔻 is the cosine-weighted diagonal; on a real plant's bake the tables are cached,
//! read back equal, and re-measured when the file is damaged. Tiny tables; lavapipe and GL.

mod common;

use common::gpu;
use glam::Vec3;
use sylvan_render::bake::CachePolicy;
use sylvan_render::bake::image::TileLevel;
use sylvan_render::directions::HemiGrid;
use sylvan_render::technique::shadermap::{
    ForestMix, MixSpecies, ShaderMapBakeParams, ShaderMapTables, load_or_measure, measure_tables,
};
use sylvan_render::technique::zfield::{
    ZFieldBake, ZFieldBakeParams, ZFieldBaked, ZFieldDrawParams, ZView,
};

fn zfield_params() -> ZFieldBakeParams {
    ZFieldBakeParams {
        order: 3,
        tile: 32,
        supersample: 2,
        ..Default::default()
    }
}

fn small_tables() -> ShaderMapBakeParams {
    ShaderMapBakeParams {
        theta: 5,
        phi: 3,
        lambda: 4,
        patch_radii: 12,
        patch_px: 128,
        seed: 3,
    }
}

/// Every view an opaque disk of `fraction` of the frame's half side about its centre: an
/// opaque sphere of radius `fraction · radius` at the frame centre.
fn sphere_asset(fraction: f32) -> ZFieldBaked {
    let p = zfield_params();
    let grid = HemiGrid::new(p.order).unwrap();
    let tree = common::test_tree();
    let (min, max) = (Vec3::from(tree.bbox_min), Vec3::from(tree.bbox_max));
    let sizes: Vec<usize> = (0..=p.tile.ilog2())
        .map(|m| (p.tile >> m) as usize)
        .collect();
    let alpha = |n: usize| -> Vec<u8> {
        let mut a = vec![0u8; n * n];
        let r = fraction * n as f32 * 0.5;
        // 4×4 samples per texel: the disk's coverage, as a box-filtered mip would hold it.
        for y in 0..n {
            for x in 0..n {
                let mut inside = 0;
                for sy in 0..4 {
                    for sx in 0..4 {
                        let dx = x as f32 + (sx as f32 + 0.5) / 4.0 - n as f32 * 0.5;
                        let dy = y as f32 + (sy as f32 + 0.5) / 4.0 - n as f32 * 0.5;
                        inside += (dx * dx + dy * dy <= r * r) as u32;
                    }
                }
                a[y * n + x] = (inside * 255 / 16) as u8;
            }
        }
        a
    };
    let view = ZView {
        levels: sizes
            .iter()
            .map(|&n| TileLevel {
                size: n as u32,
                color: alpha(n)
                    .iter()
                    .flat_map(|&a| [a / 3, a / 2, a / 4, a])
                    .collect(),
                normal: [128, 255, 128, 128].repeat(n * n),
            })
            .collect(),
        zfield: sizes
            .iter()
            .map(|&n| {
                alpha(n)
                    .iter()
                    .flat_map(|&a| [a / 4, (a as u16 * 3 / 4) as u8, a, a])
                    .collect()
            })
            .collect(),
    };
    ZFieldBaked {
        order: p.order,
        tile: p.tile,
        centre: ((min + max) * 0.5).to_array(),
        radius: (max - min).length() * 0.5,
        views: vec![view; grid.len()],
    }
}

fn mix<'a>(
    plant: &'a sylvan_plant::Plant,
    z: &'a ZFieldBaked,
    radius_m: f32,
    lambda_max: f32,
) -> ForestMix<'a> {
    ForestMix {
        species: vec![MixSpecies {
            plant,
            zfield: z,
            weight: 1.0,
            height_m: [plant.bbox_max[1], plant.bbox_max[1]],
        }],
        zfield_bake: zfield_params(),
        zfield_draw: ZFieldDrawParams::default(),
        radius_m,
        lambda_max,
    }
}

/// Ground fraction visible at (λ node, θv, θl, φ) nodes.
fn g(t: &ShaderMapTables, l: usize, v: usize, s: usize, m: usize) -> f32 {
    t.g_node(l, v, s, m)
}

#[test]
fn opaque_spheres_give_the_analytic_top_view_and_a_hotspot() {
    let gpu = gpu();
    let tree = common::test_tree();
    let z = sphere_asset(0.5);
    let sphere_r = 0.5 * z.radius;
    // Pattern radius over two sphere radii: crowns never overlap, so from straight above
    // the ground seen is exactly 1 − λA.
    let spacing = 2.2 * sphere_r;
    let forest = mix(&tree, &z, spacing, 1.0);
    let p = small_tables();
    let t = measure_tables(&gpu, &forest, &p, &mut |_, _| {}).unwrap();
    t.check().unwrap();
    let disk = std::f32::consts::PI * sphere_r * sphere_r;
    assert!(
        (t.crown_area_m2 - disk).abs() < 0.03 * disk,
        "crown area {} m², the sphere's disk {disk} m²",
        t.crown_area_m2
    );
    // A sphere's crown is as tall as it is wide: h = 2 within the leaf mesh's extent.
    let (nt, np, nl) = (t.theta as usize, t.phi as usize, t.lambdas.len());
    for l in 0..nl {
        let expected = 1.0 - t.lambdas[l] * disk;
        let got = t.gd_node(l, 0);
        assert!(
            (got - expected).abs() < 0.015,
            "λ {:.4}/m²: top view sees {got}, 1 − λA = {expected}",
            t.lambdas[l]
        );
        // Falls with zenith; 90° sees no ground through trees.
        for v in 1..nt {
            assert!(
                t.gd_node(l, v) <= t.gd_node(l, v - 1) + 0.005,
                "λ node {l}: Gd rises from θ node {} to {v}: {:?}",
                v - 1,
                &t.gd[l * nt..(l + 1) * nt]
            );
        }
        assert_eq!(t.gd_node(l, nt - 1), if l == 0 { 1.0 } else { 0.0 });
        // Swapping view and light keeps 𝔾 (the patch is isotropic; a few % of noise).
        for v in 0..nt - 1 {
            for s in 0..nt - 1 {
                for m in 0..np {
                    let (a, b) = (g(&t, l, v, s, m), g(&t, l, s, v, m));
                    assert!(
                        (a - b).abs() < 0.03,
                        "λ node {l} θ nodes {v}/{s} φ node {m}: {a} vs swapped {b}"
                    );
                    assert!(a <= t.gd_node(l, v).min(t.gd_node(l, s)) + 1e-6);
                }
            }
        }
    }
    for l in 1..nl {
        // Denser forests hide more ground, at every zenith.
        for v in 0..nt - 1 {
            assert!(
                t.gd_node(l, v) < t.gd_node(l - 1, v),
                "λ node {l} θ node {v}"
            );
        }
        // The hotspot: with the sun behind the viewer (φ = 0) the ground seen is lit where it
        // is seen; looking into the sun (φ = 180°) much of it is in shadow.
        let v = nt / 2;
        let (behind, facing) = (g(&t, l, v, v, 0), g(&t, l, v, v, np - 1));
        assert_eq!(behind, t.gd_node(l, v));
        assert!(
            facing < 0.8 * behind,
            "λ node {l}: lit ground seen {behind} with the sun behind, {facing} facing it"
        );
        // 𝔻 is the cosine-weighted diagonal: 1 without trees, falling with density, between
        // the top view's and the grazing views'.
        assert!(t.d[l] < t.d[l - 1] && t.d[l] < t.gd_node(l, 0) && t.d[l] > 0.0);
        assert!((t.d[l] - t.integrate_d(l, 256)).abs() < 2e-3);
    }
    assert_eq!(t.d[0], 1.0);
    // 𝕋 with zfield's default lighting (τ = 2, the phase half-way to the leaf response at
    // the baked normal, here straight up: up to (1 + 1/0.34)/2 ≈ 1.97 under a zenith sun): at
    // the hotspot every tree point seen is lit from its own side; facing the sun the light
    // crosses the crown first.
    for l in 1..nl {
        for v in 0..nt - 1 {
            let hot = t.t_node(l, v, v, 0);
            assert!(
                hot > 0.5 && hot <= 1.98,
                "λ node {l} θ node {v}: 𝕋 at the hotspot {hot}"
            );
        }
        let v = nt / 2;
        let (behind, facing) = (t.t_node(l, v, v, 0), t.t_node(l, v, v, np - 1));
        assert!(
            facing < 0.9 * behind,
            "λ node {l}: 𝕋 {behind} with the sun behind, {facing} facing it"
        );
        // 𝔼: δ = 1 on these crowns, so it is the cylindrical hole alone, below 1 and falling
        // with density.
        for v in 0..nt {
            let e = t.e_node(l, v);
            assert!(e > 0.3 && e < 1.0, "λ node {l} θ node {v}: 𝔼 {e}");
            if l > 1 {
                assert!(
                    e < t.e_node(l - 1, v) + 0.01,
                    "λ node {l} θ node {v}: 𝔼 rises"
                );
            }
        }
    }
    // Without extinction and with the isotropic phase (BN12's own model), a tree point is lit
    // unless another tree shades it: 1 at the hotspot, and from straight above with the sun
    // straight above.
    let bn12 = ForestMix {
        zfield_draw: ZFieldDrawParams {
            tau: 0.0,
            normal_weight: 0.0,
            ..ZFieldDrawParams::default()
        },
        ..mix(&tree, &z, spacing, 1.0)
    };
    let u = measure_tables(&gpu, &bn12, &p, &mut |_, _| {}).unwrap();
    assert_eq!(u.g, t.g, "𝔾 does not depend on the trees' lighting");
    for l in 1..nl {
        for v in 0..nt - 1 {
            let hot = u.t_node(l, v, v, 0);
            assert!((hot - 1.0).abs() < 0.01, "λ node {l} θ node {v}: 𝕋 {hot}");
        }
        // Away from the hotspot some points seen are in other trees' shadows (most with the
        // sun to the side: BN12's model lights a point where the light enters its crown).
        let side = u.t_node(l, nt - 2, nt - 2, np / 2);
        assert!(
            side < 0.95,
            "λ node {l}: 𝕋 at 67.5° with the sun to the side {side}"
        );
    }
}

#[test]
fn tables_of_a_real_plant_are_cached_and_remeasured_when_damaged() {
    let gpu = gpu();
    let tree = common::test_tree();
    let zp = zfield_params();
    let (z, _) = sylvan_render::bake::load_or_bake::<ZFieldBake>(
        &gpu,
        &tree,
        &zp,
        &CachePolicy::Off,
        &mut |_, _| {},
    )
    .unwrap();
    let dir = std::env::temp_dir().join(format!("sylvan-shadermap-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let policy = CachePolicy::Dir(dir.clone());
    let forest = mix(&tree, &z, 7.0, 0.01);
    let p = small_tables();
    let (first, report) = load_or_measure(&gpu, &forest, &p, &policy, &mut |_, _| {}).unwrap();
    assert!(!report.from_cache);
    let path = report.path.clone().unwrap();
    assert!(
        path.file_name()
            .unwrap()
            .to_str()
            .unwrap()
            .contains("-shadermap-"),
        "{path:?}"
    );
    let (again, report) = load_or_measure(&gpu, &forest, &p, &policy, &mut |_, _| {}).unwrap();
    assert!(report.from_cache);
    assert_eq!(again, first);
    // The leafy test tree hides some ground, and more with density.
    let nl = first.lambdas.len();
    assert!(first.gd_node(nl - 1, 0) < 0.95 && first.gd_node(nl - 1, 0) > 0.3);
    assert!(first.d[nl - 1] < first.d[1]);
    // A flipped byte in the payload: the checksum fails, the tables are measured again.
    let mut bytes = std::fs::read(&path).unwrap();
    let at = bytes.len() - 9;
    bytes[at] ^= 0x5a;
    std::fs::write(&path, &bytes).unwrap();
    let (third, report) = load_or_measure(&gpu, &forest, &p, &policy, &mut |_, _| {}).unwrap();
    assert!(!report.from_cache && report.stale.is_some());
    assert_eq!(third, first);
    // Another seed is another patch, so another file.
    let reseeded = ShaderMapBakeParams {
        seed: 4,
        ..p.clone()
    };
    let (_, report) = load_or_measure(&gpu, &forest, &reseeded, &policy, &mut |_, _| {}).unwrap();
    assert!(!report.from_cache);
    // Bad inputs are one-line errors, not panics.
    let bad = ShaderMapBakeParams {
        theta: 2,
        ..small_tables()
    };
    let e = load_or_measure(&gpu, &forest, &bad, &policy, &mut |_, _| {}).unwrap_err();
    assert!(e.to_string().contains("theta 2"), "{e}");
    let e = load_or_measure(
        &gpu,
        &mix(&tree, &z, 7.0, f32::NAN),
        &p,
        &policy,
        &mut |_, _| {},
    )
    .unwrap_err();
    assert!(e.to_string().contains("peak density"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_table_key_follows_what_was_measured() {
    use sylvan_render::technique::shadermap::measure::table_key;
    let tree = common::test_tree();
    let z = sphere_asset(0.5);
    let p = small_tables();
    let base = mix(&tree, &z, 7.0, 0.01);
    let key = table_key(&base, &p);
    let with = |draw: ZFieldDrawParams| {
        table_key(
            &ForestMix {
                zfield_draw: draw,
                ..mix(&tree, &z, 7.0, 0.01)
            },
            &p,
        )
    };
    let d = ZFieldDrawParams::default;
    // What the measurement lights the trees with re-measures ...
    for changed in [
        ZFieldDrawParams { tau: 1.0, ..d() },
        ZFieldDrawParams {
            normal_weight: 0.2,
            ..d()
        },
        ZFieldDrawParams {
            opacity_scaled_tau: false,
            ..d()
        },
    ] {
        assert_ne!(with(changed), key);
    }
    // ... what the shader applies at run time does not.
    for same in [
        ZFieldDrawParams { a1: 0.5, ..d() },
        ZFieldDrawParams { a2: 5.0, ..d() },
        ZFieldDrawParams {
            sun_scale: 1.0,
            ..d()
        },
        ZFieldDrawParams {
            sky_scale: 2.0,
            ..d()
        },
        ZFieldDrawParams {
            sky_normal_weight: 0.0,
            ..d()
        },
    ] {
        assert_eq!(with(same), key);
    }
    // The patch, the mix and the z-field bake all count.
    assert_ne!(
        table_key(
            &base,
            &ShaderMapBakeParams {
                seed: 9,
                ..p.clone()
            }
        ),
        key
    );
    assert_ne!(table_key(&mix(&tree, &z, 7.5, 0.01), &p), key);
    assert_ne!(table_key(&mix(&tree, &z, 7.0, 0.02), &p), key);
    let other = ForestMix {
        zfield_bake: ZFieldBakeParams {
            ao_density: 2.0,
            ..zfield_params()
        },
        ..mix(&tree, &z, 7.0, 0.01)
    };
    assert_ne!(table_key(&other, &p), key);
}

#[test]
fn the_gpu_samples_the_tables_as_measured_and_keeps_the_hotspot_at_backscatter() {
    use sylvan_render::technique::shadermap::gpu::GpuTables;
    use sylvan_render::technique::shadermap::ridge::RidgeTables;
    let gpu = gpu();
    let tree = common::test_tree();
    let z = sphere_asset(0.5);
    let t = measure_tables(
        &gpu,
        &mix(&tree, &z, 2.2 * 0.5 * z.radius, 1.0),
        &small_tables(),
        &mut |_, _| {},
    )
    .unwrap();
    let ridge = RidgeTables::new(&t);
    let g = GpuTables::upload(&gpu, &t).unwrap();
    let (nt, np, nl) = (t.theta as usize, t.phi as usize, t.lambdas.len());
    // Every diagonal node (θv = θl) comes back as measured, to f16's precision.
    let mut points = Vec::new();
    let mut expected = Vec::new();
    for l in 0..nl {
        for k in 0..nt {
            for m in 0..np {
                let th = t.theta_at(k as u32);
                points.push([th, th, t.phi_at(m as u32), t.lambdas[l]]);
                expected.push([
                    t.g_node(l, k, k, m),
                    t.t_node(l, k, k, m),
                    t.e_node(l, k),
                    t.d[l],
                ]);
            }
        }
    }
    let got = g.probe(&gpu, &points).unwrap();
    for ((p, e), o) in points.iter().zip(&expected).zip(&got) {
        for c in 0..4 {
            assert!(
                (o[c] - e[c]).abs() <= 2e-3 * e[c].abs().max(1.0),
                "node {p:?}: component {c} is {}, measured {}",
                o[c],
                e[c]
            );
        }
        let cpu = ridge.sample(p[0], p[1], p[2], p[3]);
        assert!((cpu[0] - e[0]).abs() < 1e-5 && (cpu[1] - e[1]).abs() < 1e-5);
    }
    // Between nodes the GPU's filtering is the CPU twin's multilinear interpolation.
    let mut rng = sylvan_plant::rng::Rng::new(7);
    let mut r = || rng.next_f64() as f32;
    let lmax = *t.lambdas.last().unwrap();
    let random: Vec<[f32; 4]> = (0..500)
        .map(|_| {
            [
                r() * 1.5707964,
                r() * 1.5707964,
                r() * std::f32::consts::PI,
                r() * lmax * 1.1,
            ]
        })
        .collect();
    let got = g.probe(&gpu, &random).unwrap();
    let mut worst = 0.0f32;
    for (p, o) in random.iter().zip(&got) {
        let cpu = ridge.sample(p[0], p[1], p[2], p[3]);
        worst = worst.max((o[0] - cpu[0]).abs()).max((o[1] - cpu[1]).abs());
    }
    assert!(worst < 4e-3, "GPU and CPU lookups differ by up to {worst}");
    // The hotspot: θl fixed between nodes, θv swept in 0.25° steps, the sun behind the viewer —
    // on tables of BN12's zenith resolution (16 nodes, 6° apart) the ground seen and lit peaks
    // where the view meets the sun's direction. (On these 5-node test tables it need not: at
    // θl = 61° it peaks at 55.5°, where the linear interpolation of Gd along θ̄ between 45° and
    // 67.5° outweighs the hotspot's fall along δ.)
    let fine = ShaderMapBakeParams {
        theta: 16,
        phi: 2,
        lambda: 2,
        patch_px: 64,
        ..small_tables()
    };
    let t = measure_tables(
        &gpu,
        &mix(&tree, &z, 2.2 * 0.5 * z.radius, 1.0),
        &fine,
        &mut |_, _| {},
    )
    .unwrap();
    let ridge = RidgeTables::new(&t);
    let g = GpuTables::upload(&gpu, &t).unwrap();
    let lmax = *t.lambdas.last().unwrap();
    // (Beyond 70° this dense stand, λA = 0.57, leaves under 0.2 % of the ground lit: no peak.)
    for tl_deg in [20.0f32, 35.0, 50.0, 61.0, 70.0] {
        let tl = tl_deg.to_radians();
        let sweep: Vec<[f32; 4]> = (0..=240)
            .map(|i| [(15.0 + 0.25 * i as f32).to_radians(), tl, 0.0, lmax])
            .collect();
        let got = g.probe(&gpu, &sweep).unwrap();
        let best = |v: &dyn Fn(usize) -> f32| {
            (0..sweep.len())
                .max_by(|&a, &b| v(a).total_cmp(&v(b)))
                .map(|i| sweep[i][0].to_degrees())
                .unwrap()
        };
        let gpu_peak = best(&|i| got[i][0]);
        let cpu_peak = best(&|i| ridge.sample(sweep[i][0], tl, 0.0, lmax)[0]);
        assert!(
            (gpu_peak - tl_deg).abs() <= 0.5 && (cpu_peak - tl_deg).abs() <= 0.5,
            "θl {tl_deg}°: 𝔾 peaks at θv {gpu_peak}° on the GPU, {cpu_peak}° on the CPU"
        );
    }
}
