//! Technique `hbt`: MNP01 — Meyer, Neyret, Poulin, *Interactive Rendering of Trees with
//! Shading and Shadows*, EGWR 2001. A first increment: the top level of the hierarchy only.
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
//! - §4.1 and the appendix, **reconstruction**: per tree and frame, the 3 view samples and
//!   3 light samples enclosing the (model-space) eye and sun directions with their barycentric
//!   weights ([`crate::directions::DirectionSet::nearest3`] on the CPU, per instance); the 9
//!   products, those below [`HbtParams::min_weight`] dropped and the rest renormalised
//!   ([`reconstruction_weights`]); 9 weighted fetches summed in one fragment (the
//!   order-independent weighted sum the appendix builds with "darken then add", done in one
//!   pass) and composited premultiplied over the background. Colour = sun colour × direct BTF
//!   × received shadow + sky colour × ambient BTF (§4.2). Facing (billboard) or cross
//!   projection (§4.1, fig. 3.2), selectable ([`HbtProjection`]).
//!
//! Deviations, plainly:
//! - **Only the top level.** The tree is one BTF; the lower levels (main branches through
//!   `plant.instancing`, small branches), LOD by projected size (§4, §5) and baking higher
//!   levels from lower ones (§6.1) are not implemented yet.
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
//! - **Cross projection** composites its 3 planes with premultiplied "over" (not the appendix's
//!   exact weighted sum, which facing projection gets exactly).
//! - Leaf transmission is applied to wood too (the baker does not tell them apart), as in
//!   `boxtree`.
//!
//! Cost: bake = V + L rasterisations plus a CPU lighting pass of V·L·(tile·ss)² samples; per
//! frame, 2 direction look-ups per tree in view and 1 per tree per cascade (CPU), one instanced
//! draw per pass, up to 9 + 6 texture fetches per fragment. Memory: (V·L + 2V) tiles of
//! `tile²` RGBA8 with mips.

pub mod bake;
mod draw;

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

/// Bake and draw parameters of `hbt`.
#[derive(Debug, Clone, PartialEq)]
pub struct HbtParams {
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
            view_level: 1,
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
        for (what, level) in [("view", self.view_level), ("light", self.light_level)] {
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
