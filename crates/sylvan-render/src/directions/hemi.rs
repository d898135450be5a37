//! The hemi-octahedral diamond grid: `2(n² + n) + 1` directions over the upper hemisphere (181
//! for `n = 9`, BN12 §5's count), with the 3-view lookup of a direction. Analytic, so shaders
//! need no table ([`HEMI_GRID_WGSL`] mirrors [`HemiGrid::nearest3`]).
//!
//! A unit direction `d` (y up, `y ≥ 0`) maps to the diamond `|x| + |z| ≤ 1` of the plane by
//! `e = (d.x, d.z) / (|d.x| + d.y + |d.z|)`; the grid is every lattice point `(i, j) / n` of
//! that diamond (`|i| + |j| ≤ n`), mapped back by `(x, 1 − |x| − |z|, z)` normalised. The
//! diamond's border is the horizon, its centre the zenith. The lattice's unit squares, split
//! along the diagonal parallel to the border in each quadrant, tile the diamond exactly; a
//! direction blends the 3 corners of its triangle with barycentric weights (exact on a grid
//! direction, continuous everywhere, `Σ wᵢ eᵢ = e`).
//!
//! Index order: rows `j = −n..=n`, each row `i = −(n − |j|)..=(n − |j|)`.

use glam::{Vec2, Vec3};

/// Largest grid order accepted (2·32·33 + 1 = 2113 directions).
pub const MAX_ORDER: u32 = 32;

/// The diamond grid of order `n` over the upper hemisphere.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HemiGrid {
    n: u32,
}

impl HemiGrid {
    /// BN12 §5: 181 views (`n = 9`).
    pub const BN12: HemiGrid = HemiGrid { n: 9 };

    /// The grid of order `n` (1..=32); `None` outside that range.
    pub fn new(n: u32) -> Option<Self> {
        (1..=MAX_ORDER).contains(&n).then_some(Self { n })
    }

    /// The order `n`.
    pub fn order(self) -> u32 {
        self.n
    }

    /// Number of directions: `2(n² + n) + 1`.
    pub fn len(self) -> usize {
        let n = self.n as usize;
        2 * (n * n + n) + 1
    }

    /// Never empty (the zenith is always a direction).
    pub fn is_empty(self) -> bool {
        false
    }

    /// Index of lattice point `(i, j)` (`|i| + |j| ≤ n`).
    pub fn index(self, i: i32, j: i32) -> u32 {
        let n = self.n as i32;
        debug_assert!(i.abs() + j.abs() <= n, "({i}, {j}) outside order {n}");
        let rows_before = if j <= 0 {
            (j + n) * (j + n)
        } else {
            (n + 1) * (n + 1) + (j - 1) * (2 * n + 1) - (j - 1) * j
        };
        (rows_before + i + (n - j.abs())) as u32
    }

    /// Lattice point `(i, j)` of index `k`.
    pub fn lattice(self, k: u32) -> (i32, i32) {
        let n = self.n as i32;
        let mut k = k as i32;
        for j in -n..=n {
            let w = 2 * (n - j.abs()) + 1;
            if k < w {
                return (k - (n - j.abs()), j);
            }
            k -= w;
        }
        panic!("index out of range for order {n}");
    }

    /// Unit direction of index `k`.
    pub fn direction(self, k: u32) -> Vec3 {
        let (i, j) = self.lattice(k);
        let (x, z) = (i as f32 / self.n as f32, j as f32 / self.n as f32);
        Vec3::new(x, (1.0 - x.abs() - z.abs()).max(0.0), z).normalize()
    }

    /// Every direction, in index order.
    pub fn directions(self) -> Vec<Vec3> {
        (0..self.len() as u32).map(|k| self.direction(k)).collect()
    }

