//! `billboard-cloud` (GPSS07): the clustering, the hash / lists / records and the fragment walk,
//! checked on the CPU against the plant's own triangles; the payload's damage checks; and a
//! one-tree render against the geometry (coverage, ꟻLIP, GPU- vs CPU-driven).

mod common;

use common::gpu;
use glam::{Vec2, Vec3};
use sylvan_render::RenderOptions;
use sylvan_render::bake::CachePolicy;
use sylvan_render::bake::codec::Codec;
use sylvan_render::technique::bcloud::layers::{self, Cloud};
use sylvan_render::technique::bcloud::{BillboardCloudBakeParams, bake, cluster};
use sylvan_scene::{Camera, Scene, TreeInstance};

fn small_params() -> BillboardCloudBakeParams {
    BillboardCloudBakeParams {
        planes: 40,
        planes_mid: 16,
        planes_far: 6,
        cells: 1 << 14,
        tile: 8,
        supersample: 2,
        iterations: 6,
    }
}

fn baked(preset: &str) -> (sylvan_plant::Plant, bake::BillboardCloudBaked) {
    let plant = sylvan_plant::preset(preset).expect("preset");
    let b = bake::bake_clouds(&plant, &small_params(), &mut |_, _| {}).expect("bake");
    (plant, b)
}

/// Points spread over a triangle (barycentric grid).
fn samples(t: [Vec3; 3], n: usize) -> Vec<(Vec3, [f32; 3])> {
    let mut out = Vec::new();
    for i in 0..n {
        for j in 0..n - i {
            let (a, b) = ((i as f32 + 0.33) / n as f32, (j as f32 + 0.33) / n as f32);
            let c = 1.0 - a - b;
            if c < 0.0 {
                continue;
            }
            out.push((t[0] * a + t[1] * b + t[2] * c, [a, b, c]));
        }
    }
    out
}

#[test]
fn every_leaf_is_in_exactly_one_plane_of_each_cloud() {
    for preset in ["chestnut", "pine"] {
        let (plant, b) = baked(preset);
        assert_eq!(b.leaves as usize, cluster::leaves(&plant, false).len());
        for (level, c) in b.clouds.iter().enumerate() {
            let n = cluster::leaves(&plant, bake::cut_leaves(level)).len();
            let mut seen = vec![0u32; n];
            for m in &c.members {
                for &l in m {
                    seen[l as usize] += 1;
                }
            }
            assert!(
                seen.iter().all(|&k| k == 1),
                "{preset} cloud {level}: a leaf in {} planes",
                seen.iter().find(|&&k| k != 1).copied().unwrap_or(0)
            );
        }
    }
}

/// Each leaf's triangles in leaf-image coordinates.
fn uv_tris(plant: &sylvan_plant::Plant, leaf: &cluster::Leaf) -> Vec<[Vec2; 3]> {
    let m = &plant.leaves;
    leaf.triangles
        .iter()
        .map(|t| t.map(|i| Vec2::from(m.uvs[i as usize])))
        .collect()
}

/// A cell's list holds exactly the leaves whose fitted triangles, projected onto the plane,
/// cover some point of the cell: checked against
/// a dense CPU rasterisation of every fitted triangle (nothing covered is missing; every
/// listed leaf has a sample there or an exact overlap).
#[test]
fn cell_lists_cover_exactly_the_overlapping_leaf_fragments() {
    let plant = sylvan_plant::preset("chestnut").expect("preset");
    let leaves = cluster::leaves(&plant, true);
    let planes = cluster::cluster(&plant, &leaves, 40, 6);
    let spec = layers::CloudSpec {
        cells: 1 << 14,
        tile: 8,
        supersample: 1,
        layered: true,
    };
    let c: Cloud = layers::build(&plant, &leaves, &planes, spec).expect("build");
    let mut checked = 0;
    for (p, members) in c.members.iter().enumerate().step_by(7) {
        let rec = &c.planes[p];
        let (nx, ny) = rec.cells();
        let mut covered = vec![Vec::<u32>::new(); (nx * ny) as usize];
        let fitted = |l: u32| -> Vec<[Vec2; 3]> {
            let r = &c.records[l as usize];
            uv_tris(&plant, &leaves[l as usize])
                .into_iter()
                .map(|t| t.map(|uv| layers::leaf_point(r, uv).truncate()))
                .collect()
        };
        for &l in members {
            for tri in fitted(l) {
                for (pt, _) in samples(tri.map(|x| x.extend(0.0)), 12) {
                    let (cx, cy) = rec.cell_of(pt.truncate());
                    covered[(cy * nx + cx) as usize].push(l);
                }
            }
        }
        for cy in 0..ny {
            for cx in 0..nx {
                let list = c.list(p, cx, cy);
                let mut want = covered[(cy * nx + cx) as usize].clone();
                want.sort_unstable();
                want.dedup();
                for l in &want {
                    assert!(
                        list.contains(l),
                        "plane {p} cell ({cx},{cy}) misses leaf {l}"
                    );
                }
                // Listed but not sampled: must be a true overlap of a fitted triangle.
                for l in list.iter().filter(|l| !want.contains(l)) {
                    let lo = rec.min() + Vec2::new(cx as f32, cy as f32) * rec.origin_cell[3];
                    let hi = lo + Vec2::splat(rec.origin_cell[3]);
                    let hit = fitted(*l)
                        .into_iter()
                        .any(|tri| layers::triangle_overlaps_box(tri, lo, hi));
                    assert!(
                        hit,
                        "plane {p} cell ({cx},{cy}) lists leaf {l} that does not overlap it"
                    );
                }
                checked += list.len();
            }
        }
    }
    assert!(checked > 100, "only {checked} list entries checked");
}

