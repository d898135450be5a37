//! The built-in scenes: the forest to the horizon (the default) and the small grove — size,
//! species, camera, determinism, speed.

use glam::Vec2;
use sylvan_scene::{BUILTIN_FOREST_CHAIN, PlantSource, Scene};

#[test]
fn builtin_grove_is_a_grove_on_hills() {
    let t0 = std::time::Instant::now();
    let s = Scene::builtin_grove();
    let elapsed = t0.elapsed();
    let per_species: Vec<usize> = (0..s.species.len())
        .map(|i| s.trees.iter().filter(|t| t.species == i as u32).count())
        .collect();
    println!("{} trees {per_species:?} in {elapsed:?}", s.trees.len());
    assert!(s.trees.len() >= 5000, "{}", s.trees.len());
    assert!(s.species.len() >= 2 && per_species.iter().all(|&n| n > 100));
    assert!(matches!(&s.species[0].plant, PlantSource::Preset(p) if p == "pine"));
    let [sx, sz] = s.terrain.size;
    assert!((1000.0..=1500.0).contains(&sx) && (1000.0..=1500.0).contains(&sz));
    let (lo, hi) = s.terrain.min_max();
    assert!(hi - lo > 50.0, "hilly: relief {}", hi - lo);
    assert!(s.terrain.resolution[0] <= 513 && s.terrain.resolution[1] <= 513);
    for t in &s.trees {
        assert!(s.terrain.contains(t.position.x, t.position.z));
        assert!((t.position.y - s.terrain.height_at(t.position.x, t.position.z)).abs() < 1e-3);
        let h = s.species[t.species as usize].height_m;
        assert!(t.height >= h[0] && t.height <= h[1]);
    }
    assert!((35.0..=45.0).contains(&s.sun.elevation_deg));
    // Camera: above the ground and every nearby tree, looking slightly down across the terrain.
    let c = s.camera;
    assert!(c.position.y > s.terrain.height_at(c.position.x, c.position.z) + 10.0);
    let d = (c.look_at - c.position).normalize();
    let pitch = d.y.asin().to_degrees();
    assert!((-15.0..0.0).contains(&pitch), "pitch {pitch}");
    assert!(d.x > 0.3 && d.z > 0.3, "looks across the terrain: {d}");
    assert!(s.source.is_none());
    let again = Scene::builtin_grove();
    assert_eq!(s.trees, again.trees);
    // The grove is the built-in scene of before the forest: the same trees.
    assert_eq!(s.trees.len(), 6381);
}

#[test]
fn builtin_default_is_a_forest_to_the_horizon() {
    let t0 = std::time::Instant::now();
    let s = Scene::builtin_default();
    let elapsed = t0.elapsed();
    let [sx, sz] = s.terrain.size;
    assert!(sx * sz >= 36e6, "tens of km²: {sx} x {sz} m");
    let (lo, hi) = s.terrain.min_max();
    assert!(hi - lo > 150.0, "hilly: relief {}", hi - lo);
    // Nothing placed at load: the trees come tile by tile from the seeded forest.
    assert!(s.trees.is_empty());
    let forest = s.seeded.as_ref().expect("a seeded forest");
    let estimated = s.estimated_trees();
    println!("{estimated:.0} trees estimated, scene built in {elapsed:?}");
    assert!(estimated >= 2e6, "millions of trees: {estimated:.0}");
    assert!(s.species.len() >= 3);
    assert_eq!(forest.layouts().len(), s.species.len());
    assert!(
        forest
            .layouts()
            .iter()
            .all(|l| matches!(l.density, sylvan_scene::Density::Map { .. })),
        "every species from a density map"
    );
    assert_eq!(s.lod_chain, BUILTIN_FOREST_CHAIN.map(String::from));
    assert!(s.lod_chain.last().unwrap().starts_with("shadermap:"));
    assert!(s.world.tree_distance_m.is_finite());
    // Every species grows somewhere: a 2 km square near the camera holds each of them.
    let mut trees = Vec::new();
    let c = Vec2::new(s.camera.position.x, s.camera.position.z);
    forest.produce(&s.terrain, c, c + Vec2::splat(2000.0), &mut trees);
    let per_species: Vec<usize> = (0..s.species.len())
        .map(|i| trees.iter().filter(|t| t.species == i as u32).count())
        .collect();
    println!("{per_species:?} trees in 4 km² by the camera");
    assert!(per_species.iter().all(|&n| n > 1000), "{per_species:?}");
    // Open country too: the density maps are not one uniform stand.
    let pine = &forest.layouts()[0].density;
    let samples: Vec<f32> = (0..64)
        .flat_map(|i| (0..64).map(move |j| (i, j)))
        .map(|(i, j)| pine.per_m2(s.terrain.size, i as f32 * sx / 63.0, j as f32 * sz / 63.0))
        .collect();
    let open = samples.iter().filter(|&&d| d < 1e-3).count();
    assert!(
        open > 64 && open < 64 * 64 / 2,
        "{open} of 4096 samples without pines"
    );
    // Cheap to start: maps and pattern only.
    assert!(elapsed.as_secs_f32() < 20.0, "{elapsed:?}");
    let c = s.camera;
    assert!(c.position.y > s.terrain.height_at(c.position.x, c.position.z) + 10.0);
}
