//! `tiled` placement produced tile by tile: any partition of the terrain gives the same trees
//! as the whole, each tree inside its own rectangle, spacing and density as the eager placement.

mod common;

use common::{scene_file, tree_key, two_species};
use glam::Vec2;
use sylvan_scene::{
    Placement, PlacementMethod, Scene, SeededForest, Terrain, TreeInstance, place_trees,
};

fn produce_tiles(forest: &SeededForest, terrain: &Terrain, tile: f32) -> Vec<TreeInstance> {
    let n = (terrain.size[0] / tile).ceil() as i32;
    let m = (terrain.size[1] / tile).ceil() as i32;
    let mut all = Vec::new();
    for j in 0..m {
        for i in 0..n {
            let min = Vec2::new(i as f32, j as f32) * tile;
            let max = min + Vec2::splat(tile);
            let start = all.len();
            forest.produce(terrain, min, max, &mut all);
            for t in &all[start..] {
                assert!(
                    (min.x..max.x).contains(&t.position.x)
                        && (min.y..max.y).contains(&t.position.z),
                    "a tree of tile ({i}, {j}) lies outside it"
                );
            }
        }
    }
    all
}

#[test]
fn any_partition_gives_the_same_trees() {
    let terrain = Terrain::procedural(5, [900.0, 700.0], 60.0);
    let forest = SeededForest::new(terrain.size, &two_species(), 11, &[])
        .unwrap()
        .unwrap();
    let mut whole = Vec::new();
    forest.produce(&terrain, Vec2::ZERO, Vec2::from(terrain.size), &mut whole);
    let mut whole_keys: Vec<_> = whole.iter().map(tree_key).collect();
    whole_keys.sort_unstable();
    for tile in [64.0, 100.0, 256.0, 333.3] {
        let mut keys: Vec<_> = produce_tiles(&forest, &terrain, tile)
            .iter()
            .map(tree_key)
            .collect();
        keys.sort_unstable();
        assert_eq!(keys, whole_keys, "tiles of {tile} m");
    }
    // The eager placement of the same method is the same forest.
    let placed = place_trees(
        &terrain,
        &two_species(),
        &Placement {
            seed: 11,
            method: PlacementMethod::Tiled,
        },
        &[],
    )
    .unwrap();
    assert_eq!(placed.trees, whole);
    // ≈ ∫ density: 450 / ha over 63 ha.
    let expected = 450.0 * 63.0;
    assert!(
        (whole.len() as f64 - expected).abs() < 0.1 * expected,
        "{} trees, expected about {expected}",
        whole.len()
    );
}

#[test]
fn a_tile_costs_its_area_not_the_world() {
    // 100 km²: producing one 256 m tile must not touch the rest of the world.
    let terrain = Terrain::flat([10_000.0, 10_000.0], 0.0);
    let forest = SeededForest::new(terrain.size, &two_species(), 3, &[])
        .unwrap()
        .unwrap();
    assert!(forest.estimated_trees() > 4.0e6);
    let mut out = Vec::new();
    let start = std::time::Instant::now();
    forest.produce(
        &terrain,
        Vec2::new(5000.0, 5000.0),
        Vec2::new(5256.0, 5256.0),
        &mut out,
    );
    let n = out.len() as f64;
    let expected = 450.0 * 0.256 * 0.256 * 100.0;
    assert!((n - expected).abs() < 0.15 * expected, "{n} vs {expected}");
    // Not a timing claim: a generous bound that a whole-world scan (4.5M trees) would break.
    assert!(start.elapsed().as_secs_f64() < 1.0);
}

#[test]
fn a_tiled_scene_is_not_placed_at_load() {
    let text = "[terrain]\nprocedural = { seed = 4, size_m = [3000, 3000], relief_m = 30 }\n\
                [[species]]\npreset = \"pine\"\ndensity_per_ha = 200\n\
                [placement]\nmethod = \"tiled\"\nseed = 8\n";
    let scene = Scene::load(&scene_file("seeded", text)).unwrap();
    assert!(scene.trees.is_empty());
    let forest = scene.seeded.as_ref().expect("tiled placement is seeded");
    assert!((forest.estimated_trees() - 200.0 * 900.0).abs() < 1.0);
    let all = scene.all_trees().unwrap();
    assert!(
        (all.len() as f64 - 180_000.0).abs() < 18_000.0,
        "{}",
        all.len()
    );
    // Seeds are spread (colour variation), not all alike.
    let distinct: std::collections::HashSet<u32> = all.iter().map(|t| t.seed).collect();
    assert!(distinct.len() as f64 > 0.99 * all.len() as f64);
}
