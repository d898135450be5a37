//! `wang` placement: Poisson-disk Wang tiles (CSHD03) keep the spacing across every edge and
//! corner of any valid tiling, the hashed tiling is non-periodic and deterministic, a Wang
//! forest is produced per rectangle like a tiled one, thinning follows the density maps, and
//! scene files select it (shadermap plan §3.1, tests 1–4).

mod common;

use common::{min_distance, scene_file, tree_key, two_species};
use glam::Vec2;
use std::time::Instant;
use sylvan_scene::{
    Density, DensityMap, Placement, PlacementMethod, Scene, SeededForest, SpeciesLayout, Terrain,
    WangSet, place_trees, poisson_tile,
};

/// Smallest distance between a point of `a` and a point of `b`.
fn cross_distance(a: &[Vec2], b: &[Vec2]) -> f32 {
    a.iter()
        .flat_map(|p| b.iter().map(move |q| p.distance(*q)))
        .fold(f32::INFINITY, f32::min)
}

#[test]
fn wang_tiles_keep_the_spacing() {
    let (side, r) = (60.0, 2.5);
    let start = Instant::now();
    let set = WangSet::new(side, r, 3);
    let built = start.elapsed().as_secs_f64();
    println!(
        "WangSet::new({side}, {r}, 3): {} tiles in {:.1} ms ({:.0} tiles/s, dev profile)",
        WangSet::TILES,
        built * 1e3,
        WangSet::TILES as f64 / built
    );
    for t in 0..WangSet::TILES {
        assert!(
            set.points(t)
                .iter()
                .all(|p| (0.0..side).contains(&p.x) && (0.0..side).contains(&p.y)),
            "tile {t} has a point outside [0, side)²"
        );
        assert!(min_distance(set.points(t)) >= r * (1.0 - 1e-4), "tile {t}");
    }

    // A hashed 6 × 6 tiling, as the forest lays it out.
    let mut all = Vec::new();
    for ty in 0..6 {
        for tx in 0..6 {
            all.extend(set.copy_points(tx, ty));
        }
    }
    let found = min_distance(&all);
    println!(
        "6 × 6 hashed tiling: {} points, min distance {found} m (r = {r})",
        all.len()
    );
    assert!(found >= r * (1.0 - 1e-4), "min distance {found} < r = {r}");

    // Every pair of tiles that can touch in a valid tiling, across an edge or a corner: the
    // points near their common edge or corner keep r (so does any valid tiling, since points
    // closer than r lie in the same or neighbouring copies).
    let near = |t: usize, shift: Vec2, centre: Vec2| -> Vec<Vec2> {
        set.points(t)
            .iter()
            .map(|&p| p + shift)
            .filter(|p| (*p - centre).abs().max_element() < side * 0.5 + 2.0 * r)
            .collect()
    };
    let mut worst = f32::INFINITY;
    let mut pairs = 0;
    for a in 0..WangSet::TILES {
        let [_, _, a_top, a_right] = WangSet::colours(a);
        for b in 0..WangSet::TILES {
            let [b_bottom, b_left, _, _] = WangSet::colours(b);
            let mut check = |shift: Vec2| {
                // Only the strip of width 2r on each side of the shared edge / corner matters.
                let centre = Vec2::splat(side * 0.5) + shift * 0.5;
                let (pa, pb) = (near(a, Vec2::ZERO, centre), near(b, shift, centre));
                worst = worst.min(cross_distance(&pa, &pb));
                pairs += 1;
            };
            if a_right == b_left {
                check(Vec2::new(side, 0.0));
            }
            if a_top == b_bottom {
                check(Vec2::new(0.0, side));
            }
            // Diagonal neighbours share no edge: every pair can meet at a corner.
            check(Vec2::new(side, side));
            check(Vec2::new(side, -side));
        }
    }
    println!("{pairs} adjacent tile pairs: min distance {worst} m");
    assert_eq!(pairs, 128 + 128 + 256 + 256);
    assert!(
        worst >= r * (1.0 - 1e-4),
        "adjacent tiles {worst} < r = {r}"
    );

    // Density: within 3 % of a periodic Poisson tile's at the same radius.
    let tiled: f64 = (0..4)
        .map(|s| poisson_tile(side, r, s).len() as f64 / (side as f64 * side as f64))
        .sum::<f64>()
        / 4.0;
    let tiling = all.len() as f64 / (36.0 * side as f64 * side as f64);
    println!(
        "density (points per r²): poisson_tile {:.4}, Wang set {:.4} ({:+.2} %), 6 × 6 tiling \
         {:.4} ({:+.2} %)",
        tiled * (r * r) as f64,
        set.density() * (r * r) as f64,
        (set.density() / tiled - 1.0) * 100.0,
        tiling * (r * r) as f64,
        (tiling / tiled - 1.0) * 100.0
    );
    assert!((set.density() / tiled - 1.0).abs() < 0.03);
    assert!((tiling / tiled - 1.0).abs() < 0.03);
}

