//! Library integration tests: presets, hierarchy (LCV04 §3.2.1), instancing (MNP01), errors,
//! limits, import/export round trips.

#![allow(clippy::needless_range_loop)]

use std::time::Instant;
use sylvan_plant::{LSystem, Plant, PlantError, from_lsystem, preset};

fn err(src: &str) -> String {
    match LSystem::parse(src, "bad.lsys").and_then(|ls| from_lsystem(&ls, "bad")) {
        Ok(_) => panic!("expected an error for {src:?}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn presets_are_trees() {
    // Triangle budgets for a forest on a software rasteriser (wood + leaf cards), the least
    // number of leaf cards for a closed crown, and the most wood may take of the budget.
    for (name, min_h, max_tris, min_cards) in [
        ("pine", 14.0, 6_000, 1_500),
        ("prunus", 6.0, 8_000, 1_800),
        ("bush", 1.0, 2_500, 700),
    ] {
        let t = Instant::now();
        let p = preset(name).unwrap();
        let s = p.stats();
        eprintln!("{name}: {s:?} in {:?}", t.elapsed());
        assert!(
            s.triangles <= max_tris && s.triangles > max_tris / 2,
            "{name}: {} triangles, budget {max_tris}",
            s.triangles
        );
        assert!(s.leaves >= min_cards, "{name}: {} leaf cards", s.leaves);
        assert!(
            s.wood_triangles * 3 <= s.triangles,
            "{name}: wood {} of {} triangles",
            s.wood_triangles,
            s.triangles
        );
        assert!(
            sylvan_plant::texture::coverage(&p.leaf_texture) >= 0.45,
            "{name}: leaf cards too transparent"
        );
        let h = p.bbox_max[1] - p.bbox_min[1];
        let w = (p.bbox_max[0] - p.bbox_min[0]).max(p.bbox_max[2] - p.bbox_min[2]);
        assert!(h > min_h, "{name} height {h}");
        assert!(p.bbox_min[1] > -0.05, "{name} is above ground");
        assert!(s.levels >= 3, "{name}: {} levels", s.levels);
        assert_eq!(
            p.leaf_texture.rgba.len(),
            (p.leaf_texture.width * p.leaf_texture.height * 4) as usize
        );
        for m in [&p.wood, &p.leaves] {
            let n = m.positions.len();
            assert!(m.normals.len() == n && m.uvs.len() == n && m.colors.len() == n);
            assert!(m.indices.iter().all(|&i| (i as usize) < n));
        }
        match name {
            "bush" => assert!(w > h, "bush is wider than tall"),
            "prunus" => assert!(w > 0.7 * h, "prunus has a broad crown"),
            _ => assert!(h > 1.3 * w, "pine is conical"),
        }
    }
    assert!(matches!(preset("oak"), Err(PlantError::UnknownPreset(_))));
}

#[test]
fn pine_instancing_is_ten_times_smaller() {
    let p = preset("pine").unwrap();
    let s = p.stats();
    eprintln!(
        "pine: instanced {} B, flattened {} B, {} instances of {} objects, {} levels",
        s.instanced_bytes, s.flattened_bytes, s.instances, s.base_objects, s.instance_levels
    );
    assert!(s.flattened_bytes >= 10 * s.instanced_bytes);
    // MNP01's levels: needle tuft → bough → main branch → tree.
    assert!(s.instance_levels >= 4);
    // Expanding the instances gives the flattened plant back.
    let (wood, leaves) = p.instancing.flatten();
    assert_eq!(wood.positions.len(), p.wood.positions.len());
    assert_eq!(leaves.triangle_count(), p.leaves.triangle_count());
    let bb = |m: &sylvan_plant::Mesh| {
        let mut lo = [f32::MAX; 3];
        let mut hi = [f32::MIN; 3];
        for q in &m.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(q[k]);
                hi[k] = hi[k].max(q[k]);
            }
        }
        (lo, hi)
    };
    let (a, b) = (bb(&wood), bb(&p.wood));
    for k in 0..3 {
        assert!(
            (a.0[k] - b.0[k]).abs() < 1e-3 && (a.1[k] - b.1[k]).abs() < 1e-3,
            "{a:?} vs {b:?}"
        );
    }
    let (a, b) = (bb(&leaves), bb(&p.leaves));
    for k in 0..3 {
        assert!(
            (a.0[k] - b.0[k]).abs() < 1e-3 && (a.1[k] - b.1[k]).abs() < 1e-3,
            "{a:?} vs {b:?}"
        );
    }
}

