//! Technique `zfield`: BN12 (Bruneton & Neyret, *Real-time Realistic Rendering and Lighting of
//! Forests*, 2012) §5 z-fields for the nearest trees, with §5's sun and sky lighting and §8's
//! per-tree coverage masks. One camera-facing proxy quad per tree from the GPU cull's lists.
//!
//! **Bake** (§5 "Precomputations", [`bake`]): per plant, one orthographic view per direction of
//! the hemi-octahedral diamond grid ([`crate::directions::HemiGrid`], `2(n² + n) + 1`
//! directions, 181 at the default order 9), all sharing one frame (the square enclosing the
//! bounding sphere, centre `o`). Each texel holds `(α z, α z̄, α δ, α)` in RGBA8: min and max
//! depth across the frame (the front image and one rendered from behind, through the shared
//! baker), the ambient occlusion of the isolated tree on flat ground, and the opacity; mips are
//! box-filtered premultiplied. Albedo and normal come from the same front images as every
//! image technique's (premultiplied sRGB albedo + coverage, normal + depth), so colours match
//! the reference. Cached through `load_or_bake` like every bake.
//!
//! **Reconstruction** (§5 steps 1–5, fig. 4, `zfield.wgsl`): per tree (vertex shader) the 3
//! grid views around the eye direction and their barycentric weights, and the same for the
//! sun. Per pixel: `p` where the view ray meets the plane through `o` facing the eye (the quad);
//! iteration 1 projects `p` orthogonally in the 3 views, `q = p + (Σwz/Σwα) v`; iteration 2
//! projects `q`, `p_v = p + (Σwz'/Σwα') v`, `α_v = Σwα'`, `δ_v = Σwδ'/α_v`; the fragment depth
//! is `p_v`'s (so z-fields cut terrain and each other). The light ray through `p_v` meets the
//! plane through `o` facing the sun at `p'`; one iteration gives `p_l`.
//!
//! **Lighting**: sun (eq. 7–8) `ρ p exp(−τ‖p_l − p_v‖) F(v, l) V(p_l) L_sun` with the hotspot
//! `F = 1 − a1 (1 − exp(−a2 acos(v·l)))`, `V` from the shared cascades at `p_l`; sky (eq. 9)
//! `ρ L_sky δ_v (1 + n·u_z)/2 / (1 + d² Λ_h / 4)`, `d` the depth of `p_v` below the tree's top,
//! `Λ_h(x)` and the ground's `n·u_z` read from the ground cover at the trunk
//! ([`crate::world::cover`]: the density map, from the trees placed). Ground (eq. 10–12): the
//! terrain's sky is `δ_g Δ(x)` with eq. 10's `Δ = 1 − a3 (Γ − Γ̄)` from the same cover, for
//! every technique (`frame.wgsl` `ground_sky`). Casters (§5): the quad facing the sun, step 5
//! only, at `z̄`.
//!
//! **Coverage** (§8): with `blend = false`, opaque fragments kept where `α_v` (times the LOD
//! presence, by optical depth) exceeds a threshold hashed from (pixel, tree): n uncorrelated
//! trees of opacity α cover `1 − (1 − α)ⁿ` of a pixel's samples, with no sort. The renderer
//! has no MSAA path: its samples are the supersamples of `--spp` (box-resolved), so the masks
//! are drawn per supersample (the paper's per-tree "combination table" of coverage masks
//! becomes a per-tree hash; `per_tree_masks = false` is plain alpha to coverage, α not
//! `1 − (1 − α)ⁿ`). **Default** (`blend = true`): premultiplied "over" on the cull's camera
//! list sorted back to front, p_v's depth still written — at 1 spp the masks' noise cost
//! ꟻLIP 0.0739 vs 0.0678 on the default scene (same other settings), so masks are the
//! choice for supersampled or MSAA-like output, blending for 1 spp.
//!
//! **Deviations**, each stated:
//! - Directions: the diamond grid is near-uniform, not exactly uniform; the "3 closest views"
//!   are the corners of the grid triangle holding the direction (as `octahedral`).
//! - Depths are distances along each view's axis; `q = p + z v` uses them along the pixel's
//!   ray unchanged, as the paper does (no `1/cos` correction).
//! - `δ` is computed on the CPU against a sub-grid of the baked views themselves (order `n/3`,
//!   25 directions at `n = 9`; each view's opacity × `1 − exp(−ao_density · depth behind its
//!   front surface)` at a 32² mip), cosine-weighted over the upper hemisphere.
//! - The phase function is isotropic scaled by `sun_scale` (the renderer's sun has no 1/π);
//!   `normal_weight` (default 0.5) blends it towards the reference's leaf response at the
//!   baked normal (Lambert + the geometry's diffuse transmission) — 0 is BN12's model
//!   (measured 0.0648 with 0.5 vs 0.0678 with 0 on the default scene).
//! - Sky: `L_sky` is the renderer's hemispherical sky seen by an upward normal, blended by
//!   `sky_normal_weight` (default 1) towards the sky seen by the baked normal, as the reference
//!   lights a leaf facing the eye (from the side it sees half ground). BN12's upward sky (0)
//!   made far crowns too bright in sky light alone: against 16-spp geometry +16 % green at
//!   0.65–1 km rising to +86 % at 3–5 km; with the normal −4 % to −1 % (BENCHMARKS "M8").
//!   `Λ_h(x)` is the density of the trees placed around (16 m either side), not of the density
//!   maps they came from; where the cover holds no tile, and with `density_per_ha` set, one
//!   value per scene and flat ground.
//! - Ground: `Δ` subtracts Γ's local mean Γ̄, not BN12's `Λ_h A`, so it averages to 1 whatever
//!   the crowns' shapes; `δ_g` is eq. 9's hole at the depth of the mean tree for the local
//!   density (BN12 takes it from the shader-map's 𝔻, which only a forest field has — with
//!   one, the ground uses 𝔻); Γ is one disk per tree from the plant's box, at ~2 m texels.
//! - Shadows: BN12 §5's soft shadows (`shadow_opacity`, the default): a caster writes `z̄`'s
//!   depth and its optical depth `σ = −ln(1 − α)` into the cascades' translucent layers
//!   (`PassKind::ShadowTranslucent`: depth-tested against the opaque casters, not written;
//!   the nearest translucent depth kept by `Min`, Σσ, Σσz and the count n summed), so
//!   overlapping crowns multiply what they let through in any draw order. BN12 stores one
//!   layer; one layer keeps only the nearest crown (E1 from straight above: +58 % against
//!   the field's tables). Deviation: a receiver behind the nearest caster gets the share of
//!   Σσ of the casters in front of it under the model that the n casters are spread evenly
//!   from the nearest to the end their σ-weighted mean implies (`translucent_depth`), and a
//!   z-field tree's light entry point takes its own crown's σ out of the sum (its own
//!   shadowing is `exp(−τ‖p_l − p_v‖)`). Measured (BENCHMARKS "Soft shadows that
//!   accumulate"): ꟻLIP against 16-spp geometry on the broadleaf scene 0.1694 (opaque
//!   where `α > ½`: 0.1759), on the built-in forest 0.0623 (0.0650); on the dense E1 stand
//!   the ground-and-crowns shadow ratio within 0.011 / 0.030 / 0.055 of geometry's at view
//!   zenith 0° / 20° / 45° (thresholded 0.006 / 0.053 / 0.049). `shadow_opacity = false`:
//!   opaque where `α > ½`, stochastic by `α` while a tree fades (an LOD transition or into a
//!   forest field); soft casters scale `σ` by presence and fade. A caster's quad
//!   (BN12: the sphere's square facing the sun) covers only what its 3 views can show — the
//!   box projected along each view onto the quad (`caster_extent`; `tight_casters`, default
//!   on), widened by the mips' spread: the same shadows (a few texels flip at `α = ½` by
//!   rounding: ꟻLIP 0.0001 on the built-in forest) from fewer fragments.
//! - `opacity_scaled_tau` (default on): τ is scaled per light ray by `ln(1 − α_l)/ln 0.01`, the
//!   optical depth the light view's opacity implies relative to an opaque chord, so sparse
//!   crowns (and trunks below them) are not lit as if behind solid foliage; off is BN12's
//!   constant τ.
//! - Camera mips are sampled `lod_bias` (−1) finer than the pixel footprint (0.0631 → 0.0615).
//!
//! **Parameters fitted** (draw keys, no re-bake) against `geometry --spp 16`: τ, `sun_scale`,
//! `normal_weight`, `sky_scale` on one pine, prunus and chestnut at 160 px (τ 1–3 within 0.001
//! ꟻLIP of each other, kept 2/m) and on the default scene (`sun_scale` 0.4 with
//! `normal_weight` 0.5; `sky_scale` 1; `a1` 0.2 and `a2` 20 are BN12 fig. 8's values, and
//! `a1` trades against `sun_scale` off the hotspot).
//!
//! **Cost**: per pixel 3 × 3 z-field fetches (two view iterations, one light) + 3 × 2 colour
//! and normal fetches; the fragment depth is written (no early depth test). **Memory**:
//! `views × tile² × 4 B × 3 images × 4/3` per plant — 47 MB at 181 × 128² (BN12: 45 MB at
//! 181 × 256² for the z-field alone). The default tile is 128, not BN12's 256: 256² is
//! 190 MB per plant (the default scene's four species would hold 760 MB of atlases on a CPU
//! rasteriser) and bakes in 16–21 s; 128² bakes in 7–8 s (pine, prunus; chestnut 29 s, its
//! 205k-triangle leaves) and is what the measurements use.
//!
//! **Measured** (lavapipe, `scripts/measure-zfield.sh`, BENCHMARKS.md "`zfield`"): default
//! scene 1280×720 ꟻLIP 0.0617 vs `geometry --spp 16` (1-spp geometry 0.0499, octahedral
//! 0.0815); one pine at 256/128/64/16 px 0.0494/0.0447/0.0468/0.0610 (1-spp geometry
//! 0.0277/0.0452/0.0466/0.1277); prunus and chestnut 0.20–0.43 (octahedral 0.23–0.45): sparse
//! broadleaf domes smear when magnified. Frame time 1.26–1.30× octahedral's (same quads).