/// Every fitted leaf lies inside its plane's box (rectangle × slab), so the box drawn for the
/// plane covers every pixel that sees one of its leaves.
#[test]
fn slabs_hold_their_leaves() {
    let (plant, b) = baked("chestnut");
    let leaves = cluster::leaves(&plant, true);
    for (level, c) in b.clouds.iter().enumerate().take(2) {
        let mut points = 0;
        for (p, members) in c.members.iter().enumerate() {
            let rec = &c.planes[p];
            let (h0, h1) = rec.heights();
            let (lo, hi) = (rec.min(), rec.min() + rec.size());
            for &l in members {
                let r = &c.records[l as usize];
                for t in uv_tris(&plant, &leaves[l as usize]) {
                    for uv in t {
                        let x = layers::leaf_point(r, uv);
                        let inside = x.z >= h0
                            && x.z <= h1
                            && x.truncate().cmpge(lo).all()
                            && x.truncate().cmple(hi).all();
                        assert!(
                            inside,
                            "cloud {level} plane {p}: leaf {l} point {x} outside {lo}..{hi} × {h0}..{h1}"
                        );
                        points += 1;
                    }
                }
            }
        }
        assert!(points > 10_000, "cloud {level}: only {points} points");
    }
    // The far cloud is drawn flat from its tiles.
    assert!(b.clouds[2].planes.iter().all(|p| p.heights() == (0.0, 0.0)));
}

/// Where a fitted leaf's texture is opaque, the walk along a ray through that point — along
/// the leaf's normal, and from a random direction on the side the leaf faces up to 85° from
/// its normal (its plane may then be seen almost edge-on) — finds an opaque leaf there or in
/// front of it: the slab walk loses no coverage and keeps the order along the ray.
#[test]
fn the_walk_keeps_the_leaves_coverage() {
    let (plant, b) = baked("chestnut");
    let leaves = cluster::leaves(&plant, true);
    let c = &b.clouds[0];
    let mut rng = 0x1234_5678_u32;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 17;
        rng ^= rng << 5;
        rng as f32 / u32::MAX as f32
    };
    let tex = &plant.leaf_texture;
    let (mut opaque, mut found, mut found_oblique, mut behind) = (0usize, 0usize, 0usize, 0usize);
    for (p, members) in c.members.iter().enumerate() {
        for &l in members.iter().step_by(5) {
            let r = &c.records[l as usize];
            let (tu, tv) = (Vec3::from(r.to_u), Vec3::from(r.to_v));
            let n = tu.cross(tv).normalize_or(Vec3::Z);
            let side = if n.z >= 0.0 { n } else { -n };
            for t in uv_tris(&plant, &leaves[l as usize]) {
                for (_, w) in samples([Vec3::X, Vec3::Y, Vec3::Z], 4) {
                    let uv = t[0] * w[0] + t[1] * w[1] + t[2] * w[2];
                    let (x, y) = (
                        ((uv.x * tex.width as f32) as u32).min(tex.width - 1),
                        ((uv.y * tex.height as f32) as u32).min(tex.height - 1),
                    );
                    if tex.rgba[((y * tex.width + x) * 4 + 3) as usize] < 200 {
                        continue;
                    }
                    opaque += 1;
                    // The point on the fitted leaf (plane space) and rays through it.
                    let pt = layers::leaf_point(r, uv);
                    let mut seen = |to_eye: Vec3| {
                        let Some(hit) = layers::walk(c, &plant, p, pt, -to_eye) else {
                            return false;
                        };
                        let rec = &c.records[hit.record as usize];
                        let (lambda, _) = layers::leaf_hit(rec, pt, -to_eye).expect("hit");
                        behind += (lambda > 1e-3) as usize;
                        true
                    };
                    found += seen(side) as usize;
                    let a = next() * std::f32::consts::TAU;
                    let tilt = next().sqrt() * 85f32.to_radians();
                    let (e1, e2) = side.any_orthonormal_pair();
                    let dir = side * tilt.cos() + (e1 * a.cos() + e2 * a.sin()) * tilt.sin();
                    found_oblique += seen(dir) as usize;
                }
            }
        }
    }
    let kept = found as f64 / opaque.max(1) as f64;
    let kept_oblique = found_oblique as f64 / opaque.max(1) as f64;
    eprintln!(
        "{opaque} opaque points: kept {kept:.4} along the normal, {kept_oblique:.4} oblique, {behind} hits behind the point"
    );
    assert!(
        opaque > 1000 && kept > 0.999 && kept_oblique > 0.99,
        "{found}/{found_oblique} of {opaque} opaque leaf points covered"
    );
    assert_eq!(
        behind, 0,
        "the walk returned a leaf behind the first one on the ray"
    );
}

