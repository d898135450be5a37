//! ABOP ch. 1 examples typed in from the book: fig. 1.24 (a)–(f) segment counts and
//! proportions, the parametric derivation of fig. 1.30 (p. 42), stochastic productions
//! (p. 28) and context-sensitive signal propagation (p. 31).

use sylvan_plant::{LSystem, from_lsystem};

fn plant(src: &str) -> sylvan_plant::Plant {
    let ls = LSystem::parse(src, "test.lsys").unwrap_or_else(|e| panic!("{e}"));
    from_lsystem(&ls, "test").unwrap_or_else(|e| panic!("{e}"))
}

/// (F count, X count) after n steps of X → (f F's, x X's), F → FF.
fn fx(n: u32, f_per_x: u64, x_per_x: u64) -> u64 {
    let (mut f, mut x) = (0u64, 1u64);
    for _ in 0..n {
        f = 2 * f + f_per_x * x;
        x *= x_per_x;
    }
    f
}

const FIG_124: [(&str, &str, u64); 6] = [
    (
        "a",
        "iterations: 5\nangle: 25.7\naxiom: F\nF -> F[+F]F[-F]F\n",
        3125,
    ),
    (
        "b",
        "iterations: 5\nangle: 20\naxiom: F\nF -> F[+F]F[-F][F]\n",
        3125,
    ),
    (
        "c",
        "iterations: 4\nangle: 22.5\naxiom: F\nF -> FF-[-F+F+F]+[+F-F-F]\n",
        4096,
    ),
    (
        "d",
        "iterations: 7\nangle: 20\naxiom: X\nX -> F[+X]F[-X]+X\nF -> FF\n",
        0,
    ),
    (
        "e",
        "iterations: 7\nangle: 25.7\naxiom: X\nX -> F[+X][-X]FX\nF -> FF\n",
        0,
    ),
    (
        "f",
        "iterations: 5\nangle: 22.5\naxiom: X\nX -> F-[[X]+X]+F[+X]-X\nF -> FF\n",
        0,
    ),
];

#[test]
fn fig_1_24_segment_counts() {
    let expect = |fig: &str, n: u64| match fig {
        "d" | "e" => fx(7, 2, 3),
        "f" => fx(5, 2, 4),
        _ => n,
    };
    for (fig, src, n) in FIG_124 {
        let p = plant(src);
        assert_eq!(p.internodes as u64, expect(fig, n), "fig. 1.24 ({fig})");
    }
    assert_eq!(fx(7, 2, 3), 4118);
    assert_eq!(fx(5, 2, 4), 992);
}

#[test]
fn fig_1_24_proportions() {
    // Width is 0.1 step (radius 0.05) by default; heights in steps.
    let dims = |src: &str| {
        let p = plant(src);
        let w = p.bbox_max[0] - p.bbox_min[0];
        let h = p.bbox_max[1] - p.bbox_min[1];
        assert!(
            p.bbox_max[2] - p.bbox_min[2] < 0.2,
            "2D figures stay in the z = 0 plane"
        );
        (w, h)
    };
    // (a): the main axis F→F·F·F (branches aside) is 3^5 = 243 straight steps, the highest
    // point. (b): F→F[+F]F[-F][F] moves 2 steps and its top branch [F] climbs on:
    // H(n) = 2^n + H(n-1), H(5) = 63.
    for (fig, want) in [(0, 243.0), (1, 63.0)] {
        let (_, h) = dims(FIG_124[fig].1);
        assert!(
            (h - want).abs() < 0.2,
            "fig. 1.24 ({}) height {h}",
            FIG_124[fig].0
        );
    }
    // (d): the main axis X → F…F…+X leans left, each level 2^k steps; the tree is taller than
    // wide, as in the book; likewise (a), (b), (e). (c) and (f) are bushier: nearly as wide.
    let ranges = [
        (0.25, 0.45),
        (0.35, 0.6),
        (0.5, 0.8),
        (0.45, 0.7),
        (0.38, 0.6),
        (0.0, 9.0),
    ];
    for (k, (fig, src, _)) in FIG_124.iter().enumerate() {
        let (w, h) = dims(src);
        let r = w / h;
        eprintln!("fig. 1.24 ({fig}): {w:.1} x {h:.1}, ratio {r:.3}");
        assert!(
            r > ranges[k].0 && r < ranges[k].1,
            "fig. 1.24 ({fig}): width/height {r}"
        );
    }
    // + turns counter-clockwise seen from +Z: a single `+F` from an upward heading goes to −X.
    let p = plant("iterations: 0\nangle: 90\naxiom: +F\n");
    assert!(
        p.bbox_min[0] < -0.9 && p.bbox_max[0] < 0.1,
        "{:?} {:?}",
        p.bbox_min,
        p.bbox_max
    );
}

