//! Property tests (proptest): no input makes parsing, derivation, interpretation or meshing
//! panic; derived strings respect the declared limit; derivation is deterministic; the
//! hierarchy and instancing invariants hold on random bracketed grammars.

use proptest::prelude::*;
use sylvan_plant::{LSystem, from_lsystem};

/// Characters that make up `.lsys` files, weighted towards the interesting ones.
fn source_char() -> impl Strategy<Value = char> {
    prop::sample::select(
        "FfAB+-&^\\/|$[]!'~%(),.:<>=*^-0123456789 xyl\n#\n->"
            .chars()
            .collect::<Vec<_>>(),
    )
}

fn header(iters: u32) -> String {
    format!("iterations: {iters}\nangle: 27\nlimit: 4000\nseed: 3\n")
}

/// A balanced successor over turtle symbols, A and B, with parameters sometimes.
fn successor() -> impl Strategy<Value = String> {
    let atom = prop::sample::select(vec![
        "F", "F(0.5)", "f", "+", "-(40)", "&", "^", "\\", "/(90)", "|", "!", "!(0.05)", "'", "~",
        "~(0.3)", "A", "B", "$",
    ])
    .prop_map(str::to_string);
    let leaf = prop::collection::vec(atom, 1..6).prop_map(|v| v.concat());
    leaf.prop_recursive(3, 24, 4, |inner| {
        prop::collection::vec(inner, 1..4).prop_map(|parts| {
            let mut s = String::new();
            for (i, p) in parts.iter().enumerate() {
                if i % 2 == 1 {
                    s.push('[');
                    s.push_str(p);
                    s.push(']');
                } else {
                    s.push_str(p);
                }
            }
            s
        })
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_text_never_panics(body in prop::collection::vec(source_char(), 0..200), iters in 0u32..5) {
        let src = format!("{}axiom: F\n{}", header(iters), body.iter().collect::<String>());
        if let Ok(ls) = LSystem::parse(&src, "p.lsys") {
            if let Ok(w) = ls.derive() {
                prop_assert!(w.len() <= ls.limit);
            }
            let _ = from_lsystem(&ls, "p");
        }
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
        let src = String::from_utf8_lossy(&bytes);
        if let Ok(mut ls) = LSystem::parse(&src, "p.lsys") {
            ls.limit = ls.limit.min(5000);
            ls.iterations = ls.iterations.min(6);
            let _ = from_lsystem(&ls, "p");
        }
    }

    #[test]
    fn bracketed_grammars_build_consistent_plants(a in successor(), b in successor(), iters in 0u32..4) {
        let src = format!("{}axiom: A\nA -> {a}\nB -> {b}\nF -> F\n", header(iters));
        let ls = LSystem::parse(&src, "g.lsys").map_err(|e| TestCaseError::fail(e.to_string()))?;
        let (w1, w2) = (ls.derive(), ls.derive());
        prop_assert_eq!(w1.is_ok(), w2.is_ok());
        let Ok(w) = w1 else { return Ok(()) };
        prop_assert_eq!(&w, &w2.unwrap());
        prop_assert!(w.len() <= ls.limit);
        let p = from_lsystem(&ls, "g").map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert!(p.leaf_count <= w.count(b'~'), "cut (%) can only remove leaves");
        prop_assert_eq!(p.leaves.triangle_count(), 2 * p.leaf_count);
        // Hierarchy: nested leaf ranges, children one level deeper.
        let h = &p.hierarchy;
        prop_assert_eq!(h.nodes[0].leaves.clone(), 0..p.leaf_count as u32);
        for n in &h.nodes {
            for &c in &n.children {
                let c = &h.nodes[c as usize];
                prop_assert!(c.leaves.start >= n.leaves.start && c.leaves.end <= n.leaves.end);
                prop_assert_eq!(c.level, n.level + 1);
            }
        }
        // Instancing expands back to the flattened meshes.
        let (wood, leaves) = p.instancing.flatten();
        prop_assert_eq!(wood.triangle_count(), p.wood.triangle_count());
        prop_assert_eq!(leaves.triangle_count(), p.leaves.triangle_count());
        for m in [&p.wood, &p.leaves] {
            prop_assert!(m.positions.iter().flatten().all(|v| v.is_finite()));
            prop_assert!(m.indices.iter().all(|&i| (i as usize) < m.positions.len()));
        }
    }

    #[test]
    fn constant_arithmetic_matches_f64(a in -100i32..100, b in 1i32..50, c in -5i32..5) {
        let src = format!("{}axiom: A({a} + {b} * {c} - {a} / {b})\n", header(0));
        let w = LSystem::parse(&src, "e.lsys").unwrap().derive().unwrap();
        let want = a as f64 + (b * c) as f64 - a as f64 / b as f64;
        prop_assert!((w.args(0)[0] - want).abs() < 1e-9);
    }
}
