//! The tables as the shader samples them (plan deviation D3): 𝔾 and 𝕋 resampled from the
//! measured (θv, θl) grid onto ridge-aligned axes — θ̄ = (θv + θl)/2 on the measured zenith
//! nodes and δ = θv − θl on nodes that crowd the diagonal — so hardware interpolation never
//! cuts across the hotspot ridge (θv = θl, φ = 0): along a sweep of θv with θl fixed, δ passes
//! the node δ = 0 exactly at θv = θl, and the interpolated peak stays at the backscatter
//! direction whatever the node spacing. Packed as `Rg16Float` (x: φ, y: δ node, z: λ node ×
//! θ̄ node); [`RidgeTables::sample`] is the CPU twin of `field_tables.wgsl`'s `table_gt`.

use super::tables::ShaderMapTables;
use std::f32::consts::FRAC_PI_2;

/// δ nodes: `2c + 1` of them, `δ_j = 90° · sgn(j − c) · ((j − c)/c)²`.
pub const DELTA_NODES: u32 = 17;

/// 𝔾 and 𝕋 on (λ, θ̄, δ, φ) nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct RidgeTables {
    /// θ̄ nodes (the measured zenith nodes), δ nodes, φ nodes.
    pub theta: u32,
    /// δ nodes ([`DELTA_NODES`]).
    pub delta: u32,
    /// φ nodes.
    pub phi: u32,
    /// The density nodes, trees per m².
    pub lambdas: Vec<f32>,
    /// `gt[(((l · theta + a) · delta + j) · phi + m)]`: (𝔾, 𝕋).
    pub gt: Vec<[f32; 2]>,
}

/// δ (radians) of node `j` of `n` (odd).
pub fn delta_at(j: u32, n: u32) -> f32 {
    let c = ((n - 1) / 2) as f32;
    let x = (j as f32 - c) / c;
    FRAC_PI_2 * x.signum() * x * x
}

/// The fractional node index of δ (radians), the inverse of [`delta_at`].
pub fn delta_index(delta: f32, n: u32) -> f32 {
    let c = ((n - 1) / 2) as f32;
    let x = (delta.abs() / FRAC_PI_2).min(1.0).sqrt();
    c + c * delta.signum() * x
}

/// The measured table `f` at (θv, θl) (radians, clamped to [0, 90°]), node φ `m`, node λ
/// `l`: linear on the two triangles of each cell split along its diagonal, so values on the
/// diagonal come from diagonal nodes only.
fn measured(t: &ShaderMapTables, f: &[f32], l: usize, tv: f32, tl: f32, m: usize) -> f32 {
    let (nt, np) = (t.theta as usize, t.phi as usize);
    let at = |v: usize, s: usize| f[((l * nt + v) * nt + s) * np + m];
    let scale = (nt - 1) as f32 / FRAC_PI_2;
    let (x, y) = (
        (tv.clamp(0.0, FRAC_PI_2) * scale).min((nt - 1) as f32),
        (tl.clamp(0.0, FRAC_PI_2) * scale).min((nt - 1) as f32),
    );
    let (i, j) = (
        (x.floor() as usize).min(nt - 2),
        (y.floor() as usize).min(nt - 2),
    );
    let (fu, fv) = (x - i as f32, y - j as f32);
    let (f00, f10, f01, f11) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
    if fu >= fv {
        (1.0 - fu) * f00 + (fu - fv) * f10 + fv * f11
    } else {
        (1.0 - fv) * f00 + (fv - fu) * f01 + fu * f11
    }
}

impl RidgeTables {
    /// Resamples `t`'s 𝔾 and 𝕋. Where (θ̄ ± δ/2) leaves [0°, 90°] the angles are clamped.
    pub fn new(t: &ShaderMapTables) -> Self {
        let (nt, nd, np, nl) = (t.theta, DELTA_NODES, t.phi, t.lambdas.len());
        let mut gt = Vec::with_capacity(nl * (nt * nd * np) as usize);
        for l in 0..nl {
            for a in 0..nt {
                let mean = t.theta_at(a);
                for j in 0..nd {
                    let d = delta_at(j, nd);
                    let (tv, tl) = (mean + 0.5 * d, mean - 0.5 * d);
                    for m in 0..np as usize {
                        gt.push([
                            measured(t, &t.g, l, tv, tl, m),
                            measured(t, &t.t, l, tv, tl, m),
                        ]);
                    }
                }
            }
        }
        Self {
            theta: nt,
            delta: nd,
            phi: np,
            lambdas: t.lambdas.clone(),
            gt,
        }
    }