fn check_hierarchy(p: &Plant) {
    let h = &p.hierarchy;
    let root = &h.nodes[0];
    assert!(root.parent.is_none());
    assert_eq!(root.leaves, 0..p.leaf_count as u32);
    for k in 0..3 {
        // Boxes are conservative: internodes are bounded as spheres around their ends.
        assert!(
            root.bbox_min[k] <= p.bbox_min[k] + 1e-3 && root.bbox_max[k] >= p.bbox_max[k] - 1e-3
        );
        assert!(root.bbox_min[k] >= p.bbox_min[k] - 0.5 && root.bbox_max[k] <= p.bbox_max[k] + 0.5);
    }
    for (i, n) in h.nodes.iter().enumerate() {
        for &c in &n.children {
            let c = &h.nodes[c as usize];
            assert_eq!(c.parent, Some(i as u32));
            assert_eq!(c.level, n.level + 1);
            assert!(c.leaves.start >= n.leaves.start && c.leaves.end <= n.leaves.end);
            for k in 0..3 {
                assert!(
                    c.bbox_min[k] >= n.bbox_min[k] - 1e-4 && c.bbox_max[k] <= n.bbox_max[k] + 1e-4,
                    "child box inside parent box"
                );
            }
        }
        assert_eq!(
            n.leaf_indices.start,
            h.leaf_first_index[n.leaves.start as usize]
        );
        // Every leaf of the subtree lies in the box.
        for ix in &p.leaves.indices[n.leaf_indices.start as usize..n.leaf_indices.end as usize] {
            let q = p.leaves.positions[*ix as usize];
            for k in 0..3 {
                assert!(q[k] >= n.bbox_min[k] - 1e-3 && q[k] <= n.bbox_max[k] + 1e-3);
            }
        }
    }
    let own: u32 = h.nodes.iter().map(|n| n.own_leaves).sum();
    assert_eq!(own as usize, p.leaf_count);
}

#[test]
fn hierarchy_boxes_nest() {
    for name in ["pine", "prunus", "bush"] {
        let p = preset(name).unwrap();
        check_hierarchy(&p);
    }
    // LCV04 §3.2.1 on a tiny string: trunk with two branches, one with a sub-branch.
    let ls = LSystem::parse(
        "iterations: 0\nangle: 90\naxiom: F[+F[-F~]]F[-F~]F~\n",
        "t.lsys",
    )
    .unwrap();
    let p = from_lsystem(&ls, "t").unwrap();
    assert_eq!(p.hierarchy.nodes.len(), 4);
    assert_eq!(p.hierarchy.levels(), 3);
    assert_eq!(p.hierarchy.nodes[0].own_leaves, 1);
    check_hierarchy(&p);
}

#[test]
fn errors_name_file_line_col() {
    let cases = [
        (
            "iterations: 2\nangle: 20\naxiom: F\nF -> F[+F\n",
            "bad.lsys:4:7: unbalanced '['",
        ),
        (
            "iterations: 2\nangle: 20\naxiom: F\nF -> F]+F\n",
            "bad.lsys:4:7: unbalanced ']'",
        ),
        (
            "iterations: 2\nangle: 20\naxiom: F\nF -> F@F\n",
            "bad.lsys:4:7: unknown symbol '@'",
        ),
        (
            "iterations: 2\nangle: 20\naxiom: A(1)\nA(x) -> A(x*)\n",
            "bad.lsys:4:13: expected a number",
        ),
        (
            "iterations: 2\nangle: 20\naxiom: A(1)\nA(x) -> A(x/0)\n",
            "bad.lsys:4:12: division by zero",
        ),
        (
            "iterations: 2\nangle: 20\naxiom: A(0)\nA(x) -> A(1/x)\n",
            "bad.lsys:4:12: division by zero",
        ),
        (
            "iterations: 2\nangle: 20\nF -> FF\n",
            "bad.lsys:1:1: missing axiom",
        ),
        (
            "iterations: 2\nangle: 20\naxiom: A(1)\nA(x) -> A(y)\n",
            "bad.lsys:4:11: unknown name 'y'",
        ),
        (
            "iterations: 2\nangle: 20\naxiom: F\ncolour: red\n",
            "bad.lsys:4:1: unknown header key 'colour'",
        ),
        (
            "iterations: 2\nangle: 20\naxiom: F\nF -> F(sqrt(-1))\n",
            "bad.lsys:4:8:",
        ),
    ];
    for (src, want) in cases {
        let e = err(src);
        assert!(e.starts_with(want), "{e:?} should start with {want:?}");
        assert!(e.contains(" — "), "{e:?} has a fix");
        assert!(!e.contains('\n'));
    }
}

