//! The built-in scene: size, species, camera, determinism, speed.

use sylvan_scene::{PlantSource, Scene};

#[test]
fn builtin_scene_is_a_forest_on_hills() {
    let t0 = std::time::Instant::now();
    let s = Scene::builtin_default();
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
    let again = Scene::builtin_default();
    assert_eq!(s.trees, again.trees);
}