pub mod bake;
mod draw;

pub use bake::{ZFieldBake, ZFieldBaked, ZView};
pub use draw::ZField;
pub(crate) use draw::ZFieldBindings;

use super::Built;
use super::params::{self, ParamDoc, ParamTable};
use super::registry::{self, Entry, Kind};
use crate::directions::HemiGrid;

/// Bake parameters of `zfield`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ZFieldBakeParams {
    /// Order `n` of the diamond direction grid: `2(n² + n) + 1` views (9: BN12's 181), 1–16.
    pub order: u32,
    /// Tile size of each view in texels, a power of two from 16 to 512.
    pub tile: u32,
    /// Supersampling per axis when baking, 1 to 8.
    pub supersample: u32,
    /// Foliage density for the baked ambient occlusion (optical depth per bounding radius of
    /// foliage behind a view's front surface), 0.1 to 100.
    pub ao_density: f32,
}

impl Default for ZFieldBakeParams {
    fn default() -> Self {
        Self {
            order: 9,
            tile: 128,
            supersample: 2,
            ao_density: 4.0,
        }
    }
}

/// Most texels of one plant's views together (`views × tile²`).
pub const MAX_TEXELS: u64 = 1 << 26;

impl ParamTable for ZFieldBakeParams {
    const DOCS: &'static [ParamDoc] = &[
        ParamDoc {
            key: "order",
            unit: "grid order",
            doc: "diamond grid order n: 2(n²+n)+1 views over the upper hemisphere (9: BN12's 181; 1–16)",
        },
        ParamDoc {
            key: "tile",
            unit: "texels",
            doc: "size of each view's image (a power of two 16–512; BN12 uses 256)",
        },
        ParamDoc {
            key: "supersample",
            unit: "per axis",
            doc: "samples per texel per axis when baking",
        },
        ParamDoc {
            key: "ao_density",
            unit: "per radius",
            doc: "optical depth per bounding radius of foliage for the baked ambient occlusion δ",
        },
    ];

    fn validate(&self) -> Result<(), String> {
        if !(1..=16).contains(&self.order) {
            return Err(format!("zfield order {}: must be 1 to 16", self.order));
        }
        if !self.tile.is_power_of_two() || !(16..=512).contains(&self.tile) {
            return Err(format!(
                "zfield tile {}: must be a power of two from 16 to 512",
                self.tile
            ));
        }
        if !(1..=crate::bake::MAX_SUPERSAMPLE).contains(&self.supersample) {
            return Err(format!(
                "zfield supersample {}: must be 1 to {}",
                self.supersample,
                crate::bake::MAX_SUPERSAMPLE
            ));
        }
        if !(0.1..=100.0).contains(&self.ao_density) {
            return Err(format!(
                "zfield ao_density {}: must be 0.1 to 100",
                self.ao_density
            ));
        }
        let views = HemiGrid::new(self.order).map_or(0, |g| g.len()) as u64;
        let texels = views * (self.tile as u64).pow(2);
        if texels > MAX_TEXELS {
            return Err(format!(
                "zfield order {} × tile {}: {} Mtexels per plant, more than {} — lower the order or the tile",
                self.order,
                self.tile,
                texels >> 20,
                MAX_TEXELS >> 20
            ));
        }
        Ok(())
    }
}

