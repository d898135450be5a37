//! Two-sided single leaves (issue #16): a leaf seen from behind shows its back image (paler),
//! not the front one, in the reference technique.

mod common;

use common::*;
use glam::Vec3;
use sylvan_plant::{LSystem, from_lsystem};
use sylvan_scene::{Camera, TreeInstance};

const SIZE: u32 = 64;

/// One flat chestnut leaf, 2 m long in the XY plane (front facing +Z), 10 m tall once the
/// renderer scales it to the tree's height.
fn one_leaf() -> sylvan_plant::Plant {
    let src = "iterations: 0\nangle: 30\nleaves: chestnut\nblade: 2 0 0\naxiom: ~(2)\n";
    from_lsystem(&LSystem::parse(src, "leaf.lsys").unwrap(), "leaf").unwrap()
}

#[test]
fn a_leaf_seen_from_behind_shows_its_back_image() {
    let gpu = gpu();
    let plant = one_leaf();
    assert!(!plant.leaf_back.rgba.is_empty());
    let tree = TreeInstance {
        position: Vec3::new(50.0, 0.0, 50.0),
        height: 10.0,
        rotation: 0.0,
        species: 0,
        seed: 0,
    };
    // The sun straight above: both sides of the vertical leaf get the same (grazing) light,
    // so what differs is the image.
    let light = sun(0.0, 89.0);
    let mut seen = Vec::new();
    for dz in [16.0, -16.0] {
        let camera = Camera {
            position: Vec3::new(50.0, 5.5, 50.0 + dz),
            look_at: Vec3::new(50.0, 5.5, 50.0),
            fov_deg: 40.0,
        };
        let s = scene(terrain(100.0, 17, |_, _| 0.0), vec![tree], camera, light);
        let options = sylvan_render::RenderOptions {
            width: SIZE,
            height: SIZE,
            spp: 1,
            ..Default::default()
        };
        let (img, _) = render_with_options(&gpu, &s, std::slice::from_ref(&plant), &options);
        // Two points on the blade either side of the midrib, at 55 % of its length.
        let l = luma_at(&img, &camera, Vec3::new(50.4, 5.5, 50.0), 1)
            + luma_at(&img, &camera, Vec3::new(49.6, 5.5, 50.0), 1);
        let green = img.get_pixel(
            pixel_of(&camera, SIZE, Vec3::new(50.4, 5.5, 50.0)).0,
            SIZE / 2,
        );
        seen.push((l / 2.0, *green));
    }
    let ((front, fg), (back, bg)) = (seen[0], seen[1]);
    // Measured on lavapipe: see the eprintln (the back image is about 1.6× as bright).
    eprintln!("front luma {front:.1} {fg:?}, back {back:.1} {bg:?}");
    assert!(
        fg[1] > fg[0] && bg[1] > bg[0],
        "both sides are leaves (green)"
    );
    assert!(
        back > front * 1.3,
        "the back ({back:.1}) should be paler than the front ({front:.1})"
    );
}
