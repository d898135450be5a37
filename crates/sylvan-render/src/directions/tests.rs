//! Tests of the direction sets and the table: MNP01's counts, even spread, cells tiling the
//! sphere, the blend of the enclosing cell, and the table agreeing with
//! [`DirectionSet::nearest3`].

use super::*;
use glam::{DVec3, Vec3};
use std::collections::HashMap;
use std::f64::consts::PI;

/// xorshift64*: a seeded stream of uniform unit directions (no RNG dependency).
struct Rng(u64);

impl Rng {
    fn f32(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 40) as f32 / (1u64 << 24) as f32
    }

    fn direction(&mut self) -> Vec3 {
        let z = 2.0 * self.f32() - 1.0;
        let phi = std::f32::consts::TAU * self.f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

fn sets() -> Vec<DirectionSet> {
    (0..=MAX_LEVEL)
        .map(|l| DirectionSet::new(l).unwrap())
        .collect()
}

fn angle(a: Vec3, b: Vec3) -> f64 {
    a.as_dvec3().angle_between(b.as_dvec3())
}

/// Samples sorted by angle from `d`.
fn by_angle(set: &DirectionSet, d: Vec3) -> Vec<u32> {
    let mut order: Vec<u32> = (0..set.len() as u32).collect();
    let key = |i: &u32| angle(d, set.directions()[*i as usize]);
    order.sort_by(|a, b| key(a).total_cmp(&key(b)));
    order
}

/// `(indices, weights)` as a map from index to total weight, dropping zeros.
fn weight_map((ids, w): ([u32; 3], [f32; 3])) -> HashMap<u32, f32> {
    let mut map = HashMap::new();
    for (i, w) in ids.into_iter().zip(w).filter(|(_, w)| *w > 0.0) {
        *map.entry(i).or_insert(0.0) += w;
    }
    map
}

fn map_distance(a: &HashMap<u32, f32>, b: &HashMap<u32, f32>) -> f32 {
    let keys: std::collections::HashSet<_> = a.keys().chain(b.keys()).collect();
    keys.iter()
        .map(|k| (a.get(k).unwrap_or(&0.0) - b.get(k).unwrap_or(&0.0)).abs())
        .sum()
}

#[test]
fn counts_are_mnp01s() {
    for (level, set) in sets().iter().enumerate() {
        assert_eq!(set.len(), SAMPLE_COUNTS[level]);
        assert_eq!(set.len(), 4usize.pow(level as u32) * 4 + 2);
        assert_eq!(set.faces().len(), 8 * 4usize.pow(level as u32));
        assert_eq!(DirectionSet::with_count(set.len()).unwrap(), *set);
        assert_eq!(set.directions()[..6], sets()[0].directions()[..]);
    }
    assert_eq!(DirectionSet::new(4), Err(DirectionError::Level(4)));
    assert_eq!(DirectionSet::with_count(64), Err(DirectionError::Count(64)));
    assert!(
        DirectionError::Count(64)
            .to_string()
            .contains("6, 18, 66 or 258")
    );
}

#[test]
fn samples_are_unit_distinct_and_antipodal() {
    for set in sets() {
        for (i, d) in set.directions().iter().enumerate() {
            assert!(
                (d.length() - 1.0).abs() < 1e-6,
                "sample {i} has length {}",
                d.length()
            );
            let opposite = set.directions().iter().any(|e| (*d + *e).length() < 1e-6);
            assert!(opposite, "sample {i}'s antipode is missing");
        }
    }
}

/// Spread: the closest pair of samples vs the loneliest sample's nearest neighbour. Measured
/// for 6/18/66/258 samples: 1, 1, 0.922 (22.5° vs 24.4°), 0.728 (11.25° vs 15.5°).
/// Re-normalised midpoints crowd the 6 octahedron corners (degree 4) and stretch cells near
/// octant centres; the bounds keep that within 1/0.7 ≈ 1.4× and catch a wrong subdivision
/// (an unnormalised or misplaced midpoint halves the ratio).
#[test]
fn samples_are_evenly_spread() {
    let bounds = [0.999, 0.999, 0.9, 0.7];
    for (set, bound) in sets().iter().zip(bounds) {
        let dirs = set.directions();
        let nn: Vec<f64> = (0..dirs.len())
            .map(|i| {
                let others = (0..dirs.len()).filter(|&j| j != i);
                others
                    .map(|j| angle(dirs[i], dirs[j]))
                    .fold(f64::INFINITY, f64::min)
            })
            .collect();
        let min = nn.iter().copied().fold(f64::INFINITY, f64::min);
        let max = nn.iter().copied().fold(0.0, f64::max);
        eprintln!(
            "{} samples: min pair {:.2}°, max nearest-neighbour {:.2}°, ratio {:.3}",
            dirs.len(),
            min.to_degrees(),
            max.to_degrees(),
            min / max
        );
        assert!(
            min / max >= bound,
            "{} samples: spread ratio {}",
            dirs.len(),
            min / max
        );
    }
}

#[test]
fn cells_tile_the_sphere() {
    for set in sets() {
        let dirs: Vec<DVec3> = set.directions().iter().map(|d| d.as_dvec3()).collect();
        let mut area = 0.0;
        let mut edges = std::collections::HashSet::new();
        for &[a, b, c] in set.faces() {
            let [a3, b3, c3] = [a, b, c].map(|i| dirs[i as usize]);
            let det = a3.dot(b3.cross(c3));
            assert!(det > 0.0, "cell {a} {b} {c} winds clockwise");
            // Van Oosterom–Strackee: tan(E/2) = det / (1 + a·b + b·c + c·a).
            area += 2.0 * det.atan2(1.0 + a3.dot(b3) + b3.dot(c3) + c3.dot(a3));
            for edge in [(a, b), (b, c), (c, a)] {
                assert!(edges.insert(edge), "edge {edge:?} used twice the same way");
            }
        }
        assert!(
            (area - 4.0 * PI).abs() < 1e-4,
            "{} samples: area {area}",
            set.len()
        );
        assert!(
            edges.iter().all(|&(a, b)| edges.contains(&(b, a))),
            "the mesh has a hole"
        );
        assert_eq!(edges.len() / 2, set.len() + set.faces().len() - 2, "Euler");
    }
}

/// For 10,000 random directions per set: weights are a partition of unity, blend the samples
/// back onto the input (gnomonic barycentrics: `Σ wᵢ sᵢ ∥ d`), the angularly nearest sample
/// is always one of the 3, and the largest weight is always on one of the 3 nearest.
/// Measured for 6/18/66/258 samples: the largest weight is on the nearest sample for
/// 100/92.7/92.8/92.6% of directions; the 3 are exactly the 3 nearest for 100/69.5/66.8/70.7%
/// (near an edge's middle, the neighbouring cell's far corner can be as near as our own).
#[test]
fn nearest3_blends_the_enclosing_cell() {
    for set in sets() {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let (mut top_is_nearest, mut same_three) = (0, 0);
        for _ in 0..10_000 {
            let d = rng.direction();
            let (ids, w) = set.nearest3(d);
            assert!(w.iter().all(|&x| x >= 0.0), "{d}: negative weight {w:?}");
            assert!(
                (w.iter().sum::<f32>() - 1.0).abs() < 1e-5,
                "{d}: weights {w:?}"
            );
            let blend: Vec3 = (0..3)
                .map(|k| w[k] * set.directions()[ids[k] as usize])
                .sum();
            assert!(blend.normalize().dot(d) > 1.0 - 1e-6, "{d}: blend {blend}");

            let order = by_angle(&set, d);
            assert!(
                ids.contains(&order[0]),
                "{d}: nearest {} not in {ids:?}",
                order[0]
            );
            let top = ids[(0..3).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap()];
            assert!(
                order[..3].contains(&top),
                "{d}: top {top} not among 3 nearest"
            );
            top_is_nearest += usize::from(top == order[0]);
            same_three += usize::from(ids.iter().all(|i| order[..3].contains(i)));
        }
        eprintln!(
            "{} samples: top weight on nearest {:.1}%, same 3 as nearest {:.1}%",
            set.len(),
            top_is_nearest as f64 / 100.0,
            same_three as f64 / 100.0
        );
        assert!(top_is_nearest >= 9_000 && same_three >= 6_000);
    }
}

#[test]
fn nearest3_is_exact_on_samples_and_edges() {
    for set in sets() {
        for (i, &s) in set.directions().iter().enumerate() {
            let map = weight_map(set.nearest3(s));
            let w = map.get(&(i as u32)).copied().unwrap_or(0.0);
            assert!(w > 1.0 - 1e-6, "sample {i}: own weight {w}");
        }
        for &[a, b, _] in set.faces() {
            let [sa, sb] = [a, b].map(|i| set.directions()[i as usize]);
            let map = weight_map(set.nearest3(sa + sb));
            for i in [a, b] {
                let w = map.get(&i).copied().unwrap_or(0.0);
                assert!(
                    (w - 0.5).abs() < 1e-5,
                    "edge {a}-{b} midpoint: weights {map:?}"
                );
            }
        }
    }
}

/// Weights move continuously: across every edge, and for random small steps, the weights
/// (L1 over samples) change by at most 30× the angle moved (measured up to 14.5× for 258
/// samples over 200,000 steps: about twice the inverse cell height; a jump to a wrong cell
/// changes them by O(1), i.e. ~10⁴× a 10⁻⁴ step).
#[test]
fn nearest3_is_continuous() {
    let set = DirectionSet::new(MAX_LEVEL).unwrap();
    let step = 1e-4;
    for &[a, b, _] in set.faces() {
        let [sa, sb] = [a, b].map(|i| set.directions()[i as usize]);
        let across = sa.cross(sb).normalize() * step;
        for t in [0.1, 0.5, 0.9] {
            let on = sa.lerp(sb, t);
            let (left, right) = (set.nearest3(on + across), set.nearest3(on - across));
            let jump = map_distance(&weight_map(left), &weight_map(right));
            assert!(
                jump < 30.0 * 2.0 * step,
                "edge {a}-{b} at {t}: weights jump by {jump}"
            );
        }
    }
    let mut rng = Rng(7);
    for _ in 0..10_000 {
        let d = rng.direction();
        let e = (d + rng.direction() * step).normalize();
        let jump = map_distance(&weight_map(set.nearest3(d)), &weight_map(set.nearest3(e)));
        assert!(
            jump < 30.0 * angle(d, e) as f32 + 1e-6,
            "{d} → {e}: weights jump by {jump}"
        );
    }
}

#[test]
fn degenerate_directions_do_not_panic() {
    for set in sets() {
        let lut = DirectionLut::new(&set, DirectionLut::DEFAULT_RESOLUTION).unwrap();
        let fallback = (set.faces()[0], [1.0, 0.0, 0.0]);
        assert_eq!(set.faces()[0][0], 0);
        for bad in [Vec3::ZERO, Vec3::NAN, Vec3::new(f32::INFINITY, 0.0, 1.0)] {
            assert_eq!(set.nearest3(bad), fallback, "{bad}");
            assert_eq!(lut.lookup(bad), fallback, "{bad}");
        }
        // Power-of-two scales keep the direction exact, down to subnormals and up to overflow.
        let d = Vec3::new(3.0, -5.0, 8.0);
        for scaled in [d * 2f32.powi(-145), d * 2f32.powi(-60), d * 2f32.powi(124)] {
            assert_eq!(set.nearest3(scaled), set.nearest3(d), "{scaled}");
            assert_eq!(lut.lookup(scaled), lut.lookup(d), "{scaled}");
        }
    }
}

/// The table gives `nearest3`'s answer: the same 3 samples and weights for 10,000 random
/// directions, and the same blend on samples, edges and the octant boundaries where the
/// octahedral map folds (there a tie between two cells may pick either, with weight 0 on
/// the differing sample).
#[test]
fn lut_matches_nearest3() {
    for set in sets() {
        for resolution in [32, DirectionLut::DEFAULT_RESOLUTION, 128] {
            let lut = DirectionLut::new(&set, resolution).unwrap();
            let mut rng = Rng(0xDEAD_BEEF);
            for _ in 0..10_000 {
                let d = rng.direction();
                let ((ids, w), (lut_ids, lut_w)) = (set.nearest3(d), lut.lookup(d));
                let mut sorted = [ids, lut_ids];
                sorted.iter_mut().for_each(|s| s.sort());
                assert_eq!(sorted[0], sorted[1], "{d}: {ids:?} vs table {lut_ids:?}");
                let map = weight_map((lut_ids, lut_w));
                for (i, w) in ids.iter().zip(w) {
                    let diff = (map.get(i).copied().unwrap_or(0.0) - w).abs();
                    assert!(diff <= 1e-5, "{d}: sample {i} weight differs by {diff}");
                }
            }
            let mut special: Vec<Vec3> = set.directions().to_vec();
            for &[a, b, _] in set.faces() {
                let [sa, sb] = [a, b].map(|i| set.directions()[i as usize]);
                special.extend([sa + sb, sa.lerp(sb, 0.3)]);
            }
            for k in 0..200 {
                let (c, s) = (k as f32 * 0.0314).sin_cos();
                special.extend([Vec3::new(c, 0.0, s), Vec3::new(0.0, c, s)]);
                special.extend([Vec3::new(c, s, 0.0), Vec3::new(c, -0.0, -s.abs())]);
            }
            for d in special {
                let (a, b) = (weight_map(set.nearest3(d)), weight_map(lut.lookup(d)));
                assert!(map_distance(&a, &b) < 1e-5, "{d}: {a:?} vs table {b:?}");
            }
        }
    }
}

#[test]
fn lut_size_and_limits() {
    let set = DirectionSet::new(MAX_LEVEL).unwrap();
    let lut = DirectionLut::new(&set, DirectionLut::DEFAULT_RESOLUTION).unwrap();
    assert_eq!(size_of::<GpuDirTexel>(), 16);
    assert_eq!(lut.as_bytes().len(), 64 * 64 * 16);
    assert_eq!(lut.bytes(), 64 * 64 * 16 + 512 * 16 + 258 * 16);
    for r in [16, 32, 64, 128] {
        match DirectionLut::new(&set, r) {
            Ok(lut) => eprintln!("resolution {r}: ≤ {} cells per texel", lut.max_candidates()),
            Err(e) => eprintln!("resolution {r}: {e}"),
        }
    }
    assert!(matches!(
        DirectionLut::new(&set, 8),
        Err(DirectionError::TooCoarse { .. })
    ));
    assert_eq!(
        DirectionLut::new(&set, 0),
        Err(DirectionError::Resolution(0))
    );
    assert_eq!(
        DirectionLut::new(&set, 4096),
        Err(DirectionError::Resolution(4096))
    );
    assert!(
        DirectionLut::new(&sets()[0], 1).is_ok(),
        "8 cells fit one texel"
    );
    let faces = set.gpu_faces();
    assert_eq!(faces[5].indices[..3], set.faces()[5]);
    assert_eq!(
        set.gpu_samples()[7].direction[..3],
        set.directions()[7].to_array()
    );
}

#[test]
fn frames_are_right_handed_cameras() {
    let set = DirectionSet::new(MAX_LEVEL).unwrap();
    for (i, &s) in set.directions().iter().enumerate() {
        let (right, up, forward) = set.frame(i);
        assert!(
            forward.abs_diff_eq(-s, 1e-6),
            "sample {i}: forward {forward}"
        );
        for (v, name) in [(right, "right"), (up, "up")] {
            assert!(
                (v.length() - 1.0).abs() < 1e-5,
                "sample {i}: |{name}| = {}",
                v.length()
            );
        }
        assert!(right.dot(up).abs() < 1e-5 && right.dot(forward).abs() < 1e-5);
        assert!(up.dot(forward).abs() < 1e-5);
        assert!(
            right.cross(up).abs_diff_eq(-forward, 1e-5),
            "sample {i}: left-handed"
        );
        if s.y.abs() < 0.999 {
            assert!(
                up.y > 0.0 && right.y.abs() < 1e-6,
                "sample {i}: camera rolled"
            );
        }
    }
}
