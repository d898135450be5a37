//! BN12's shader-map (Bruneton & Neyret, *Real-time Realistic Rendering and Lighting of
//! Forests*, 2012), the far end of the `auto` chain: §6's precomputed tables and the field they
//! shade the terrain with, drawn alone (`--technique shadermap`: the terrain carries the whole
//! forest, no tree is drawn) or as the last band of `auto` (§7). `docs/plans/shadermap.md` is
//! the plan and says what is left.
//!
//! **Built** ([`measure`], [`tables`], [`scene`]): the tables of §6 for a scene's species mix —
//! 𝔾(θv, θl, φ, λ), the fraction of ground seen from the view that the sun also reaches
//! (eq. 14); its diagonal 𝔾(θ, θ, 0, λ) (`k_g + k_ḡ`, eq. 15); 𝕋(θv, θl, φ, λ), the sunlight
//! reaching the tree points seen (eq. 16 with `zfield`'s eq. 7 inside); 𝔻(λ), the ground's
//! cosine-weighted sky visibility (eq. 18–19); 𝔼(θv, λ), the sky reaching the tree points seen
//! (eq. 21 with `zfield`'s eq. 9) — measured by rendering `zfield` forest patches, cached like
//! every bake ([`measure::load_or_measure`]).
//!
//! On the GPU ([`gpu`], [`ridge`], `field_tables.wgsl`): 𝔾 and 𝕋 resampled onto ridge-aligned
//! axes (θ̄ = (θv + θl)/2, δ = θv − θl on nodes crowding δ = 0, φ, λ) in an `Rg16Float` 3D
//! texture (139,264 B at BN12's resolution), 𝔼 and 𝔻 in a 2D one (1,024 B); two fetches per
//! lookup.
//!
//! **The field** ([`field`], `field.wgsl`): per terrain pixel eq. 2–5 (view and sun zeniths
//! and their azimuth in the transformed space, the slope factor), then eq. 13
//! `L = k_g Ī_g + (k_g + k_ḡ) J̄_g + (1 − k_g − k_ḡ)(𝕋 Ī_t + J̄_t)` with the ground's own albedo,
//! sun (eq. 17) and sky × 𝔻 (eq. 19), and the trees' albedo with `zfield`'s sun scale and
//! hotspot (eq. 20) and sky scale × 𝔼 (eq. 21) — the mix's mean ρ̄ scaled by the local
//! species' albedo over the terrain's mean ([`density`]'s colour layer), so where the local
//! trees are the mix it is ρ̄ and a stand of another colour keeps it to the horizon.
//!
//! **As the last band of `auto`** (§7, e.g. `["zfield:0-1500", "shadermap:1500-"]`): the chain
//! builds the field first and hands it to the bands before it. `zfield` trees converge to the
//! field's means (eq. 22–23, ν = smoothstep(0, 0.8, s/s_max)) and fade by their own distance
//! over [0.8, 1] s_max; the ground converges the same way (eq. 24–25) and takes the trees'
//! share as they fade (eq. 26–27). Other per-tree bands before a field fade by presence over
//! the same window. `shadermap.handover=false` is a hard switch; `shadermap.nu` forces ν.
//!
//! **Trees under 3 px are never drawn** (§4): each tree's own end is min(s_max, where it is
//! `handover_px` tall in the output), in every band of the chain (`technique::FieldEnd`, the
//! GPU cull and the CPU lists alike); `zfield` fades and converges by it. The ground takes each
//! species' ν and w from that species' own end, weighed by its crown area there (the density
//! raster's per-species layers, `field_handover_at`), so the field takes a bush's share where
//! the bushes end while the pines are still drawn. A deviation: the ground's per-species end
//! uses the species' rms height, the trees their own heights.
//!
//! **Density** ([`density`]): the field samples Λ_h(x) per pixel from a raster of the scene's
//! density maps (summed over species) and its placed trees (binned per ≥ 25 m cell, tent
//! smoothed), at most 512² texels whatever the terrain — a clearing is bare ground — with the
//! local trees' crown areas, so the one mix table is looked up at the density of mix trees
//! that covers the view as the local species do.
//!
//! **Coverage** (§4, §7's "Γ/A replacing Λ"): the fractions of ground seen are scaled by
//! m = (1 − Γ)/(1 − Γ̄), the ground cover's crowns from above (`world::cover`) at the mip of the
//! pixel's footprint and their local mean — mean-preserving (a deviation: BN12 replaces Λ by
//! Γ/A with G(·,·,·,1/A) = 0, which changes the mean where disks are resolved), so the field's
//! trees lie where the trees are and a tree fading out leaves its share under its own crown.
//!
//! **Not built yet**: ℂ, and coverage beyond the ground cover's window (one level and its mips,
//! within the trees' distance; farther the field uses the density raster's Λ_h alone).
//!
//! **Deviations from BN12**, each stated:
//! - The patch is drawn unscaled and each table direction `v′` of the transformed space
//!   (`S = diag(1, 2/h, 1)`, BN12's scaling of the forest by `2/h`) is measured along `S⁻¹ v′`:
//!   ground-visibility fractions are invariant under the affine map `S` (the ground plane is
//!   fixed, rays map to rays), `zfield` instances are similarities only, and 𝕋 then uses the
//!   true path lengths `zfield`'s eq. 7 uses.
//! - Factorised, not one render per entry: per density node one render per direction of the
//!   grid (`1 + (θ − 1)·φ` of them, sheared ground-aligned orthographic projections, so a pixel
//!   is the same ground texel in all), each writing the highest tree point along each ground
//!   texel's ray; the view directions' renders are G-buffers (tree, p_v's height, δ_v, normal),
//!   the others light maps. One compute pass per view and batch of lights evaluates every
//!   (view, light) pair: 𝔾 counts the texels that are ground in both, 𝕋 reconstructs each tree
//!   sample's light ray with `zfield`'s own `z_light` and lights it with `zfield`'s phase and
//!   extinction, `V(p_l)` = 1 where the light map's highest point along the light ray through
//!   p_l is the same tree or lies below p_l. 𝕋 and 𝔼 use every `patch_px / 128`-th texel.
//! - A tree hides a ground texel's ray where its z-field opacity α along the ray exceeds a
//!   threshold hashed from (texel, tree), the same for every direction: fractional opacity
//!   counts as the expected `(1 − α)ⁿ` over many texels, and a texel hidden from v is hidden
//!   from l = v. The runtime `zfield` casts shadows where α > ½ (depth-only cascades); the
//!   tables keep the physical mean.
//! - 𝕋 is relative to an unshadowed isotropic leaf and carries `zfield`'s normal-weighted
//!   phase (`normal_weight`, default 0.5), so the far field can match the near trees; at
//!   `normal_weight = 0`, `tau = 0` it is BN12's `k_t / (k_t + k_t̄)`.
//! - 𝔼 comes with 𝔼ₙ, the part of it below the horizon of the tree points' baked normals
//!   (the mean of `δ·hole·(1 − n_y)/2`), so the field's trees take `zfield`'s sky blended
//!   towards the normal's (`sky_normal_weight`, default 1): `S 𝔼 − w (S − G) 𝔼ₙ` for sky `S`
//!   and ground `G` — BN12's `S 𝔼` at `w = 0`. 𝔼ₙ is stored in 𝔼's texture's third channel.
//! - 𝔾 at the 90° node is analytic (no ground is seen through an endless forest at grazing
//!   angles); the directions rendered are capped at 87° real zenith (𝕋 and 𝔼 at 90° are
//!   measured there).
//! - Stored on ridge-aligned axes (θ̄, δ) rather than (θv, θl): multilinear interpolation on
//!   (θv, θl, φ) puts the hotspot ridge on cell diagonals. On BN12's 16 zenith nodes the
//!   interpolated 𝔾 then peaks exactly at θv = θl (0.25° sweeps, θl 20°–80°); on coarse tables
//!   (5 nodes) the slope of Gd along θ̄ can still pull the peak off it.
//! - The terrain's relief shadows (the cascades' V) multiply both the ground's and the trees'
//!   sun (eq. 17, 20 assume flat open sky) where the cascades hold no drawn trees (the field
//!   alone, or beyond 1.1 s_max); nearer, the mean terms take no V (𝔾 and 𝕋 hold the trees'
//!   shadows), so relief shadows there reach only the (1 − ν) own-lit part.
//! - Eq. 27's μ is made mean-preserving: μ = c w / (1 − c (1 − w)), c = 1 − Gd, so drawn
//!   trees fading as (1 − w) plus the ground's share keep the tree fraction c at every w
//!   (BN12's μ = c w dips to c − c²/4 at w = ½). The fade goes by each tree's trunk distance
//!   (a tree fades as one), the ground's by the pixel's.
//! - Eq. 22–23's means take the field's albedo there (ρ̄ scaled to the local species, as BN12's
//!   Ī_t, J̄_t take the field's) and assume flat ground (the zfield shader does not know the
//!   terrain normal).
//! - The trees' albedo per pixel is ρ̄ × (Σ Λⁱ aⁱ ρⁱ / Σ Λⁱ aⁱ) / (the terrain's mean of the same):
//!   BN12 keeps a density channel per species and tables per model, so each species is lit
//!   with its own; here one table set, with the colour of the local species mix.
//! - One table set and one density for the species summed (BN12: a channel per species,
//!   tables per model), corrected to first order by the local crown areas ([`density`]).
//! - One table set for the scene's species mix, h and A area-weighted over it (BN12 §10 allows
//!   per-mix sets); the patch is a periodic Poisson tile with the scene's pattern radius, not
//!   the terrain's own tiling, so the wrap-around is exact. Density nodes are the patch's
//!   realised densities (n trees / area).