/// Where two listed leaves are both opaque at a point, the walk seen from the front side
/// returns the one higher above the plane and the walk from the back side the lower one.
#[test]
fn front_and_back_walks_see_opposite_ends_of_the_list() {
    let (plant, b) = baked("chestnut");
    let c = &b.clouds[0];
    let mut flipped = 0;
    for (p, rec) in c.planes.iter().enumerate() {
        let (nx, ny) = rec.cells();
        for cy in 0..ny {
            for cx in 0..nx {
                let list = c.list(p, cx, cy);
                if list.len() < 2 {
                    continue;
                }
                let cm = rec.origin_cell[3];
                let st = rec.min() + (Vec2::new(cx as f32, cy as f32) + 0.5) * cm;
                let o = st.extend(0.0);
                let (Some(f), Some(k)) = (
                    layers::walk(c, &plant, p, o, -Vec3::Z),
                    layers::walk(c, &plant, p, o, Vec3::Z),
                ) else {
                    continue;
                };
                if f.record == k.record {
                    continue;
                }
                // The height above the plane where the vertical line meets the leaf.
                let h = |r: u32| {
                    let (lambda, _) = layers::leaf_hit(&c.records[r as usize], o, Vec3::Z)
                        .expect("the walk's leaf is on the line");
                    lambda
                };
                assert!(h(f.record) >= h(k.record), "plane {p} cell ({cx},{cy})");
                flipped += 1;
            }
        }
    }
    assert!(
        flipped > 50,
        "only {flipped} cells show different leaves from the two sides"
    );
}

#[test]
fn payload_round_trips_and_damage_is_rejected() {
    let (_, b) = baked("pine");
    let bytes = b.encode();
    assert_eq!(bake::BillboardCloudBaked::decode(&bytes).unwrap(), b);
    for cut in (0..bytes.len()).step_by(bytes.len() / 61 + 1) {
        assert!(
            bake::BillboardCloudBaked::decode(&bytes[..cut]).is_err(),
            "cut at {cut}"
        );
    }
    let mut long = bytes.clone();
    long.push(0);
    assert!(bake::BillboardCloudBaked::decode(&long).is_err());
    // A list entry naming a record past the end is refused (the entries follow the cells).
    let mut bad = b.clone();
    let n = bad.clouds[0].records.len() as u32;
    bad.clouds[0].lists[0] = n + 5;
    assert!(bake::BillboardCloudBaked::decode(&bad.encode()).is_err());
    let mut bad = b.clone();
    bad.clouds[1].cells[0] = u32::MAX;
    assert!(bake::BillboardCloudBaked::decode(&bad.encode()).is_err());
}

const SIZE: u32 = 160;