#[test]
fn wang_tiles_build_at_forest_size() {
    // The forest's own tiles: side ≈ 53 r (TILE_POINTS 2,500), r for 400 trees / ha.
    let r = (0.75f32 / 0.04).sqrt();
    let side = r * (2500.0f32 / 0.88).sqrt();
    let start = Instant::now();
    let set = WangSet::new(side, r, 17);
    let built = start.elapsed().as_secs_f64();
    let points: usize = (0..WangSet::TILES).map(|t| set.points(t).len()).sum();
    println!(
        "WangSet::new({side:.1}, {r:.2}, 17): {points} points in {} tiles, {:.0} ms ({:.0} \
         tiles/s, dev profile)",
        WangSet::TILES,
        built * 1e3,
        WangSet::TILES as f64 / built
    );
    // ≈ 2,500 points per tile (as `tiled`'s periodic tile).
    let mean = points as f64 / WangSet::TILES as f64;
    assert!(
        (mean - 2500.0).abs() < 0.05 * 2500.0,
        "{mean} points per tile"
    );
    let tiled = poisson_tile(side, r, 17).len() as f64 / (side as f64 * side as f64);
    let ratio = set.density() / tiled;
    println!(
        "density vs poisson_tile at forest size: {:+.2} %",
        (ratio - 1.0) * 100.0
    );
    assert!((ratio - 1.0).abs() < 0.03);
    let mut all = Vec::new();
    for ty in -1..2 {
        for tx in -1..2 {
            all.extend(set.copy_points(tx, ty));
        }
    }
    assert!(min_distance(&all) >= r * (1.0 - 1e-4));
}

fn tile_indices(set: &WangSet, n: i64) -> Vec<Vec<usize>> {
    (0..n)
        .map(|ty| (0..n).map(|tx| set.tile_of(tx, ty)).collect())
        .collect()
}

#[test]
fn wang_tiling_is_aperiodic_and_deterministic() {
    let set = WangSet::new(60.0, 2.5, 3);
    let idx = tile_indices(&set, 96);
    // Touching copies agree on their shared edge's colour.
    for ty in 0..95 {
        for tx in 0..95 {
            let [_, _, top, right] = WangSet::colours(idx[ty][tx]);
            assert_eq!(right, WangSet::colours(idx[ty][tx + 1])[1]);
            assert_eq!(top, WangSet::colours(idx[ty + 1][tx])[0]);
        }
    }
    // All 16 tiles appear, about equally often.
    let mut count = [0usize; WangSet::TILES];
    idx.iter().flatten().for_each(|&t| count[t] += 1);
    let mean = 96.0 * 96.0 / 16.0;
    assert!(
        count.iter().all(|&c| (c as f64 - mean).abs() < 0.25 * mean),
        "{count:?}"
    );
    // A 64 × 64 block differs from itself shifted by (p, 0) or (0, p), p in 1..32 — not just
    // somewhere: about 15/16 of the copies differ, as for independent tiles.
    let mut most_alike: f64 = 0.0;
    for p in 1..32 {
        for (dx, dy) in [(p, 0), (0, p)] {
            let same = (0..64)
                .flat_map(|y| (0..64).map(move |x| (x, y)))
                .filter(|&(x, y)| idx[y][x] == idx[y + dy][x + dx])
                .count();
            let share = same as f64 / 4096.0;
            most_alike = most_alike.max(share);
            assert!(
                share < 0.2,
                "shift ({dx}, {dy}): {same} of 4096 copies alike"
            );
        }
    }
    println!("largest share of copies alike under a shift: {most_alike:.3}");
    // Far from the origin, too (negative and large coordinates).
    let far: Vec<usize> = (0..64)
        .map(|i| set.tile_of(-1_000_000 + i, 77_777))
        .collect();
    assert!(far.iter().collect::<std::collections::HashSet<_>>().len() > 8);

    // The same on a re-run: points bit for bit, tiling identical; another seed differs.
    let again = WangSet::new(60.0, 2.5, 3);
    for t in 0..WangSet::TILES {
        let bits = |s: &WangSet| -> Vec<(u32, u32)> {
            s.points(t)
                .iter()
                .map(|p| (p.x.to_bits(), p.y.to_bits()))
                .collect()
        };
        assert_eq!(bits(&set), bits(&again), "tile {t}");
    }
    assert_eq!(tile_indices(&again, 96), idx);
    let other = WangSet::new(60.0, 2.5, 4);
    assert_ne!(tile_indices(&other, 96), idx);
    assert_ne!(other.points(0), set.points(0));
}