/// Draw parameters of `zfield` (never re-bake).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ZFieldDrawParams {
    /// Foliage extinction τ of eq. 7 (per metre of path from p_l to p_v).
    pub tau: f32,
    /// Scale τ per light ray by the optical depth the light view's opacity implies
    /// (`ln(1 − α_l) / ln(0.01)`: 1 through dense foliage, less through sparse crowns).
    pub opacity_scaled_tau: bool,
    /// Sun scale: ρ's phase function `p` (isotropic) in the renderer's units.
    pub sun_scale: f32,
    /// Blend of the isotropic phase towards the reference's leaf response at the baked normal
    /// (0: BN12's model; 1: the reference's Lambert + transmission).
    pub normal_weight: f32,
    /// Blend of eq. 9's sky (what an upward normal sees) towards what the baked normal sees,
    /// as the reference lights a leaf (0: BN12's model; 1, the default: the reference's).
    pub sky_normal_weight: f32,
    /// Hotspot amplitude a1 of eq. 8.
    pub a1: f32,
    /// Hotspot sharpness a2 of eq. 8 (width 1/a2 radians).
    pub a2: f32,
    /// Sky scale of eq. 9 (`ρ/2 ∫p` in the renderer's units).
    pub sky_scale: f32,
    /// One tree density Λ_h for eq. 9 everywhere (trees per hectare); 0: the ground cover's
    /// local density at each tree (the density map), and where it holds no tile the scene's
    /// placed trees over its terrain area (400 when none are placed).
    pub density_per_ha: f32,
    /// Per-tree coverage masks (BN12 §8); false: every tree shares one mask (plain alpha to
    /// coverage: overlapping trees cover α, not 1 − (1 − α)ⁿ).
    pub per_tree_masks: bool,
    /// Camera pass blended premultiplied "over", back to front (the cull's sorted list),
    /// instead of coverage masks; p_v's depth is still written.
    pub blend: bool,
    /// Mip bias of the camera pass (negative: sharper), −4 to 4.
    pub lod_bias: f32,
    /// Shadow casters are translucent (the default, BN12 §5 soft shadows): their optical depth
    /// accumulates in the cascades' translucent layers, so what lies behind crowns gets the
    /// product of what each lets through; false: opaque where α > ½.
    pub shadow_opacity: bool,
    /// Shadow casters cover only the part of their sun-facing quad that their 3 views can
    /// show (the box projected along each view, `caster_extent` in `zfield.wgsl`) instead of
    /// the bounding square.
    pub tight_casters: bool,
}

