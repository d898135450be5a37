//! Placement: determinism, density → count, minimum spacing across species, sun convention.

mod common;

use common::{min_tree_distance, scene_file};
use glam::Vec3;
use sylvan_scene::{
    Density, Placement, PlacementMethod, Scene, SpeciesLayout, Sun, Terrain, place_trees,
};

fn layout(species: u32, per_ha: f32) -> SpeciesLayout {
    SpeciesLayout {
        species,
        height_m: [5.0, 10.0],
        density: Density::PerHectare(per_ha),
    }
}

#[test]
fn density_gives_count_within_ten_percent() {
    let t = Terrain::flat([400.0, 250.0], 5.0);
    for method in [
        PlacementMethod::Poisson,
        PlacementMethod::Tiled,
        PlacementMethod::Wang,
    ] {
        for (per_ha, seed) in [(400.0, 1), (50.0, 2), (1500.0, 3)] {
            let p = Placement { seed, method };
            let n = place_trees(&t, &[layout(0, per_ha)], &p, &[])
                .unwrap()
                .trees
                .len() as f32;
            let expected = per_ha * 10.0;
            assert!(
                (n - expected).abs() <= 0.1 * expected,
                "{method:?} {per_ha}/ha: {n} vs {expected}"
            );
        }
    }
}

#[test]
fn spacing_holds_across_species() {
    let t = Terrain::procedural(3, [300.0, 200.0], 40.0);
    for method in [
        PlacementMethod::Poisson,
        PlacementMethod::Tiled,
        PlacementMethod::Wang,
    ] {
        let p = Placement { seed: 9, method };
        let placed = place_trees(&t, &[layout(0, 300.0), layout(1, 200.0)], &p, &[]).unwrap();
        assert!(placed.min_spacing_m > 2.0);
        assert!(
            min_tree_distance(&placed.trees) >= placed.min_spacing_m * 0.999,
            "{method:?}"
        );
        let n0 = placed.trees.iter().filter(|t| t.species == 0).count() as f32;
        let n1 = placed.trees.iter().filter(|t| t.species == 1).count() as f32;
        assert!((n0 / n1 - 1.5).abs() < 0.2, "{n0} : {n1}");
        for tree in &placed.trees {
            assert!(t.contains(tree.position.x, tree.position.z));
            assert_eq!(
                tree.position.y,
                t.height_at(tree.position.x, tree.position.z)
            );
            assert!((5.0..=10.0).contains(&tree.height));
            assert!((0.0..std::f32::consts::TAU).contains(&tree.rotation));
        }
    }
}

#[test]
fn same_seed_same_trees() {
    let text = "[terrain]\nprocedural = { seed = 4, size_m = [300, 200], relief_m = 30 }\n\
                [[species]]\npreset = \"pine\"\ndensity_per_ha = 200\n\
                [[species]]\npreset = \"bush\"\ndensity_per_ha = 100\n";
    let a = Scene::load(&scene_file("det-a", text)).unwrap();
    let b = Scene::load(&scene_file("det-b", text)).unwrap();
    assert_eq!(a.trees, b.trees);
    assert_eq!(a.terrain.heights, b.terrain.heights);
    let c = Scene::load(&scene_file(
        "det-c",
        &format!("{text}[placement]\nseed = 5\n"),
    ))
    .unwrap();
    assert_ne!(a.trees, c.trees);
}

#[test]
fn sun_azimuth_convention() {
    let dir = |az, el| {
        Sun {
            azimuth_deg: az,
            elevation_deg: el,
            color: [1.0; 3],
        }
        .direction()
    };
    assert!(dir(0.0, 0.0).abs_diff_eq(Vec3::Z, 1e-6));
    assert!(dir(90.0, 0.0).abs_diff_eq(Vec3::X, 1e-6));
    assert!(dir(180.0, 0.0).abs_diff_eq(-Vec3::Z, 1e-6));
    assert!(dir(0.0, 90.0).abs_diff_eq(Vec3::Y, 1e-6));
}

#[test]
fn defaults_fill_a_minimal_scene() {
    let s = Scene::parse(
        "[[species]]\npreset = \"prunus\"\ndensity_per_ha = 2\n",
        "x/scene.toml".as_ref(),
    )
    .unwrap();
    assert_eq!(s.sun, Sun::default());
    assert_eq!(s.terrain.size, [2000.0, 2000.0]);
    assert_eq!(s.species[0].height_m, [5.0, 9.0]);
    assert!(s.lod_chain.is_empty());
    assert!(
        s.camera.position.y
            > s.terrain
                .height_at(s.camera.position.x, s.camera.position.z)
    );
}

#[test]
fn vanishing_densities_place_nothing_and_finish() {
    // A density so small that the pattern radius overflows (or is infinite) once made a
    // `tiled` sampler loop forever, growing memory.
    let t = Terrain::flat([400.0, 250.0], 5.0);
    for method in [
        PlacementMethod::Poisson,
        PlacementMethod::Tiled,
        PlacementMethod::Wang,
    ] {
        for per_ha in [1e-37f32, 1e-30, f32::MIN_POSITIVE] {
            let p = Placement { seed: 1, method };
            let placed = place_trees(&t, &[layout(0, per_ha)], &p, &[]).unwrap();
            assert!(placed.trees.len() <= 1, "{method:?} {per_ha}/ha");
        }
    }
}
