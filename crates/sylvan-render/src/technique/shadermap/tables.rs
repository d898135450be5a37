//! The shader-map's tables (BN12 §6: 𝔾 and 𝕋 eq. 14–16, 𝔻 eq. 18–19, 𝔼 eq. 21) as measured,
//! and their codec.
//!
//! Axes, all in BN12's transformed space (the forest scaled vertically by `2/h`, so crowns are
//! near-spheres and the angles mean the same for every species mix): `θ` (view or light zenith)
//! on `theta` equal nodes of [0°, 90°], `φ` (the azimuth between view and light) on `phi`
//! equal nodes of [0°, 180°], `λ` (trees per m²) on [`ShaderMapTables::lambdas`] (node 0 is no
//! tree at all).

use crate::bake::codec::{Codec, DecodeError, Decoder, Encoder};

/// 𝔾, its diagonal, 𝕋, 𝔻 and 𝔼 for one species mix.
#[derive(Debug, Clone, PartialEq)]
pub struct ShaderMapTables {
    /// Zenith nodes (view and light), ≥ 2; node `k` is `90° · k / (theta − 1)`.
    pub theta: u32,
    /// Azimuth nodes, ≥ 2; node `m` is `180° · m / (phi − 1)`.
    pub phi: u32,
    /// Density nodes, trees per m², increasing from 0.
    pub lambdas: Vec<f32>,
    /// The crown shape `h` of the transform `S = diag(1, 2/h, 1)` (crown height over crown
    /// radius, area-weighted over the mix).
    pub h: f32,
    /// Mean crown area A of the mix, m² (the α-weighted area of the trees' top views).
    pub crown_area_m2: f32,
    /// Ground texels per measured entry.
    pub samples: u32,
    /// ρ̄: the mix's mean tree albedo (linear RGB), the α-weighted mean of its `zfield` views'
    /// albedo, species weighted by share × crown area (eq. 20–21).
    pub tree_albedo: [f32; 3],
    /// `g[((l · theta + v) · theta + t) · phi + m]`: 𝔾(θv, θl, φ, λ), the fraction of ground
    /// seen from the view direction that the sun also reaches (eq. 14).
    pub g: Vec<f32>,
    /// `gd[l · theta + v]`: 𝔾(θv, θv, 0, λ), the fraction of ground seen at all
    /// (`k_g + k_ḡ`, eq. 15).
    pub gd: Vec<f32>,
    /// `d[l]`: 𝔻(λ), the sky's cosine-weighted visibility from the ground (eq. 18–19).
    pub d: Vec<f32>,
    /// `t[((l · theta + v) · theta + t) · phi + m]`: 𝕋(θv, θl, φ, λ), the sunlight reaching
    /// the tree points seen from the view, relative to an unshadowed, unattenuated isotropic
    /// leaf: the mean of `zfield`'s `phase · exp(−τ‖p_l − p_v‖) · V(p_l)` without `sun_scale`
    /// (eq. 16's `k_t / (k_t + k_t̄)` with `zfield`'s eq. 7 inside; exactly BN12's at
    /// `normal_weight = 0`, `tau = 0`).
    pub t: Vec<f32>,
    /// `e[l · theta + v]`: 𝔼(θv, λ), the sky reaching the tree points seen from the view: the
    /// mean of `zfield`'s `δ_v / (1 + d²λ/4)` (eq. 9 in eq. 21).
    pub e: Vec<f32>,
    /// `e_side[l · theta + v]`: 𝔼ₙ(θv, λ), the part of 𝔼 below the horizon of the leaves'
    /// normals: the mean of `δ_v / (1 + d²λ/4) · (1 − n_y)/2`, n the baked normal (facing the
    /// eye). `zfield`'s sky `mix(S, sky_light(n), w)` averages to `S 𝔼 − w (S − G) 𝔼ₙ`.
    pub e_side: Vec<f32>,
}