impl Default for ZFieldDrawParams {
    fn default() -> Self {
        Self {
            tau: 2.0,
            opacity_scaled_tau: true,
            sun_scale: 0.4,
            normal_weight: 0.5,
            sky_normal_weight: 1.0,
            a1: 0.2,
            a2: 20.0,
            sky_scale: 1.0,
            density_per_ha: 0.0,
            per_tree_masks: true,
            blend: true,
            lod_bias: -1.0,
            shadow_opacity: true,
            tight_casters: true,
        }
    }
}

impl ParamTable for ZFieldDrawParams {
    const DOCS: &'static [ParamDoc] = &[
        ParamDoc {
            key: "tau",
            unit: "1/m",
            doc: "foliage extinction τ (eq. 7): sunlight falls as exp(−τ‖p_l − p_v‖)",
        },
        ParamDoc {
            key: "opacity_scaled_tau",
            unit: "bool",
            doc: "scale τ per light ray by the light view's opacity (ln(1−α)/ln 0.01): sparse crowns attenuate less",
        },
        ParamDoc {
            key: "sun_scale",
            unit: "factor",
            doc: "isotropic phase function ρp of eq. 7 in the renderer's sun units",
        },
        ParamDoc {
            key: "normal_weight",
            unit: "0–1",
            doc: "blend of the isotropic phase towards the reference leaf response at the baked normal (0: BN12)",
        },
        ParamDoc {
            key: "sky_normal_weight",
            unit: "0–1",
            doc: "blend of eq. 9's sky (seen by an upward normal) towards the sky the baked normal sees, as the reference lights a leaf (0: BN12)",
        },
        ParamDoc {
            key: "a1",
            unit: "factor",
            doc: "hotspot amplitude a1 (eq. 8)",
        },
        ParamDoc {
            key: "a2",
            unit: "1/rad",
            doc: "hotspot sharpness a2 (eq. 8; width 1/a2)",
        },
        ParamDoc {
            key: "sky_scale",
            unit: "factor",
            doc: "sky term scale of eq. 9",
        },
        ParamDoc {
            key: "density_per_ha",
            unit: "trees/ha",
            doc: "one tree density Λ_h for eq. 9's cylindrical hole everywhere (0: the ground cover's local density map)",
        },
        ParamDoc {
            key: "per_tree_masks",
            unit: "bool",
            doc: "per-tree coverage masks (BN12 §8); false: one shared mask (plain alpha to coverage)",
        },
        ParamDoc {
            key: "blend",
            unit: "bool",
            doc: "blend premultiplied back to front instead of coverage masks (p_v's depth still written)",
        },
        ParamDoc {
            key: "lod_bias",
            unit: "mips",
            doc: "mip bias of the camera pass (negative: sharper; −4 to 4)",
        },
        ParamDoc {
            key: "shadow_opacity",
            unit: "bool",
            doc: "shadows keep the crowns' opacity (default; BN12 §5 soft shadows: behind overlapping crowns the product of what each lets through); false: opaque where α > ½",
        },
        ParamDoc {
            key: "tight_casters",
            unit: "bool",
            doc: "shadow casters cover only what their 3 views can show (the box's projections), not the bounding square: fewer shadow fragments; false: the whole square (for comparisons)",
        },
    ];

    fn validate(&self) -> Result<(), String> {
        let ranges = [
            ("tau", self.tau, 0.0, 100.0),
            ("sun_scale", self.sun_scale, 0.0, 100.0),
            ("normal_weight", self.normal_weight, 0.0, 1.0),
            ("sky_normal_weight", self.sky_normal_weight, 0.0, 1.0),
            ("a1", self.a1, 0.0, 1.0),
            ("a2", self.a2, 0.0, 1000.0),
            ("sky_scale", self.sky_scale, 0.0, 100.0),
            ("density_per_ha", self.density_per_ha, 0.0, 1e6),
            ("lod_bias", self.lod_bias, -4.0, 4.0),
        ];
        for (key, v, lo, hi) in ranges {
            if !(lo..=hi).contains(&v) {
                return Err(format!("zfield {key} {v}: must be {lo} to {hi}"));
            }
        }
        Ok(())
    }
}

