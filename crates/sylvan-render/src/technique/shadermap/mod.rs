//! BN12's shader-map (Bruneton & Neyret, *Real-time Realistic Rendering and Lighting of
//! Forests*, 2012), the far end of the `auto` chain — **in progress**: this module holds what
//! is built of it so far, the first half of §6's precomputed tables. It draws nothing yet: it
//! is not in the registry (`render --technique shadermap` is an unknown technique), and only
//! `sylvan bake --technique shadermap [--scene FILE]` measures its tables.
//! `docs/plans/shadermap.md` is the plan and says what comes next.
//!
//! **Built** ([`measure`], [`tables`]): the ground tables of §6 — 𝔾(θv, θl, φ, λ), the fraction
//! of ground seen from the view that the sun also reaches (eq. 14), its diagonal 𝔾(θ, θ, 0, λ)
//! (`k_g + k_ḡ`, eq. 15) and 𝔻(λ), the ground's cosine-weighted sky visibility (eq. 18–19) —
//! measured by rendering `zfield` forest patches of the scene's species mix, and cached like
//! every bake ([`measure::load_or_measure`]).
//!
//! **Not built yet**: 𝕋 and 𝔼 (the lit and sky-lit fractions of the visible trees, eq. 16 and
//! 21, which need `zfield`'s light-ray reconstruction in the measuring pass), ℂ, the field on
//! the terrain, coverage tiles, seeds on the GPU and the transitions of §7.
//!
//! **Deviations from BN12**, each stated:
//! - The patch is drawn unscaled and each table direction `v′` of the transformed space
//!   (`S = diag(1, 2/h, 1)`, BN12's scaling of the forest by `2/h`) is measured along `S⁻¹ v′`:
//!   ground-visibility fractions are invariant under the affine map `S` (the ground plane is
//!   fixed, rays map to rays), and `zfield` instances are similarities only.
//! - All (θv, θl, φ) entries of a density node come from one render per direction (1 + (θ − 2)·φ
//!   of them) and bit counts, not one render per entry: the ground texel seen from v and lit
//!   from l is the AND of two masks in the same ground-aligned pixels.
//! - A tree hides a ground texel's ray where its z-field opacity α along the ray exceeds a
//!   threshold hashed from (texel, tree), the same for every direction: fractional opacity
//!   counts as the expected `(1 − α)ⁿ` over many texels, and a texel hidden from v is hidden
//!   from l = v. The runtime `zfield` casts shadows where α > ½ (depth-only cascades); the
//!   tables keep the physical mean.
//! - The 90° node is analytic (no ground is seen through an endless forest at grazing
//!   angles); directions measured are capped at 87° real zenith.
//! - One table set for the scene's species mix, h and A area-weighted over it (BN12 §10 allows
//!   per-mix sets); the patch is a periodic Poisson tile with the scene's pattern radius, not
//!   the terrain's own tiling, so the wrap-around is exact.

pub mod measure;
pub mod scene;
pub mod tables;

pub use measure::{ForestMix, MixSpecies, load_or_measure, measure_ground};
pub use scene::{SceneMix, bake_scene, scene_mix};
pub use tables::GroundTables;

use super::params::{ParamDoc, ParamTable};

/// What the tables are measured with (their cache key).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ShaderMapBakeParams {
    /// Zenith nodes (view and light) over [0°, 90°] of the transformed space (BN12: 16).
    pub theta: u32,
    /// Azimuth nodes over [0°, 180°] (BN12: 16).
    pub phi: u32,
    /// Density nodes over [0, the scene's peak] (BN12: 8).
    pub lambda: u32,
    /// Side of the measured patch in pattern radii.
    pub patch_radii: u32,
    /// Pixels (ground texels) per side of each measuring render.
    pub patch_px: u32,
    /// Seed of the patch (positions, thinning, species, heights, rotations).
    pub seed: u32,
}

impl Default for ShaderMapBakeParams {
    fn default() -> Self {
        Self {
            theta: 16,
            phi: 16,
            lambda: 8,
            patch_radii: 24,
            patch_px: 256,
            seed: 1,
        }
    }
}

impl ParamTable for ShaderMapBakeParams {
    const DOCS: &'static [ParamDoc] = &[
        ParamDoc {
            key: "theta",
            unit: "nodes",
            doc: "zenith nodes of the tables over [0°, 90°] (BN12: 16; 3–32)",
        },
        ParamDoc {
            key: "phi",
            unit: "nodes",
            doc: "azimuth nodes between view and sun over [0°, 180°] (BN12: 16; 2–32)",
        },
        ParamDoc {
            key: "lambda",
            unit: "nodes",
            doc: "tree-density nodes over [0, the scene's peak] (BN12: 8; 2–16)",
        },
        ParamDoc {
            key: "patch_radii",
            unit: "pattern radii",
            doc: "side of the measured forest patch (4–64)",
        },
        ParamDoc {
            key: "patch_px",
            unit: "texels",
            doc: "ground texels per side of each measuring render (a power of two 32–1024)",
        },
        ParamDoc {
            key: "seed",
            unit: "",
            doc: "seed of the measured patch",
        },
    ];

    fn validate(&self) -> Result<(), String> {
        let ranges = [
            ("theta", self.theta, 3, 32),
            ("phi", self.phi, 2, 32),
            ("lambda", self.lambda, 2, 16),
            ("patch_radii", self.patch_radii, 4, 64),
            ("patch_px", self.patch_px, 32, 1024),
        ];
        for (key, v, lo, hi) in ranges {
            if !(lo..=hi).contains(&v) {
                return Err(format!("shadermap {key} {v}: must be {lo} to {hi}"));
            }
        }
        if !self.patch_px.is_power_of_two() {
            return Err(format!(
                "shadermap patch_px {}: must be a power of two",
                self.patch_px
            ));
        }
        Ok(())
    }
}