    /// (𝔾, 𝕋) at transformed zeniths `tv`, `tl`, azimuth `phi` (radians, in [0, π]: |φ| is
    /// clamped to π, not folded) and density `lambda`
    /// (trees per m²): multilinear in (φ, δ node index, θ̄) within the two density slabs
    /// around `lambda`, linear between them — what the GPU's trilinear fetches give.
    pub fn sample(&self, tv: f32, tl: f32, phi: f32, lambda: f32) -> [f32; 2] {
        let (nt, nd, np) = (self.theta as usize, self.delta as usize, self.phi as usize);
        let coord = |x: f32, n: usize| {
            let x = x.clamp(0.0, (n - 1) as f32);
            let i = (x.floor() as usize).min(n - 2);
            (i, x - i as f32)
        };
        let a = coord((tv + tl) * 0.5 / FRAC_PI_2 * (nt - 1) as f32, nt);
        let j = coord(delta_index(tv - tl, self.delta), nd);
        let m = coord(
            phi.abs().min(std::f32::consts::PI) / std::f32::consts::PI * (np - 1) as f32,
            np,
        );
        let (l, fl) = lambda_coord(&self.lambdas, lambda);
        let at = |l: usize, a: usize, j: usize, m: usize| self.gt[((l * nt + a) * nd + j) * np + m];
        let mut out = [0.0f32; 2];
        for (dl, wl) in [(0, 1.0 - fl), (1, fl)] {
            for (da, wa) in [(0, 1.0 - a.1), (1, a.1)] {
                for (dj, wj) in [(0, 1.0 - j.1), (1, j.1)] {
                    for (dm, wm) in [(0, 1.0 - m.1), (1, m.1)] {
                        let w = wl * wa * wj * wm;
                        if w > 0.0 {
                            let v = at(l + dl, a.0 + da, j.0 + dj, m.0 + dm);
                            out[0] += w * v[0];
                            out[1] += w * v[1];
                        }
                    }
                }
            }
        }
        out
    }
}

/// The density slab below `lambda` and the fraction towards the next (clamped to the nodes).
pub fn lambda_coord(lambdas: &[f32], lambda: f32) -> (usize, f32) {
    let n = lambdas.len();
    let l = lambdas
        .iter()
        .rposition(|&x| x <= lambda)
        .unwrap_or(0)
        .min(n - 2);
    let (lo, hi) = (lambdas[l], lambdas[l + 1]);
    (l, ((lambda - lo) / (hi - lo).max(1e-12)).clamp(0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn delta_nodes_crowd_the_diagonal_and_invert() {
        let n = DELTA_NODES;
        assert_eq!(delta_at((n - 1) / 2, n), 0.0);
        assert!((delta_at(n - 1, n) - FRAC_PI_2).abs() < 1e-6);
        assert!((delta_at(0, n) + FRAC_PI_2).abs() < 1e-6);
        assert!(delta_at(9, n).to_degrees() < 1.5);
        for j in 0..n {
            assert!(
                (delta_index(delta_at(j, n), n) - j as f32).abs() < 1e-4,
                "node {j}"
            );
        }
    }

    #[test]
    fn lambda_slabs_clamp_at_the_ends() {
        let ls = [0.0, 0.001, 0.003];
        assert_eq!(lambda_coord(&ls, 0.0), (0, 0.0));
        let (l, f) = lambda_coord(&ls, 0.002);
        assert_eq!(l, 1);
        assert!((f - 0.5).abs() < 1e-5);
        assert_eq!(lambda_coord(&ls, 0.01), (1, 1.0));
        assert_eq!(lambda_coord(&ls, -1.0), (0, 0.0));
    }
}