pub mod density;
pub mod field;
pub mod gpu;
pub mod measure;
pub mod ridge;
pub mod scene;
pub mod tables;

pub use measure::{ForestMix, MixSpecies, load_or_measure, measure_tables};
pub use scene::{SceneMix, bake_scene, scene_mix};
pub use tables::ShaderMapTables;

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

/// Draw parameters of `shadermap` (never re-measure).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ShaderMapDrawParams {
    /// Scale of the field's tree density (the scene's local density, [`density`]): 0 is bare
    /// terrain.
    pub density_scale: f32,
    /// BN12 §7's handover as the last band of `auto`: the trees fade over [0.8, 1] × its
    /// start while the ground takes their share; `false`: a hard switch (for measuring pops).
    pub handover: bool,
    /// ν of eq. 22–25 forced (0 to 1); −1: BN12's smoothstep(0, 0.8, s/s_max).
    pub nu: f32,
    /// As the last band of `auto`: a tree shorter than this on screen (pixels) is not drawn
    /// (BN12 §4's 3 px) — each tree ends at min(s_max, its height × the output's pixels per
    /// metre / this) and the field takes each species' share from its own end; 0: every
    /// tree is drawn to s_max.
    pub handover_px: f32,
}

impl Default for ShaderMapDrawParams {
    fn default() -> Self {
        Self {
            density_scale: 1.0,
            handover: true,
            nu: -1.0,
            handover_px: 3.0,
        }
    }
}