#[test]
fn a_wang_forest_is_produced_per_rectangle() {
    let terrain = Terrain::procedural(5, [900.0, 700.0], 60.0);
    let forest =
        SeededForest::with_method(terrain.size, &two_species(), 11, PlacementMethod::Wang, &[])
            .unwrap()
            .unwrap();
    assert_eq!(forest.method(), PlacementMethod::Wang);
    let side = forest.wang().expect("Wang tiles").side();
    let mut whole = Vec::new();
    forest.produce(&terrain, Vec2::ZERO, Vec2::from(terrain.size), &mut whole);
    let mut whole_keys: Vec<_> = whole.iter().map(tree_key).collect();
    whole_keys.sort_unstable();
    // Rectangles straddling Wang tile edges and corners: exactly the whole forest's trees there.
    for (min, max) in [
        (
            Vec2::new(side - 37.0, side - 41.0),
            Vec2::new(side + 53.0, 2.0 * side + 9.0),
        ),
        (Vec2::new(0.0, 0.0), Vec2::new(123.4, 567.8)),
        (Vec2::new(450.5, 100.25), Vec2::new(900.0, 700.0)),
    ] {
        let mut part = Vec::new();
        forest.produce(&terrain, min, max, &mut part);
        let mut keys: Vec<_> = part.iter().map(tree_key).collect();
        keys.sort_unstable();
        let inside: Vec<_> = whole
            .iter()
            .filter(|t| {
                (min.x..max.x).contains(&t.position.x) && (min.y..max.y).contains(&t.position.z)
            })
            .map(tree_key)
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect();
        assert!(!keys.is_empty());
        assert_eq!(keys, inside, "rectangle {min} – {max}");
        assert_eq!(
            part.iter().map(tree_key).collect::<Vec<_>>().len(),
            keys.len()
        );
    }
    // A partition into 100 m squares gives the whole forest.
    let mut tiles = Vec::new();
    for j in 0..7 {
        for i in 0..9 {
            let min = Vec2::new(i as f32, j as f32) * 100.0;
            forest.produce(&terrain, min, min + 100.0, &mut tiles);
        }
    }
    let mut keys: Vec<_> = tiles.iter().map(tree_key).collect();
    keys.sort_unstable();
    assert_eq!(keys, whole_keys);
    // The eager placement of the same method is the same forest.
    let placed = place_trees(
        &terrain,
        &two_species(),
        &Placement {
            seed: 11,
            method: PlacementMethod::Wang,
        },
        &[],
    )
    .unwrap();
    assert_eq!(placed.trees, whole);
    // Spacing across species and Wang tiles; ≈ ∫ density (450 / ha over 63 ha).
    let pts: Vec<Vec2> = whole
        .iter()
        .map(|t| Vec2::new(t.position.x, t.position.z))
        .collect();
    assert!(min_distance(&pts) >= placed.min_spacing_m * (1.0 - 1e-4));
    let expected = 450.0 * 63.0;
    assert!(
        (whole.len() as f64 - expected).abs() < 0.05 * expected,
        "{} trees, expected about {expected}",
        whole.len()
    );
    // Not the tiled forest.
    let tiled = SeededForest::new(terrain.size, &two_species(), 11, &[])
        .unwrap()
        .unwrap();
    let mut t = Vec::new();
    tiled.produce(&terrain, Vec2::ZERO, Vec2::from(terrain.size), &mut t);
    assert_ne!(t, whole);
}