#[test]
fn explosion_stops_at_the_declared_limit() {
    let t = Instant::now();
    let e = err("iterations: 60\nangle: 20\nlimit: 100000\naxiom: F\nF -> FF\n");
    assert!(
        e.starts_with("bad.lsys:5:1: derivation exceeds the declared limit of 100000 modules"),
        "{e}"
    );
    let e = err("iterations: 100\nangle: 20\naxiom: F\nF -> F[+F][-F]F\n");
    assert!(e.contains("declared limit of 1000000"), "{e}");
    assert!(
        t.elapsed().as_secs() < 20,
        "bounded time: {:?}",
        t.elapsed()
    );
}

#[test]
fn export_and_reimport_round_trip() {
    let dir = std::env::temp_dir().join(format!("sylvan-plant-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = preset("bush").unwrap();
    let a = dir.join("bush.glb");
    sylvan_plant::export::write_glb(&p, &a).unwrap();
    let q = sylvan_plant::load(&a).unwrap();
    assert_eq!(q.wood.triangle_count(), p.wood.triangle_count());
    assert_eq!(q.leaves.triangle_count(), p.leaves.triangle_count());
    assert_eq!(
        (q.leaf_texture.width, q.leaf_texture.height),
        (p.leaf_texture.width, p.leaf_texture.height)
    );
    assert_eq!(q.leaf_texture.rgba, p.leaf_texture.rgba);
    for k in 0..3 {
        assert!((q.bbox_max[k] - q.bbox_min[k] - (p.bbox_max[k] - p.bbox_min[k])).abs() < 1e-3);
    }
    assert!(q.hierarchy.levels() >= 2);
    check_hierarchy(&q);
    // Second round trip is stable.
    let b = dir.join("bush2.glb");
    sylvan_plant::export::write_glb(&q, &b).unwrap();
    let r = sylvan_plant::load(&b).unwrap();
    assert_eq!(r.wood.positions.len(), q.wood.positions.len());
    for (a, b) in r.wood.positions.iter().zip(&q.wood.positions) {
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() < 1e-5, "{a:?} vs {b:?}");
        }
    }
    assert_eq!(r.leaves.indices, q.leaves.indices);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn malformed_meshes_are_clear_errors() {
    let dir = std::env::temp_dir().join(format!("sylvan-plant-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let glb = dir.join("bad.glb");
    std::fs::write(&glb, b"glTF\x02\0\0\0garbage").unwrap();
    let e = sylvan_plant::load(&glb).unwrap_err().to_string();
    assert!(e.contains("bad.glb: malformed glTF"), "{e}");
    let gltf = dir.join("bad.gltf");
    std::fs::write(&gltf, b"{\"asset\":{\"version\":\"2.0\"},\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":7}}]}]}").unwrap();
    let e = sylvan_plant::load(&gltf).unwrap_err().to_string();
    assert!(e.contains("bad.gltf: malformed glTF"), "{e}");
    let obj = dir.join("bad.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nf 1 2 9\n").unwrap();
    let e = sylvan_plant::load(&obj).unwrap_err().to_string();
    assert!(
        e.contains("bad.obj: malformed OBJ") || e.contains("out of range"),
        "{e}"
    );
    let empty = dir.join("empty.obj");
    std::fs::write(&empty, "# nothing\n").unwrap();
    let e = sylvan_plant::load(&empty).unwrap_err().to_string();
    assert!(e.contains("no triangles"), "{e}");
    let e = sylvan_plant::load(&dir.join("missing.obj"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing.obj: cannot read"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn twig_width_skips_thin_wood() {
    // Trunk 0.1 m, then a branch of 0.01 m: with `twig: 0.02` only the trunk is a cylinder,
    // the thin branch still moves the turtle (its leaf sits at the branch tip).
    let src = |twig: &str| {
        format!(
            "iterations: 0\nangle: 90\n{twig}axiom: !(0.1) F(1) [+ !(0.01) F(1) F(1) ~(0.2)] F(1)\n"
        )
    };
    let all = from_lsystem(&LSystem::parse(&src(""), "t.lsys").unwrap(), "t").unwrap();
    let cut = from_lsystem(
        &LSystem::parse(&src("twig: 0.02\n"), "t.lsys").unwrap(),
        "t",
    )
    .unwrap();
    assert_eq!(all.internodes, 4);
    assert_eq!(cut.internodes, 2);
    assert!(cut.wood.triangle_count() < all.wood.triangle_count());
    assert_eq!(cut.leaf_count, 1);
    assert_eq!(
        cut.leaves.positions, all.leaves.positions,
        "leaf placed as without twig:"
    );
    // The twig-only branch folds into the trunk's node (it draws no wood).
    assert_eq!(cut.hierarchy.nodes.len(), 1);
    assert_eq!(all.hierarchy.nodes.len(), 2);
    check_hierarchy(&cut);
    let e = err("iterations: 0\nangle: 90\ntwig: -1\naxiom: F\n");
    assert!(e.contains("bad.lsys:3:") && e.contains("twig"), "{e}");
}

/// The broadleaf presets with individual leaves (issue #16): leaf and triangle counts in
/// GPSS07's range, 2–10 triangles per leaf, every leaf on a petiole hanging from a drawn twig,
/// and the same plant every time.
#[test]
fn broadleaf_presets_have_individual_leaves_on_petioles() {
    use sylvan_plant::turtle;
    for name in ["chestnut", "beech"] {
        let t = Instant::now();
        let p = preset(name).unwrap();
        let s = p.stats();
        eprintln!("{name}: {s:?} in {:?}", t.elapsed());
        assert!(
            (10_000..=25_000).contains(&s.leaves),
            "{name}: {} leaves",
            s.leaves
        );
        assert!(
            (60_000..=250_000).contains(&s.triangles),
            "{name}: {} triangles",
            s.triangles
        );
        // Each leaf is its own small mesh of 2–10 triangles.
        let firsts = &p.hierarchy.leaf_first_index;
        assert_eq!(firsts.len(), s.leaves + 1);
        for w in firsts.windows(2) {
            let tris = (w[1] - w[0]) / 3;
            assert!(
                (2..=10).contains(&tris),
                "{name}: a leaf of {tris} triangles"
            );
        }
        assert_eq!(*firsts.last().unwrap() as usize, p.leaves.indices.len());
        // Front, back and normal map, all the same size.
        for t in [&p.leaf_back, &p.leaf_normal] {
            assert_eq!(
                (t.width, t.height),
                (p.leaf_texture.width, p.leaf_texture.height)
            );
        }
        // Every leaf starts at a point of a drawn twig (the end of an internode), and the
        // start of its mesh is its petiole: opaque in the texture at the mesh's base.
        let src = sylvan_plant::preset_source(name).unwrap();
        let ls = LSystem::parse(src, name).unwrap();
        let interp = turtle::interpret(&ls, &ls.derive().unwrap()).unwrap();
        let sk = &interp.skeleton;
        let key = |v: glam::Vec3| (v * 1e4).round().as_ivec3().to_array();
        let drawn: std::collections::HashSet<[i32; 3]> = sk
            .segments
            .iter()
            .flat_map(|s| s.iter().map(|&i| key(sk.points[i as usize].pos)))
            .collect();
        assert_eq!(sk.leaves.len(), s.leaves);
        for (i, l) in sk.leaves.iter().enumerate() {
            assert!(
                drawn.contains(&key(l.pos)),
                "{name}: leaf {i} hangs in the air"
            );
        }
        let tex = &p.leaf_texture;
        let per_leaf = p.leaves.positions.len() / s.leaves;
        for i in (0..s.leaves).step_by(97) {
            let base = i * per_leaf;
            let uv = p.leaves.uvs[base];
            assert!(
                uv[1] > 0.99,
                "{name}: leaf {i} does not start at its petiole"
            );
            let q = glam::Vec3::from(p.leaves.positions[base]);
            assert!(
                (q - sk.leaves[i].pos).length() < 1e-4,
                "{name}: leaf {i} base"
            );
        }
        // No two leaves coincide (a leaf emitted twice at one turtle state is drawn twice).
        let mut seen = std::collections::HashSet::new();
        for w in firsts.windows(2) {
            let mut k: Vec<[i32; 3]> = p.leaves.indices[w[0] as usize..w[1] as usize]
                .iter()
                .map(|&i| key(glam::Vec3::from(p.leaves.positions[i as usize])))
                .collect();
            k.sort();
            k.dedup();
            assert!(seen.insert(k), "{name}: two leaves coincide");
        }
        // Through the importer: the same leaves (blades), not groups of them.
        let dir = std::env::temp_dir().join(format!("sylvan-blades-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let glb = dir.join(format!("{name}.glb"));
        sylvan_plant::export::write_glb(&p, &glb).unwrap();
        let q = sylvan_plant::load(&glb).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(
            q.leaf_count, s.leaves,
            "{name}: leaves through the importer"
        );
        // The petiole in the texture: opaque just above the bottom edge, in the middle.
        let (x, y) = (tex.width / 2, tex.height - 4);
        assert!(
            tex.rgba[((y * tex.width + x) * 4 + 3) as usize] >= 128,
            "{name}: no petiole"
        );
        // Deterministic.
        let q = preset(name).unwrap();
        assert_eq!(p.leaves, q.leaves, "{name}");
        assert_eq!(p.wood, q.wood, "{name}");
        let h = p.bbox_max[1] - p.bbox_min[1];
        let w = (p.bbox_max[0] - p.bbox_min[0]).max(p.bbox_max[2] - p.bbox_min[2]);
        eprintln!("{name}: {h:.1} m tall, {w:.1} m wide");
        match name {
            "chestnut" => assert!(w > 0.7 * h && h > 10.0, "chestnut: broad crown, {w} × {h}"),
            _ => assert!(h > w && h > 12.0, "beech: taller than wide, {w} × {h}"),
        }
    }
}

#[test]
fn blade_header_is_checked() {
    for (src, want) in [
        (
            "iterations: 0\nangle: 30\nleaves: chestnut\nblade: 3 20 30\naxiom: ~\n",
            "bad.lsys:4:8: blade rows must be 1 or 2",
        ),
        (
            "iterations: 0\nangle: 30\nleaves: beech\nblade: 1 95 0\naxiom: ~\n",
            "bad.lsys:4:10: blade fold must be 0–80 degrees",
        ),
        (
            "iterations: 0\nangle: 30\nleaves: beech\nblade: 1 10\naxiom: ~\n",
            "bad.lsys:4:8: blade needs 3 numbers",
        ),
        (
            "iterations: 0\nangle: 30\nleaves: beech\nblade: 1 x 0\naxiom: ~\n",
            "bad.lsys:4:10:",
        ),
        (
            "iterations: 0\nangle: 30\nblade: 2 20 30\naxiom: ~\n",
            "bad.lsys:3:8: `blade:` shapes single leaves",
        ),
        (
            "iterations: 0\nangle: 30\nleaves: maple\naxiom: ~\n",
            "bad.lsys:3:9: unknown leaf kind",
        ),
    ] {
        let e = err(src);
        assert!(e.starts_with(want), "{src:?}: {e}");
    }
    // One leaf: 8 triangles (2 rows) or 4 (1 row), facing U.
    for (rows, tris) in [(2, 8), (1, 4)] {
        let src = format!(
            "iterations: 0\nangle: 30\nleaves: chestnut\nblade: {rows} 20 30\naxiom: ~(0.2)\n"
        );
        let p = from_lsystem(&LSystem::parse(&src, "one.lsys").unwrap(), "one").unwrap();
        assert_eq!(p.leaves.triangle_count(), tris);
        assert_eq!(p.leaf_count, 1);
        let n: f32 =
            p.leaves.normals.iter().map(|n| n[2]).sum::<f32>() / p.leaves.normals.len() as f32;
        assert!(n > 0.7, "the leaf faces +Z: mean normal z {n}");
    }
}