impl ParamTable for ShaderMapDrawParams {
    const DOCS: &'static [ParamDoc] = &[
        ParamDoc {
            key: "density_scale",
            unit: "×",
            doc: "scale of the field's local tree density (the scene's density maps and placed trees); 0 draws bare terrain (0–100)",
        },
        ParamDoc {
            key: "handover",
            unit: "",
            doc: "as the last band of auto: trees fade over [0.8, 1] × the band's start while the ground takes their share (BN12 §7); false: a hard switch",
        },
        ParamDoc {
            key: "nu",
            unit: "",
            doc: "ν of BN12 eq. 22–25 forced (0–1: how far near trees and ground are lit with the field's means); −1: smoothstep(0, 0.8, s/s_max)",
        },
        ParamDoc {
            key: "handover_px",
            unit: "px",
            doc: "as the last band of auto: trees shorter than this on screen are left to the field (BN12's 3 px; each tree ends where it is this tall, each species handing over at its own distance); 0 draws every tree to the field's start (0–100)",
        },
    ];

    fn validate(&self) -> Result<(), String> {
        if !(0.0..=100.0).contains(&self.density_scale) {
            return Err(format!(
                "shadermap density_scale {}: must be 0 to 100",
                self.density_scale
            ));
        }
        if !(0.0..=100.0).contains(&self.handover_px) {
            return Err(format!(
                "shadermap handover_px {}: must be 0 to 100",
                self.handover_px
            ));
        }
        if !(self.nu == -1.0 || (0.0..=1.0).contains(&self.nu)) {
            return Err(format!(
                "shadermap nu {}: must be 0 to 1, or −1 for BN12's ν",
                self.nu
            ));
        }
        Ok(())
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

/// The registry entry: `shadermap` drawn alone (the terrain carries the forest; no tree is
/// drawn), or as the last band of `auto` (the field from the band's start on).
pub const ENTRY: super::registry::Entry = super::registry::Entry {
    name: "shadermap",
    kind: super::registry::Kind::Field,
    summary: "BN12 §6–7 shader-map: the forest as a field on the terrain, from tables measured on z-field patches (alone, or the last band of auto)",
    debug_color: [0.55, 0.35, 0.85],
    gpu_driven: true,
    schema: super::params::schema::<ShaderMapBakeParams, ShaderMapDrawParams>,
    check: scene::check_settings,
    build: |cx| {
        let (tables, report, albedo) = bake_scene(
            cx.gpu,
            cx.scene,
            cx.plants,
            cx.settings,
            cx.policy,
            cx.policy,
            &mut *cx.progress,
        )?;
        let (_, draw) = super::params::resolve::<
            super::zfield::ZFieldBakeParams,
            super::zfield::ZFieldDrawParams,
        >("zfield", &cx.settings_for("zfield"))?;
        let (_, own) = super::params::resolve::<ShaderMapBakeParams, ShaderMapDrawParams>(
            "shadermap",
            &cx.settings_for("shadermap"),
        )?;
        let density = density::DensityRaster::of_scene(cx.scene, cx.plants, &albedo);
        // Alone (start 0) the field draws everything; as a chain's last band it takes over
        // from the trees at its start.
        let handover = field::Handover {
            s_max: cx.band.start,
            nu: (own.nu >= 0.0).then_some(own.nu),
            fade: own.handover,
            handover_px: own.handover_px,
        };
        let field = field::ForestField::new(
            cx.gpu,
            &tables,
            &density,
            own.density_scale,
            &draw,
            handover,
        )?;
        Ok(super::Built {
            technique: Box::new(field::ShaderMap { field }),
            reports: vec![report],
        })
    },
    bake: None,
    casts_translucent: None,
    shaders: || {
        vec![
            ("shadermap_terrain", field::terrain_source()),
            ("shadermap_measure", measure::shader_source()),
            ("shadermap_probe", gpu::probe_source()),
        ]
    },
};