#[test]
fn parametric_fig_1_30_derives_as_in_the_book() {
    let src = "iterations: 5\nangle: 90\naxiom: B(2)A(4,4)\n\
               A(x,y) : y <= 3 -> A(x*2,x+y)\n\
               A(x,y) : y > 3 -> B(x)A(x/y,0)\n\
               B(x) : x < 1 -> C\n\
               B(x) : x >= 1 -> B(x-1)\n";
    let ls = LSystem::parse(src, "fig130.lsys").unwrap();
    let book = [
        "B(2)A(4,4)",
        "B(1)B(4)A(1,0)",
        "B(0)B(3)A(2,1)",
        "CB(2)A(4,3)",
        "CB(1)A(8,7)",
    ];
    for (n, s) in book.iter().enumerate() {
        assert_eq!(ls.derive_n(n as u32).unwrap().to_string(), *s, "step {n}");
    }
    let w5 = ls.derive_n(5).unwrap();
    assert_eq!(w5.len(), 4);
    assert!((w5.args(3)[0] - 8.0 / 7.0).abs() < 1e-12, "{w5}");
}

#[test]
fn parametric_expressions_and_functions() {
    let src = "iterations: 1\nangle: 90\ndefine: r = 0.5\naxiom: A(9)\n\
               A(x) : x > 1 && sqrt(x) == 3 -> B(x^0.5, -2^2, sin(90), max(x, 10) * r, (1+2)*3)\n";
    let w = LSystem::parse(src, "e.lsys").unwrap().derive().unwrap();
    assert_eq!(w.to_string(), "B(3,-4,1,5,9)");
}

#[test]
fn stochastic_is_seeded_and_follows_weights() {
    let src = |seed: u64| {
        format!(
            "iterations: 1\nangle: 25\nseed: {seed}\naxiom: {}\nF ->(0.33) F[+F]F[-F]F\nF ->(0.33) F[+F]F\nF ->(0.34) F[-F]F\n",
            "F".repeat(3000)
        )
    };
    let a = LSystem::parse(&src(7), "s.lsys").unwrap().derive().unwrap();
    let b = LSystem::parse(&src(7), "s.lsys").unwrap().derive().unwrap();
    let c = LSystem::parse(&src(8), "s.lsys").unwrap().derive().unwrap();
    assert_eq!(a, b, "same seed, same string");
    assert_ne!(a, c, "another seed, another string");
    // Each F becomes 5 F (p1) or 3 F (p2, p3): E[F] = 3000·(0.33·5 + 0.67·3) = 10980.
    let f = a.count(b'F') as f64;
    assert!((f - 10980.0).abs() < 300.0, "F count {f}");
    // p3 alone turns right: ~0.34·3000 `-` outside p1.
    let plus = a.count(b'+') as f64;
    assert!((plus - 0.66 * 3000.0).abs() < 150.0, "+ count {plus}");
    // Same seed gives the same plant geometry.
    let p1 = plant(&src(5));
    let p2 = plant(&src(5));
    assert_eq!(p1.wood.positions, p2.wood.positions);
}

#[test]
fn context_sensitive_signal_propagation() {
    // ABOP p. 31: a signal b moves right along a filament of a's.
    let ls = LSystem::parse(
        "iterations: 3\nangle: 0\naxiom: baaaaaaaa\nb < a -> b\nb -> a\n",
        "c.lsys",
    )
    .unwrap();
    assert_eq!(ls.derive_n(1).unwrap().to_string(), "abaaaaaaa");
    assert_eq!(ls.derive().unwrap().to_string(), "aaabaaaaa");
    // Contexts skip ignored symbols and branches.
    let ls = LSystem::parse(
        "iterations: 1\nangle: 30\nignore: + -\naxiom: A[+B]+C D\nA < C > D -> X\nA < B -> Y\n",
        "c.lsys",
    )
    .unwrap();
    assert_eq!(ls.derive().unwrap().to_string(), "A[+Y]+XD");
}

#[test]
fn turtle_symbols() {
    // Width with `!`, leaves with `~`, cut with `%`, colour with `'`.
    let p =
        plant("iterations: 0\nangle: 90\nwidth: 0.2\naxiom: F!F!(0.05)F[&~(2)]['~]F[F%FFFF]F\n");
    assert_eq!(p.internodes, 6);
    assert_eq!(p.leaf_count, 2);
    assert_eq!(p.leaves.triangle_count(), 4);
    let p = plant("iterations: 0\nangle: 90\naxiom: F f F | F $ F\n");
    assert_eq!(p.internodes, 4);
}

#[test]
fn tropism_bends_and_turns_sharing_off() {
    let straight = "iterations: 0\nangle: 90\naxiom: &(60) F F F F F F F F [F][F]\n";
    let bent =
        "iterations: 0\nangle: 90\ntropism: 0 -1 0 0.3\naxiom: &(60) F F F F F F F F [F][F]\n";
    let (a, b) = (plant(straight), plant(bent));
    assert!(
        b.bbox_min[1] < a.bbox_min[1] - 0.5,
        "gravitropism pulls the branch down: {:?} vs {:?}",
        b.bbox_min,
        a.bbox_min
    );
    assert!(
        a.instancing.objects.len() > b.instancing.objects.len(),
        "identical [F] shared without tropism only"
    );
}
