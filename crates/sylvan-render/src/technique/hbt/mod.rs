//! Technique `hbt`: MNP01 — Meyer, Neyret, Poulin, *Interactive Rendering of Trees with
//! Shading and Shadows*, EGWR 2001. A first increment: the top level of the hierarchy is
//! baked and drawn; the level below (main branches) can be baked, not yet drawn.
//!
//! Implements:
//! - §3.1 the **bidirectional texture function** of the whole tree (one base object): one
//!   billboard per (view sample, light sample) pair of the shared direction sets
//!   ([`crate::directions`], 6/18/66/258 samples), holding the tree's colour lit by that light
//!   with **self-shadowing** inside the tree, plus the **ambient BTF** per view sample (sky light
//!   with a sky-occlusion estimate), sun and sky kept apart as §3.1 asks ([`bake`]);
//! - §6.1 building it: each view is rasterised once by the shared baker ([`crate::bake`]) into a
//!   supersampled albedo/normal/depth G-buffer; each light sample gets an orthographic depth map
//!   of the tree (alpha-tested leaves, so alpha-aware); every covered G-buffer sample is lit
//!   with the reference's model (Lambert + leaf transmission) times its visibility from that
//!   light (5×5 PCF in the light's depth map: soft self-shadows), then box-filtered down to the
//!   tile and mip-mapped;
//! - §3.2/§7 the **level below**: with [`HbtParams::levels`] = 2, the same BTF for each distinct
//!   base object the plant's root places (`plant.instancing`: the main branches,
//!   [`bake::main_branches`]), each expanded from its instances and baked in its own frame
//!   ([`bake::ObjectBtf`]);
//! - §4.1 and the appendix, **reconstruction**: per tree and frame, the 3 view samples and
//!   3 light samples enclosing the (model-space) eye and sun directions with their barycentric
//!   weights (MNP01's precomputed table, [`crate::directions::DirectionLut::lookup`], on the
//!   CPU per instance: ~3× faster than descending the subdivision, same result); the 9
//!   products, those below [`HbtParams::min_weight`] dropped and the rest renormalised
//!   ([`reconstruction_weights`]); 9 weighted fetches summed in one fragment (the
//!   order-independent weighted sum the appendix builds with "darken then add", done in one
//!   pass) and composited premultiplied over the background. Colour = sun colour × direct BTF
//!   × received shadow + sky colour × ambient BTF (§4.2). Facing (billboard) or cross
//!   projection (§4.1, fig. 3.2), selectable ([`HbtProjection`]).
//!
//! Deviations, plainly:
//! - **Only the top level is drawn.** Main-branch BTFs are baked (opt-in) but not used yet;
//!   the small-branch level, LOD by projected size (opening a tree into its branches, §4, §5),
//!   back-to-front drawing of opened objects, and baking higher levels by rendering the lower
//!   levels' BTFs (§6.1, for consistency between levels) are not implemented. Each level is
//!   baked from geometry instead. A branch's sky occlusion is estimated inside the branch only
//!   (its placement in the tree varies per instance).
//! - **No visibility cube-maps (§3.3, §4.2, §6.2).** Shadows received from the rest of the scene
//!   come from the renderer's cascaded shadow maps, sampled once per fragment at the billboard
//!   point moved towards the sun by the tree's bounding radius (so the tree does not shadow
//!   itself a second time: its self-shadowing is in the BTF). Trees cast into those maps with
//!   stochastic (screen-door) alpha. Ambient occlusion by other trees is not modelled.
//! - **Self-shadowing** uses depth maps with PCF rather than MNP01's ray tracer (§6.1).
//! - **Sky occlusion** is the reference's crown-position estimate (`crown_occlusion` in
//!   `frame.wgsl`) evaluated at each baked sample, so `hbt` and `geometry` agree, not the mean
//!   of a visibility cube-map. The ambient BTF is two images per view sample — sky-facing and
//!   ground-facing parts of the reference's hemispherical sky term — so sky and ground colours
//!   stay run-time parameters.
//! - **Cross projection** composites its 3 planes with premultiplied "over", each plane's
//!   opacity its share of the optical depth (as `boxtree`), not the appendix's exact weighted
//!   sum (which facing projection gets exactly).
//! - Leaf transmission is applied to wood too (the baker does not tell them apart), as in
//!   `boxtree`.
//!
//! Cost: bake = V + L rasterisations plus a CPU lighting pass of V·L·(tile·ss)² samples; per
//! frame, 2 direction look-ups per tree in view and 1 per tree per cascade (CPU, ~83 ns each
//! in release on this project's test machine: ~2 ms for the default view), one instanced
//! draw per pass, up to 9 + 6 texture fetches per fragment. Memory: (V·L + 2V) tiles of
//! `tile²` RGBA8 with mips, per plant (species sharing a plant share it), in one atlas (66 × 18 at 32 px, the
//! default: 7.2 MB per plant; 18 × 18: 1.97 MB; main branches add that per distinct branch
//! object).

