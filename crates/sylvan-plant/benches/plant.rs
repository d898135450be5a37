//! Criterion benchmarks: deriving + meshing the presets, and meshing a 100k-leaf tree.

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use sylvan_plant::LSystem;

/// A binary tree with leaf clusters: 2^12 tips × 25 leaves ≈ 102k leaves.
pub const LEAVES_100K: &str = "
iterations: 14
angle: 30
width: 0.4
leaf: 0.1
axiom: A(2,13)
A(l,d) : d > 1 -> F(l) [&(30) A(l*0.8,d-1)] /(137.5) [&(30) A(l*0.8,d-1)]
A(l,d) : d <= 1 -> F(0.2) C C C C C F(0.1) C C C C C F(0.1) C C C C C C C C C C C C C C C
C -> [&(50) ~] /(137.5)
";

fn presets(c: &mut Criterion) {
    for name in sylvan_plant::PRESETS {
        c.bench_function(&format!("preset_{name}"), |b| {
            b.iter(|| black_box(sylvan_plant::preset(name).unwrap()))
        });
    }
    for name in sylvan_plant::PRESETS {
        let ls = LSystem::parse(sylvan_plant::preset_source(name).unwrap(), name).unwrap();
        c.bench_function(&format!("derive_{name}"), |b| {
            b.iter(|| black_box(ls.derive().unwrap()))
        });
    }
}

fn leaves_100k(c: &mut Criterion) {
    let ls = LSystem::parse(LEAVES_100K, "100k.lsys").unwrap();
    let p = sylvan_plant::from_lsystem(&ls, "big").unwrap();
    assert!(p.leaf_count >= 100_000, "{} leaves", p.leaf_count);
    eprintln!("100k tree: {:?}", p.stats());
    let mut g = c.benchmark_group("big");
    g.sample_size(10);
    g.bench_function("tree_100k_leaves_build", |b| {
        b.iter(|| black_box(sylvan_plant::from_lsystem(&ls, "big").unwrap()))
    });
    g.finish();
}

criterion_group!(benches, presets, leaves_100k);
criterion_main!(benches);