impl ShaderMapTables {
    /// Zenith angle of node `k`, radians (transformed space).
    pub fn theta_at(&self, k: u32) -> f32 {
        std::f32::consts::FRAC_PI_2 * k as f32 / (self.theta - 1) as f32
    }

    /// Azimuth of node `m`, radians.
    pub fn phi_at(&self, m: u32) -> f32 {
        std::f32::consts::PI * m as f32 / (self.phi - 1) as f32
    }

    /// 𝔾 at nodes (λ `l`, θv `v`, θl `t`, φ `m`).
    pub fn g_node(&self, l: usize, v: usize, t: usize, m: usize) -> f32 {
        let (nt, np) = (self.theta as usize, self.phi as usize);
        self.g[((l * nt + v) * nt + t) * np + m]
    }

    /// 𝕋 at nodes (λ `l`, θv `v`, θl `t`, φ `m`).
    pub fn t_node(&self, l: usize, v: usize, t: usize, m: usize) -> f32 {
        let (nt, np) = (self.theta as usize, self.phi as usize);
        self.t[((l * nt + v) * nt + t) * np + m]
    }

    /// 𝔼 at nodes (λ `l`, θv `v`).
    pub fn e_node(&self, l: usize, v: usize) -> f32 {
        self.e[l * self.theta as usize + v]
    }

    /// 𝔼ₙ at nodes (λ `l`, θv `v`).
    pub fn e_side_node(&self, l: usize, v: usize) -> f32 {
        self.e_side[l * self.theta as usize + v]
    }

    /// 𝔾's diagonal at nodes (λ `l`, θ `v`).
    pub fn gd_node(&self, l: usize, v: usize) -> f32 {
        self.gd[l * self.theta as usize + v]
    }

    /// The diagonal at transformed zenith `theta` (radians), linear between nodes, at node `l`.
    pub fn gd_at(&self, l: usize, theta: f32) -> f32 {
        let x = (theta / std::f32::consts::FRAC_PI_2).clamp(0.0, 1.0) * (self.theta - 1) as f32;
        let k = (x.floor() as usize).min(self.theta as usize - 2);
        let f = x - k as f32;
        self.gd_node(l, k) * (1.0 - f) + self.gd_node(l, k + 1) * f
    }

    /// The transformed zenith angle of a real one: `S v` for `S = diag(1, 2/h, 1)`.
    pub fn transformed_zenith(&self, theta: f32) -> f32 {
        transformed_zenith(theta, self.h)
    }

    /// 𝔻 at node `l` from the diagonal (eq. 18–19): `2 ∫ Gd(θ′(θ), λ) cos θ sin θ dθ` over
    /// the real zenith θ ∈ [0, π/2], by `n`-point midpoint quadrature.
    pub fn integrate_d(&self, l: usize, n: usize) -> f32 {
        let step = std::f64::consts::FRAC_PI_2 / n as f64;
        let mut sum = 0.0f64;
        for i in 0..n {
            let t = (i as f64 + 0.5) * step;
            let gd = self.gd_at(l, self.transformed_zenith(t as f32)) as f64;
            sum += gd * t.cos() * t.sin();
        }
        (2.0 * sum * step) as f32
    }