#[test]
fn thinning_follows_the_maps() {
    // 2 km along x, species 0 ramps up 0 → 400 / ha, species 1 down 200 → 0 / ha.
    let (len, width) = (2000.0f32, 400.0f32);
    let terrain = Terrain::flat([len, width], 0.0);
    let ramp = |up: bool| DensityMap {
        resolution: [21, 2],
        values: (0..2)
            .flat_map(|_| {
                (0..21).map(move |i| {
                    if up {
                        i as f32 / 20.0
                    } else {
                        1.0 - i as f32 / 20.0
                    }
                })
            })
            .collect(),
    };
    let layouts = vec![
        SpeciesLayout {
            species: 0,
            height_m: [10.0, 15.0],
            density: Density::Map {
                map: ramp(true),
                max_per_ha: 400.0,
            },
        },
        SpeciesLayout {
            species: 1,
            height_m: [10.0, 15.0],
            density: Density::Map {
                map: ramp(false),
                max_per_ha: 200.0,
            },
        },
    ];
    let forest = SeededForest::with_method(terrain.size, &layouts, 5, PlacementMethod::Wang, &[])
        .unwrap()
        .unwrap();
    let mut trees = Vec::new();
    forest.produce(&terrain, Vec2::ZERO, Vec2::from(terrain.size), &mut trees);
    let strip_ha = 100.0 * width as f64 * 1e-4;
    let mut worst: f64 = 0.0;
    for k in 0..20 {
        // The map is linear in x: the strip's mean is its centre's value.
        let v = (k as f64 + 0.5) / 20.0;
        for (species, expected) in [(0, v * 400.0 * strip_ha), (1, (1.0 - v) * 200.0 * strip_ha)] {
            let n = trees
                .iter()
                .filter(|t| t.species == species && (t.position.x / 100.0) as usize == k)
                .count() as f64;
            // Thinning a Poisson-disk pattern is at most as variable as a Poisson count.
            let z = (n - expected) / expected.sqrt();
            worst = worst.max(z.abs());
            assert!(
                z.abs() < 3.0,
                "strip {k}, species {species}: {n} trees, ∫D = {expected:.1}"
            );
        }
    }
    println!(
        "{} trees, largest strip deviation {worst:.2} σ",
        trees.len()
    );
}

#[test]
fn scene_file_reads_wang() {
    let text = "[terrain]\nprocedural = { seed = 4, size_m = [1500, 1000], relief_m = 30 }\n\
                [[species]]\npreset = \"pine\"\ndensity_per_ha = 200\n\
                [placement]\nmethod = \"wang\"\nseed = 8\n";
    let scene = Scene::load(&scene_file("wang", text)).unwrap();
    assert!(
        scene.trees.is_empty(),
        "wang placement is never placed at load"
    );
    let forest = scene.seeded.as_ref().expect("wang placement is seeded");
    assert_eq!(forest.method(), PlacementMethod::Wang);
    assert!(forest.wang().is_some());
    let all = scene.all_trees().unwrap();
    assert!(
        (all.len() as f64 - 30_000.0).abs() < 1_500.0,
        "{}",
        all.len()
    );

    // `tiled` stays the periodic tile.
    let tiled = Scene::load(&scene_file("wang-tiled", &text.replace("wang", "tiled"))).unwrap();
    assert_eq!(
        tiled.seeded.as_ref().unwrap().method(),
        PlacementMethod::Tiled
    );
    assert!(tiled.seeded.as_ref().unwrap().wang().is_none());

    // An unknown method: one line naming file:line:col and the valid values.
    let bad = scene_file(
        "wang-bad",
        "[placement]\nseed = 2\nmethod = \"wang-tiles\"\n",
    );
    let e = Scene::load(&bad).unwrap_err().to_string();
    assert!(e.contains("scene.toml:3:10"), "{e}");
    assert!(e.contains("wang-tiles"), "{e}");
    assert!(e.contains("\"poisson\", \"tiled\" or \"wang\""), "{e}");
    assert!(!e.contains('\n'), "{e}");
}