pub mod bake;
mod draw;
pub mod scene;
pub mod visibility;

pub use bake::{HbtBaked, reconstruction_weights};
pub use draw::Hbt;

use crate::RenderError;
use crate::directions::MAX_LEVEL;

/// How the blended images are projected on screen (MNP01 §4.1, fig. 3.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HbtProjection {
    /// All images on one quad facing the eye ("billboard-like").
    Facing,
    /// Each view sample's images on the plane facing that sample ("cross-tree-like").
    Cross,
}

impl HbtProjection {
    /// The name used in flags.
    pub fn name(self) -> &'static str {
        match self {
            HbtProjection::Facing => "facing",
            HbtProjection::Cross => "cross",
        }
    }

    /// Parses `facing` or `cross`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "facing" => Some(HbtProjection::Facing),
            "cross" => Some(HbtProjection::Cross),
            _ => None,
        }
    }
}

/// Where trees' received sun shadows come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HbtShadows {
    /// MNP01 §3.3/§4.2: the hierarchy of visibility cube-maps (other trees and terrain at the
    /// top level, other branches below), which also scale the sky term.
    CubeMaps,
    /// The renderer's cascaded shadow maps, sampled outside the object towards the sun; the sky
    /// term still comes from the cube-maps.
    Cascades,
}

impl HbtShadows {
    /// The name used in flags.
    pub fn name(self) -> &'static str {
        match self {
            HbtShadows::CubeMaps => "cubemaps",
            HbtShadows::Cascades => "cascades",
        }
    }

    /// Parses `cubemaps` or `cascades`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "cubemaps" => Some(HbtShadows::CubeMaps),
            "cascades" => Some(HbtShadows::Cascades),
            _ => None,
        }
    }
}

/// Bake and draw parameters of `hbt`.
#[derive(Debug, Clone, PartialEq)]
pub struct HbtParams {
    /// Levels of the hierarchy: 1, the tree; 2, also the level below (representative main
    /// branches and the plant's rest), opened when the tree's texels would be magnified.
    pub levels: u32,
    /// View-direction set of the level below: subdivision level 0..=3.
    pub branch_view_level: u32,
    /// Light-direction set of the level below.
    pub branch_light_level: u32,
    /// Most distinct main branches baked per plant (the rest are drawn with a scaled
    /// representative; see [`bake::branch_level`]).
    pub max_branch_objects: u32,
    /// Side of each visibility cube-map face (MNP01 uses 32).
    pub cube_resolution: u32,
    /// Draw only: a tree opens into its branches when one of its texels would cover more than
    /// this many pixels (MNP01 §4: when the billboard would be magnified).
    pub open_texel_pixels: f32,
    /// Draw only: the cross-fade band around that switch, relative (0 = hard switch).
    pub band: f32,
    /// Draw only: received sun shadows from cube-maps or cascades.
    pub shadows: HbtShadows,
    /// View-direction set: subdivision level 0..=3 (6, 18, 66 or 258 samples).
    pub view_level: u32,
    /// Light-direction set: subdivision level 0..=3.
    pub light_level: u32,
    /// Billboard size in texels (MNP01: 32 or 64; a power of two 8–256).
    pub tile: u32,
    /// G-buffer samples per tile texel, per axis.
    pub supersample: u32,
    /// Side of each light's self-shadow depth map (texels).
    pub shadow_resolution: u32,
    /// Pair weights below this are dropped and the rest renormalised (MNP01 §4.1).
    pub min_weight: f32,
    /// Facing or cross projection (draw only).
    pub projection: HbtProjection,
    /// Draw only, a baseline: reconstruct every tree under this fixed world direction (unit,
    /// towards the light) whatever the sun — a view-only impostor baked under one light, as
    /// octahedral impostors are. `None` (the default) follows the sun.
    pub fixed_light: Option<[f32; 3]>,
}

