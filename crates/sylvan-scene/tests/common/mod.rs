//! Shared helpers: a fresh temporary folder per test.

#![allow(dead_code)]

use glam::Vec2;
use std::path::PathBuf;
use sylvan_scene::{Density, SpeciesLayout, TreeInstance};

/// A new empty folder under the system temp dir, unique to this process and `name`.
pub fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sylvan-scene-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Write `scene.toml` (and nothing else) into a fresh folder; return its path.
pub fn scene_file(name: &str, text: &str) -> PathBuf {
    let path = temp_dir(name).join("scene.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// Smallest distance between two points of `points` (sweep along x).
pub fn min_distance(points: &[Vec2]) -> f32 {
    let mut sorted = points.to_vec();
    sorted.sort_by(|a, b| a.x.total_cmp(&b.x));
    let mut best = f32::INFINITY;
    for i in 0..sorted.len() {
        for j in i + 1..sorted.len() {
            if sorted[j].x - sorted[i].x >= best {
                break;
            }
            best = best.min(sorted[i].distance(sorted[j]));
        }
    }
    best
}

/// Smallest distance between two trees' ground positions.
pub fn min_tree_distance(trees: &[TreeInstance]) -> f32 {
    let points: Vec<Vec2> = trees
        .iter()
        .map(|t| Vec2::new(t.position.x, t.position.z))
        .collect();
    min_distance(&points)
}

/// Two species at uniform densities (300 and 150 per ha): the seeded-forest tests' forest.
pub fn two_species() -> Vec<SpeciesLayout> {
    vec![
        SpeciesLayout {
            species: 0,
            height_m: [12.0, 20.0],
            density: Density::PerHectare(300.0),
        },
        SpeciesLayout {
            species: 1,
            height_m: [5.0, 9.0],
            density: Density::PerHectare(150.0),
        },
    ]
}

/// A tree's identity, bit for bit: position, species, seed.
pub fn tree_key(t: &TreeInstance) -> (u32, u32, u32, u32) {
    (
        t.position.x.to_bits(),
        t.position.z.to_bits(),
        t.species,
        t.seed,
    )
}