    /// The 3 directions whose blend shows `d` (any length; below the horizon folds onto it;
    /// zero or NaN gives the zenith) and their barycentric weights (≥ 0, sum 1).
    pub fn nearest3(self, d: Vec3) -> ([u32; 3], [f32; 3]) {
        let n = self.n as f32;
        let y = d.y.max(0.0);
        let s = d.x.abs() + y + d.z.abs();
        if !(s > 1e-20 && s.is_finite()) {
            return ([self.index(0, 0); 3], [1.0, 0.0, 0.0]);
        }
        let e = Vec2::new(d.x, d.z) / s;
        let (sx, sz) = (
            if e.x < 0.0 { -1 } else { 1 },
            if e.y < 0.0 { -1 } else { 1 },
        );
        let g = e.abs() * n;
        let mut c = g.floor();
        let top = n - 1.0;
        while c.x + c.y > top {
            if c.x > 0.0 {
                c.x -= 1.0;
            } else {
                c.y -= 1.0;
            }
        }
        let f = g - c;
        let (ci, cj) = (c.x as i32, c.y as i32);
        let (corners, w) = if f.x + f.y <= 1.0 || c.x + c.y >= top {
            (
                [(ci, cj), (ci + 1, cj), (ci, cj + 1)],
                [1.0 - f.x - f.y, f.x, f.y],
            )
        } else {
            (
                [(ci + 1, cj + 1), (ci + 1, cj), (ci, cj + 1)],
                [f.x + f.y - 1.0, 1.0 - f.y, 1.0 - f.x],
            )
        };
        let w = w.map(|x: f32| x.max(0.0));
        let sum = w[0] + w[1] + w[2];
        let w = if sum > 0.0 {
            w.map(|x| x / sum)
        } else {
            [1.0, 0.0, 0.0]
        };
        (corners.map(|(a, b)| self.index(sx * a, sz * b)), w)
    }
}

/// WGSL of [`HemiGrid::nearest3`]: `fn hemi_grid_nearest3(d: vec3<f32>, n: u32) -> HemiPick`
/// (`views`: 3 indices, `weights`: 3 weights) and `fn hemi_grid_index(i: i32, j: i32, n: u32)
/// -> u32`. No bindings.
pub const HEMI_GRID_WGSL: &str = r#"
// The hemi-octahedral diamond grid's 3-view lookup (sylvan_render::directions::HemiGrid).
struct HemiPick {
    views: vec3<u32>,
    weights: vec3<f32>,
};

fn hemi_grid_index(i: i32, j: i32, n_u: u32) -> u32 {
    let n = i32(n_u);
    var rows = (j + n) * (j + n);
    if (j > 0) {
        rows = (n + 1) * (n + 1) + (j - 1) * (2 * n + 1) - (j - 1) * j;
    }
    return u32(rows + i + (n - abs(j)));
}

fn hemi_grid_nearest3(d: vec3<f32>, n_u: u32) -> HemiPick {
    let n = f32(n_u);
    var out: HemiPick;
    let s = abs(d.x) + max(d.y, 0.0) + abs(d.z);
    if (!(s > 1e-20)) {
        let z = hemi_grid_index(0, 0, n_u);
        out.views = vec3<u32>(z, z, z);
        out.weights = vec3<f32>(1.0, 0.0, 0.0);
        return out;
    }
    let e = d.xz / s;
    let sx = select(1, -1, e.x < 0.0);
    let sz = select(1, -1, e.y < 0.0);
    let g = abs(e) * n;
    var c = floor(g);
    let top = n - 1.0;
    for (var k = 0; k < 2 && c.x + c.y > top; k = k + 1) {
        if (c.x > 0.0) {
            c.x = c.x - 1.0;
        } else {
            c.y = c.y - 1.0;
        }
    }
    let f = g - c;
    let ci = i32(c.x);
    let cj = i32(c.y);
    var w: vec3<f32>;
    if (f.x + f.y <= 1.0 || c.x + c.y >= top) {
        out.views = vec3<u32>(
            hemi_grid_index(sx * ci, sz * cj, n_u),
            hemi_grid_index(sx * (ci + 1), sz * cj, n_u),
            hemi_grid_index(sx * ci, sz * (cj + 1), n_u));
        w = vec3<f32>(1.0 - f.x - f.y, f.x, f.y);
    } else {
        out.views = vec3<u32>(
            hemi_grid_index(sx * (ci + 1), sz * (cj + 1), n_u),
            hemi_grid_index(sx * (ci + 1), sz * cj, n_u),
            hemi_grid_index(sx * ci, sz * (cj + 1), n_u));
        w = vec3<f32>(f.x + f.y - 1.0, 1.0 - f.y, 1.0 - f.x);
    }
    w = max(w, vec3<f32>(0.0));
    let sum = w.x + w.y + w.z;
    out.weights = select(vec3<f32>(1.0, 0.0, 0.0), w / sum, sum > 0.0);
    return out;
}
"#;