impl Default for HbtParams {
    fn default() -> Self {
        Self {
            levels: 2,
            branch_view_level: 1,
            branch_light_level: 1,
            max_branch_objects: 6,
            cube_resolution: 8,
            open_texel_pixels: 2.0,
            band: 0.3,
            // Measured: MNP01's 8-corner interpolation under-darkens a tree in another's shadow
            // (0.158 vs the reference's 0.289 on the test grove; cascades 0.261), see BENCHMARKS.md.
            shadows: HbtShadows::Cascades,
            // 66 views: with 18 (45° apart) the blend of 3 differing silhouettes blurs trees
            // and their shadows (FLIP on the default view 0.107 with 18, 0.082 with 66).
            view_level: 2,
            light_level: 1,
            tile: 32,
            supersample: 4,
            shadow_resolution: 256,
            min_weight: 0.05,
            projection: HbtProjection::Facing,
            fixed_light: None,
        }
    }
}

impl HbtParams {
    /// Checks every value; the error names the option and the valid range.
    pub fn validate(&self) -> Result<(), RenderError> {
        let bad = |m: String| Err(RenderError::Option(m));
        if !(1..=2).contains(&self.levels) {
            return bad(format!(
                "hbt levels {}: must be 1 (the tree) or 2 (tree and main branches)",
                self.levels
            ));
        }
        if !(1..=64).contains(&self.max_branch_objects) {
            return bad(format!(
                "hbt branch objects {}: must be 1 to 64",
                self.max_branch_objects
            ));
        }
        if !(2..=bake::MAX_CUBE_RESOLUTION).contains(&self.cube_resolution) {
            return bad(format!(
                "hbt cube-map resolution {}: must be 2 to {} (MNP01 uses 32)",
                self.cube_resolution,
                bake::MAX_CUBE_RESOLUTION
            ));
        }
        if !(self.open_texel_pixels.is_finite() && (0.1..=16.0).contains(&self.open_texel_pixels)) {
            return bad(format!(
                "hbt open texel pixels {}: must be 0.1 to 16",
                self.open_texel_pixels
            ));
        }
        if !(self.band.is_finite() && (0.0..=0.9).contains(&self.band)) {
            return bad(format!("hbt band {}: must be 0 to 0.9", self.band));
        }
        for (what, level) in [
            ("view", self.view_level),
            ("light", self.light_level),
            ("branch view", self.branch_view_level),
            ("branch light", self.branch_light_level),
        ] {
            if level > MAX_LEVEL {
                return bad(format!(
                    "hbt {what} level {level}: must be 0 to {MAX_LEVEL} (6, 18, 66 or 258 directions)"
                ));
            }
        }
        if !self.tile.is_power_of_two() || !(8..=256).contains(&self.tile) {
            return bad(format!(
                "hbt tile {}: must be a power of two from 8 to 256 — MNP01 uses 32 or 64",
                self.tile
            ));
        }
        if !(1..=crate::bake::MAX_SUPERSAMPLE).contains(&self.supersample) {
            return bad(format!(
                "hbt supersampling {}: must be 1 to {}",
                self.supersample,
                crate::bake::MAX_SUPERSAMPLE
            ));
        }
        if !(16..=crate::bake::MAX_TILE).contains(&self.shadow_resolution) {
            return bad(format!(
                "hbt shadow resolution {}: must be 16 to {}",
                self.shadow_resolution,
                crate::bake::MAX_TILE
            ));
        }
        if !(self.min_weight.is_finite() && (0.0..0.5).contains(&self.min_weight)) {
            return bad(format!(
                "hbt minimum weight {}: must be at least 0 and below 0.5",
                self.min_weight
            ));
        }
        if let Some(l) = self.fixed_light
            && !(l.iter().all(|c| c.is_finite()) && glam::Vec3::from(l).length() > 1e-6)
        {
            return bad(format!(
                "hbt fixed light {l:?}: must be a non-zero direction"
            ));
        }
        Ok(())
    }
}