fn resolve(
    settings: &[&sylvan_scene::Setting],
) -> Result<(ZFieldBakeParams, ZFieldDrawParams), crate::RenderError> {
    params::resolve::<ZFieldBakeParams, ZFieldDrawParams>("zfield", settings)
}

/// Whether `zfield` drawn with `settings` casts translucent shadows (`shadow_opacity`), which
/// need the cascades' translucent layer (`FrameResources::new`).
pub(crate) fn casts_translucent(
    settings: &[sylvan_scene::Setting],
) -> Result<bool, crate::RenderError> {
    let own: Vec<_> = settings
        .iter()
        .filter(|s| s.technique == "zfield")
        .collect();
    Ok(resolve(&own)?.1.shadow_opacity)
}

/// Λ_h of eq. 9 in trees per m²: the parameter, else the scene's placed trees over its
/// terrain area, else 400 per hectare.
fn density(scene: &sylvan_scene::Scene, draw: &ZFieldDrawParams) -> f32 {
    if draw.density_per_ha > 0.0 {
        return draw.density_per_ha / 10_000.0;
    }
    let [x, z] = scene.terrain.size;
    let area = (x * z).max(1.0);
    if scene.trees.is_empty() {
        400.0 / 10_000.0
    } else {
        scene.trees.len() as f32 / area
    }
}