#[cfg(test)]
mod tests {
    use super::*;

    fn upper(count: usize) -> Vec<Vec3> {
        let mut s = 11u32;
        let mut rnd = || {
            s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (s >> 8) as f32 / (1u32 << 24) as f32
        };
        (0..count)
            .map(|_| {
                let (y, a) = (rnd(), rnd() * std::f32::consts::TAU);
                let r = (1.0 - y * y).sqrt();
                Vec3::new(r * a.cos(), y, r * a.sin())
            })
            .collect()
    }

    #[test]
    fn bn12_has_181_directions_indexed_both_ways() {
        assert_eq!(HemiGrid::BN12.len(), 181);
        for n in 1..=12 {
            let g = HemiGrid::new(n).unwrap();
            assert_eq!(g.len(), (2 * (n * n + n) + 1) as usize);
            for k in 0..g.len() as u32 {
                let (i, j) = g.lattice(k);
                assert_eq!(g.index(i, j), k, "order {n}");
                let d = g.direction(k);
                assert!((d.length() - 1.0).abs() < 1e-5 && d.y >= 0.0);
            }
            assert!((g.direction(g.index(0, 0)) - Vec3::Y).length() < 1e-6);
            assert!(g.direction(g.index(n as i32, 0)).y.abs() < 1e-6);
        }
        assert!(HemiGrid::new(0).is_none() && HemiGrid::new(MAX_ORDER + 1).is_none());
    }

    #[test]
    fn lookup_is_a_partition_of_unity_exact_on_grid_views_and_near() {
        for n in [1, 2, 5, 9] {
            let g = HemiGrid::new(n).unwrap();
            for d in upper(3000) {
                let (v, w) = g.nearest3(d);
                let sum: f32 = w.iter().sum();
                assert!((sum - 1.0).abs() < 1e-5);
                assert!(w.iter().all(|&x| x >= 0.0));
                // The blend of the views' diamond points is d's diamond point.
                let e = |x: Vec3| Vec2::new(x.x, x.z) / (x.x.abs() + x.y.max(0.0) + x.z.abs());
                let blend = v
                    .iter()
                    .zip(w)
                    .fold(Vec2::ZERO, |a, (k, x)| a + e(g.direction(*k)) * x);
                assert!((blend - e(d)).length() < 1e-4, "order {n}: {d}");
                // The heaviest view is within one lattice step of d.
                let best = v[(0..3).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap()];
                let step = (g.direction(best) - d).length();
                assert!(step < 3.0 / n as f32, "order {n}: {d} → {step}");
            }
            for k in 0..g.len() as u32 {
                let (v, w) = g.nearest3(g.direction(k));
                let top = v.iter().zip(w).find(|(x, _)| **x == k).map_or(0.0, |x| x.1);
                assert!(top > 1.0 - 1e-4, "order {n} view {k}: {v:?} {w:?}");
            }
        }
        // Degenerate input: the zenith.
        let g = HemiGrid::BN12;
        assert_eq!(g.nearest3(Vec3::ZERO).0[0], g.index(0, 0));
        assert_eq!(g.nearest3(Vec3::NAN).0[0], g.index(0, 0));
        // Below the horizon folds onto it.
        let (v, w) = g.nearest3(Vec3::new(1.0, -1.0, 0.0));
        let best = (0..3).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap();
        assert_eq!(v[best], g.index(9, 0));
    }
}