    /// Checks sizes and ranges: a decoded file that fails is re-baked.
    pub fn check(&self) -> Result<(), String> {
        let (nt, np, nl) = (self.theta as usize, self.phi as usize, self.lambdas.len());
        if !(2..=64).contains(&nt) || !(2..=64).contains(&np) || !(2..=64).contains(&nl) {
            return Err(format!(
                "table sizes θ {nt}, φ {np}, λ {nl}: each must be 2 to 64"
            ));
        }
        let full = nl * nt * nt * np;
        if self.g.len() != full
            || self.t.len() != full
            || self.gd.len() != nl * nt
            || self.e.len() != nl * nt
            || self.e_side.len() != nl * nt
            || self.d.len() != nl
        {
            return Err(format!(
                "table lengths 𝔾 {}, 𝕋 {}, diagonal {}, 𝔼 {}, 𝔻 {} do not fit θ {nt} × φ {np} × λ {nl}",
                self.g.len(),
                self.t.len(),
                self.gd.len(),
                self.e.len(),
                self.d.len()
            ));
        }
        if self.lambdas[0] != 0.0
            || self
                .lambdas
                .windows(2)
                .any(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
        {
            return Err("the density nodes must rise from 0".into());
        }
        if !(self.h.is_finite() && self.h > 0.0 && self.crown_area_m2.is_finite()) {
            return Err(format!(
                "crown shape h {} or area {} out of range",
                self.h, self.crown_area_m2
            ));
        }
        let unit = |v: &f32| (0.0..=1.0).contains(v);
        if !self.tree_albedo.iter().all(unit) {
            return Err(format!("tree albedo {:?} outside [0, 1]", self.tree_albedo));
        }
        if !self.g.iter().all(unit) || !self.gd.iter().all(unit) || !self.d.iter().all(unit) {
            return Err("a visibility fraction outside [0, 1]".into());
        }
        // 𝕋 carries the normal-weighted phase (up to 1/0.34 ≈ 2.9 at a sunlit normal); 𝔼 a
        // visibility.
        if !self.t.iter().all(|v| (0.0..=4.0).contains(v))
            || !self.e.iter().all(unit)
            || !self.e_side.iter().all(unit)
        {
            return Err("a tree lighting fraction out of range (𝕋 in [0, 4], 𝔼 in [0, 1])".into());
        }
        Ok(())
    }
}

/// The transformed zenith angle of real zenith `theta` for crown shape `h`.
pub fn transformed_zenith(theta: f32, h: f32) -> f32 {
    let (s, c) = theta.sin_cos();
    s.atan2(c * 2.0 / h)
}

/// The real zenith angle of transformed zenith `theta` (the inverse of
/// [`transformed_zenith`]).
pub fn real_zenith(theta: f32, h: f32) -> f32 {
    let (s, c) = theta.sin_cos();
    s.atan2(c * h / 2.0)
}

impl Codec for ShaderMapTables {
    fn encode(&self) -> Vec<u8> {
        let mut e = Encoder::default();
        e.u32(self.theta);
        e.u32(self.phi);
        e.f32s(&self.lambdas);
        e.f32(self.h);
        e.f32(self.crown_area_m2);
        e.u32(self.samples);
        e.f32s(&self.tree_albedo);
        e.f32s(&self.g);
        e.f32s(&self.gd);
        e.f32s(&self.d);
        e.f32s(&self.t);
        e.f32s(&self.e);
        e.f32s(&self.e_side);
        e.buf
    }

    fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        let mut d = Decoder::new(bytes);
        let t = Self {
            theta: d.u32()?,
            phi: d.u32()?,
            lambdas: d.f32s()?,
            h: d.f32()?,
            crown_area_m2: d.f32()?,
            samples: d.u32()?,
            tree_albedo: {
                let a = d.f32s()?;
                a.try_into()
                    .map_err(|_| DecodeError("tree albedo is not 3 values".into()))?
            },
            g: d.f32s()?,
            gd: d.f32s()?,
            d: d.f32s()?,
            t: d.f32s()?,
            e: d.f32s()?,
            e_side: d.f32s()?,
        };
        d.finish()?;
        t.check().map_err(DecodeError)?;
        Ok(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zenith_transform_round_trips_and_keeps_the_ends() {
        for h in [1.0f32, 2.0, 3.5] {
            for k in 0..=9 {
                let t = std::f32::consts::FRAC_PI_2 * k as f32 / 9.0;
                let back = real_zenith(transformed_zenith(t, h), h);
                assert!((back - t).abs() < 1e-5, "h {h} θ {t}: {back}");
            }
        }
        assert!((transformed_zenith(0.5, 2.0) - 0.5).abs() < 1e-6);
        // Tall crowns (h > 2) look more sideways in the transformed space.
        assert!(transformed_zenith(0.5, 4.0) > 0.5);
    }
}