/// The registry entry.
pub const ENTRY: Entry = Entry {
    name: "zfield",
    kind: Kind::PerTree,
    summary: "BN12 §5 z-fields: one quad per tree, 181 depth/AO/opacity views, view and light rays reconstructed",
    debug_color: [1.0, 0.9, 0.15],
    gpu_driven: true,
    schema: params::schema::<ZFieldBakeParams, ZFieldDrawParams>,
    check: |s| resolve(s).map(|_| ()),
    build: |cx| {
        let (bake, draw) = resolve(&cx.settings_for("zfield"))?;
        let (assets, reports) = cx.load_assets::<ZFieldBake>(&bake)?;
        let density = density(cx.scene, &draw);
        Ok(Built {
            technique: Box::new(ZField::new(
                cx.gpu, cx.frame, cx.plants, &assets, &bake, &draw, density, cx.field,
            )?),
            reports,
        })
    },
    bake: Some(registry::bake_with::<ZFieldBake, ZFieldDrawParams>),
    casts_translucent: Some(casts_translucent),
    shaders: || {
        vec![
            ("zfield", shader_source()),
            ("zfield_field", shader_source_for(true)),
        ]
    },
};

/// The WGSL of `zfield` as compiled alone: [`shader_source_for`] without a field.
pub(crate) fn shader_source() -> String {
    shader_source_for(false)
}

/// The WGSL of `zfield`: the frame's group 0, `bindings.wgsl` (group 1), the direction grid's
/// lookup, `zfield.wgsl`, then — before a forest field — the field's tables and terms in group
/// 2 and `field_zfield.wgsl` (BN12 §7), or else its own lighting everywhere
/// (`field_none.wgsl`).
pub(crate) fn shader_source_for(field: bool) -> String {
    let tail = match field {
        true => crate::technique::shadermap::field::field_wgsl(
            2,
            crate::technique::shadermap::field::FieldUser::ZField,
        ),
        false => include_str!("field_none.wgsl").to_string(),
    };
    crate::pipeline::with_frame(&format!(
        "{}\n{}\n{}\n{}",
        include_str!("bindings.wgsl"),
        crate::directions::HEMI_GRID_WGSL,
        include_str!("zfield.wgsl"),
        tail
    ))
}