fn one_tree(with_tree: bool) -> Scene {
    let at = Vec3::new(60.0, 0.0, 60.0);
    let trees = if with_tree {
        vec![TreeInstance {
            position: at,
            species: 0,
            seed: 0,
            height: 10.0,
            rotation: 0.4,
        }]
    } else {
        Vec::new()
    };
    let camera = Camera {
        position: at + Vec3::new(3.0, 7.0, -22.0),
        look_at: at + Vec3::new(0.0, 5.0, 0.0),
        fov_deg: 40.0,
    };
    common::scene(
        common::terrain(160.0, 33, |_, _| 0.0),
        trees,
        camera,
        common::sun(150.0, 40.0),
    )
}

fn render(scene: &Scene, technique: &str, spp: u32, cpu_driven: bool) -> image::RgbImage {
    let options = RenderOptions {
        width: SIZE,
        height: SIZE,
        spp,
        technique: technique.into(),
        cache: CachePolicy::Off,
        cpu_driven,
        settings: ["billboard-cloud.planes=48", "billboard-cloud.cells=16384"]
            .iter()
            .map(|a| sylvan_scene::Setting::from_arg(a).unwrap())
            .collect(),
        ..Default::default()
    };
    common::render_with_options(
        &gpu(),
        scene,
        &[sylvan_plant::preset("chestnut").unwrap()],
        &options,
    )
    .0
}

fn mask(img: &image::RgbImage, background: &image::RgbImage) -> Vec<bool> {
    img.pixels()
        .zip(background.pixels())
        .map(|(a, b)| (0..3).any(|c| (a[c] as i32 - b[c] as i32).abs() > 12))
        .collect()
}

/// One chestnut: the cloud covers what the geometry covers, is close to the 16-spp reference,
/// and draws the same picture whether the GPU cull or the CPU lists feed it.
#[test]
fn one_chestnut_matches_the_geometry_and_both_frames_agree() {
    let scene = one_tree(true);
    let background = render(&one_tree(false), "geometry", 1, false);
    let reference = render(&scene, "geometry", 16, false);
    let geometry = render(&scene, "geometry", 1, false);
    let cloud = render(&scene, "billboard-cloud", 1, false);
    let cloud_cpu = render(&scene, "billboard-cloud", 1, true);
    let flip = |a: &image::RgbImage| sylvan_eval::flip(&reference, a).unwrap().mean as f32;
    let (mr, mc) = (mask(&reference, &background), mask(&cloud, &background));
    let count = |m: &[bool]| m.iter().filter(|x| **x).count() as f32;
    let inter = mr.iter().zip(&mc).filter(|(a, b)| **a && **b).count() as f32;
    let iou = inter / (count(&mr) + count(&mc) - inter).max(1.0);
    let (fc, fg) = (flip(&cloud), flip(&geometry));
    eprintln!(
        "IoU {iou:.3}, coverage {:.3} vs {:.3}, FLIP cloud {fc:.4}, geometry 1 spp {fg:.4}",
        count(&mc),
        count(&mr)
    );
    assert!(iou > 0.6, "coverage IoU {iou}");
    assert!(
        (count(&mc) / count(&mr) - 1.0).abs() < 0.25,
        "coverage {} vs {}",
        count(&mc),
        count(&mr)
    );
    assert!(fc < 3.0 * fg.max(0.02), "FLIP {fc} vs geometry {fg}");
    let same = sylvan_eval::flip(&cloud, &cloud_cpu).unwrap().mean;
    assert!(same < 1e-3, "GPU- vs CPU-driven FLIP {same}");
}

#[test]
#[ignore]
fn diagnostics() {
    let plant = sylvan_plant::preset("chestnut").expect("preset");
    let leaves = cluster::leaves(&plant, true);
    for k in [160usize, 64, 24] {
        let planes = cluster::cluster(&plant, &leaves, k, 10);
        let (mut cos, mut area, mut thick, mut rect) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for p in &planes {
            let mut t: f32 = 0.0;
            for &l in &p.leaves {
                let leaf = &leaves[l as usize];
                cos += (leaf.normal.dot(p.normal).abs() * leaf.area) as f64;
                area += leaf.area as f64;
                t = t.max(p.height(leaf.centre).abs());
            }
            thick += t as f64;
            rect += ((p.max - p.min).x * (p.max - p.min).y) as f64;
        }
        println!(
            "k={k}: mean |cos| {:.3}, mean max thickness {:.3} m, rect area {:.1} m², leaf area {:.1} m²",
            cos / area,
            thick / planes.len() as f64,
            rect,
            area
        );
    }
}
