//! Mesh import: an OBJ+MTL in the layout of a Blender Sapling export (hand-written stand-in,
//! see data/make_sapling_obj.py), unit scale, glb round trip; and, when `SYLVAN_REAL_TREE`
//! names a tree mesh made by another tool, that file too.

use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

#[test]
fn sapling_style_obj_separates_wood_and_leaves() {
    let p = sylvan_plant::load(&data("sapling.obj")).unwrap();
    // Trunk: 6 quads; 5 branches of 5 quads; 60 leaf quads.
    assert_eq!(p.wood.triangle_count(), 12 + 5 * 10);
    assert_eq!(p.leaves.triangle_count(), 120);
    assert_eq!(p.leaf_count, 60);
    assert_eq!((p.leaf_texture.width, p.leaf_texture.height), (32, 32));
    assert!(
        p.leaf_texture.rgba.chunks(4).any(|t| t[3] == 0),
        "alpha mask kept"
    );
    // Trunk base at the origin, metres.
    assert!(p.bbox_min[1].abs() < 1e-4);
    assert!(
        (p.bbox_max[1] - 3.99).abs() < 0.05,
        "height {:?}",
        p.bbox_max
    );
    // Wood colour from Kd (linear RGB as written).
    assert!((p.wood.colors[0][0] - 0.30).abs() < 1e-3);
    // Hierarchy: the trunk with five branches, each holding its 12 leaves.
    let h = &p.hierarchy;
    assert_eq!(h.nodes.len(), 6);
    assert_eq!(h.levels(), 2);
    assert_eq!(h.nodes[0].children.len(), 5);
    for &c in &h.nodes[0].children {
        assert_eq!(h.nodes[c as usize].leaves.len(), 12);
    }
    let s = p.stats();
    assert_eq!((s.internodes, s.levels), (0, 2));
}

#[test]
fn unit_scale_and_glb_round_trip() {
    let p = sylvan_plant::load_with(&data("sapling.obj"), 0.5).unwrap();
    assert!((p.bbox_max[1] - 0.5 * 3.99).abs() < 0.03);
    let dir = std::env::temp_dir().join(format!("sylvan-import-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("sapling.glb");
    sylvan_plant::export::write_glb(&p, &out).unwrap();
    let q = sylvan_plant::load(&out).unwrap();
    assert_eq!(q.wood.triangle_count(), p.wood.triangle_count());
    assert_eq!(q.leaves.triangle_count(), p.leaves.triangle_count());
    assert_eq!(q.leaf_count, p.leaf_count);
    assert_eq!(q.hierarchy.nodes.len(), p.hierarchy.nodes.len());
    assert_eq!(q.leaf_texture.rgba, p.leaf_texture.rgba);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `SYLVAN_REAL_TREE=/path/tree.obj cargo test -p sylvan-plant --test import -- --ignored`
#[test]
#[ignore = "needs SYLVAN_REAL_TREE: a tree mesh exported by another tool (not committed)"]
fn real_tree_from_another_tool() {
    let path = PathBuf::from(std::env::var("SYLVAN_REAL_TREE").expect("set SYLVAN_REAL_TREE"));
    let p = sylvan_plant::load(&path).unwrap();
    let s = p.stats();
    eprintln!("{}: {s:?}", path.display());
    assert!(
        s.wood_triangles > 0 && s.leaf_triangles > 0,
        "wood and leaves separated"
    );
    assert!(s.levels >= 2 && s.nodes >= 2, "a hierarchy");
    let out = std::env::temp_dir().join("sylvan-real-tree.glb");
    sylvan_plant::export::write_glb(&p, &out).unwrap();
    let q = sylvan_plant::load(&out).unwrap();
    assert_eq!(q.stats().triangles, s.triangles);
    assert_eq!(q.leaf_count, p.leaf_count);
}

/// Fuzz finding (gltf target): a primitive whose POSITION names an accessor the file lacks made
/// gltf-json's validation index out of bounds — a panic message on stderr even though it was
/// caught. Now checked before validation: one error line.
#[test]
fn gltf_position_naming_a_missing_accessor_is_an_error() {
    let bad = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../sylvan/tests/data/bad/gltf_position_accessor_missing.gltf");
    let e = sylvan_plant::load(&bad).unwrap_err().to_string();
    assert!(
        e.contains(
            "malformed glTF: mesh 0 primitive 0: POSITION names accessor 0, the file has 0 — "
        ),
        "{e}"
    );
}

/// Fuzz finding (gltf target): a primitive whose `indices` accessor holds floats reached an
/// `unreachable!` in the `gltf` reader. Now the accessor types of every semantic read are
/// checked first: one error line.
#[test]
fn gltf_float_indices_are_an_error() {
    let bad = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../sylvan/tests/data/bad/gltf_float_indices.glb");
    let e = sylvan_plant::load(&bad).unwrap_err().to_string();
    assert!(
        e.contains(
            "malformed glTF: indices accessor 1 is Vec3 of F32, which glTF does not allow there — "
        ),
        "{e}"
    );
}
