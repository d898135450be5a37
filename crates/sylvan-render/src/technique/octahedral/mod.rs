//! Technique `octahedral`: the hemi-octahedral impostor — the industry baseline, not one of
//! the seed papers. One camera-facing quad per tree, textured from a grid of views of the
//! plant baked over the upper hemisphere and blended per pixel.
//!
//! References (read for the method, no code taken): Ryan Brucks, *Octahedral Impostors*
//! (shaderbits.com, 2018) and Unreal's ImpostorBaker plugin; the Godot and Unity impostor
//! tools that follow it; the octahedral map of Engelhardt & Dachsbacher, *Octahedron
//! Environment Maps* (VMV 2008), folded onto the upper hemisphere.
//!
//! **Inputs**: a plant (meshes, leaf texture, bounding box). **Output of the bake**
//! ([`OctahedralBaked`]): `grid² ` tiles, one per view direction, each premultiplied linear
//! albedo + coverage and model-space normal + depth with full mips — exactly what `boxtree`'s
//! tiles hold (the shared baker's [`crate::bake::image::TileImage`]). Lighting is not baked:
//! texels are lit at run time with the reference's model, so the sun can move.
//!
//! Choices, each one a knob or a stated reason:
//! - **Grid**: `grid × grid` views at the *corners* of the grid over the hemi-octahedral square
//!   ([`bake::grid_direction`]): grid point `(i, j)` ↦ `(a, b) = 2(i, j)/(grid − 1) − 1` ↦
//!   `x = (a + b)/2`, `z = (a − b)/2`, `y = 1 − |x| − |z|`, normalised (y up). The square's
//!   border is the horizon, so trees seen level (the common case) are sampled by baked
//!   horizon views; the zenith is a grid point only for odd grids. The inverse
//!   ([`bake::hemi_oct_encode`]) is `(x, z)/(|x| + |y| + |z|)` rotated by 45°. A direction falls in one
//!   grid cell, split along its `(0,0)–(1,1)` diagonal into two triangles; its 3 views are that
//!   triangle's corners with barycentric weights ([`bake::view_weights`]), which reduce to one
//!   view of weight 1 on a grid direction.
//! - **Frame**: one square frame for every view ([`crate::bake::views::PlaneFrame::for_sphere`]):
//!   centred on the bounding-box centre, half side and half depth the radius of the box's
//!   circumscribed sphere, so all views share scale and depth range and blend without jumps.
//! - **Draw**: one camera-facing quad per tree, sized to the sphere's perspective silhouette,
//!   all trees of all species in one instanced draw per pass (species' tiles in one
//!   `texture_2d_array` atlas). The vertex shader turns the eye direction into the tree's
//!   object frame (instances turn about Y), clamps it to the upper hemisphere and picks the 3
//!   views; the fragment shader intersects the pixel's ray with each view's plane and samples
//!   that view where it saw the point, then **parallax**: [`OctahedralDrawParams::parallax_steps`]
//!   refinements moving the sample along the ray to the height the baked depth gives there
//!   (the engines' "depth-based parallax"). The 3 samples are blended premultiplied by their
//!   weights; normal and surface point are coverage-weighted.
//! - **Blending and depth**: as `boxtree`'s camera pass — premultiplied "over", sorted back to
//!   front over all species, depth tested at the quad (the plane through the crown's centre)
//!   but **not written**, so overlapping trees composite by order, not by a depth cut-out; no
//!   alpha to coverage. Presence (an LOD transition) scales optical depth.
//! - **Lighting**: the reference's model at the blended surface point (sun × cascaded shadows,
//!   leaf transmission from behind, sky term × crown occlusion, fog), as `boxtree` lights its
//!   texels.
//! - **Shadows**: each tree casts a quad facing the sun textured from the grid view nearest
//!   the sun, with stochastic coverage (the 3×3 PCF softens it) and the parallaxed surface's
//!   depth written (`frag_depth`, offset away from the sun by [`SHADOW_OFFSET`] of the radius),
//!   so the crown's sunlit side is not shadowed by a plane through its middle. The quad covers
//!   only what that view can show (`tight_casters`, default on: the box projected along the
//!   view, widened by the parallax's reach and the mips' spread; `caster_view_extent` in
//!   `frame.wgsl`) — the same shadows up to threshold flips by rounding (ꟻLIP 0.0002 on the
//!   built-in forest) from fewer fragments.
//!
//! **Cost**: per frame a CPU sort of the camera instances (O(n log n)); per pass one draw of
//! 2 triangles per tree; per fragment 3 × (1 + parallax steps) normal/depth fetches and 3
//! colour fetches. **Memory**: `grid² × tile² × 4 B × 2` images × 4/3 (mips) per distinct
//! plant: 2.8 MB at the defaults (8², 64 px). **Limits**: views above the horizon only (a tree
//! seen from below uses the horizon views, re-projected); no self-occlusion between views
//! beyond what the depth parallax corrects; the silhouette of thin parts blurs where views
//! disagree (ghosting between grid views); no per-leaf presence, so LOD transitions fade.
//!
//! **Measured** (lavapipe, release, `scripts/measure-octahedral.sh`): ꟻLIP vs `geometry
//! --spp 16` on one pine at 400/200/100/50 px: 0.0738/0.0578/0.0532/0.0586 (1-spp geometry
//! 0.0214/0.0324/0.0479/0.0520, boxtree 0.0214/0.0342/0.0496/0.0509); parallax off
//! 0.0810/0.0640/0.0587/0.0647; grid 12 within 0.002 of grid 8 (kept 8: 2.2× less memory);
//! tile 128 better at ≥ 100 px, worse at 50 px (kept 64). Default scene 1280×720: ꟻLIP
//! 0.0815 (geometry 1 spp 0.0500, boxtree 0.0574, hbt 0.0443); frame 5059 ms median vs
//! geometry 29463, boxtree 1720, hbt 2375. A coarse-mip early out for empty pixels was tried
//! and measured slower (5880 ms), so it is not in.

pub mod bake;
mod draw;

pub use bake::{OctahedralBake, OctahedralBaked};
pub use draw::Octahedral;

use super::Built;
use super::params::{self, ParamDoc, ParamTable};
use super::registry::{self, Entry, Kind};

/// Shadow casters' depth is pushed this fraction of the plant's radius away from the sun.
pub const SHADOW_OFFSET: f32 = 0.04;

/// Bake parameters of `octahedral`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OctahedralBakeParams {
    /// Views per side of the hemi-octahedral grid (`grid²` views), 4 to 32.
    pub grid: u32,
    /// Tile size of each view in texels, a power of two from 16 to 512.
    pub tile: u32,
    /// Supersampling per axis when baking (coverage precision), 1 to 8.
    pub supersample: u32,
}

impl Default for OctahedralBakeParams {
    fn default() -> Self {
        Self {
            grid: 8,
            tile: 64,
            supersample: 4,
        }
    }
}

/// Most texels of one plant's views together (`grid² × tile²`).
pub const MAX_TEXELS: u64 = 1 << 26;

impl ParamTable for OctahedralBakeParams {
    const DOCS: &'static [ParamDoc] = &[
        ParamDoc {
            key: "grid",
            unit: "views per side",
            doc: "hemi-octahedral grid of grid² view directions over the upper hemisphere (4–32)",
        },
        ParamDoc {
            key: "tile",
            unit: "texels",
            doc: "size of each view's image (a power of two 16–512)",
        },
        ParamDoc {
            key: "supersample",
            unit: "per axis",
            doc: "samples per texel per axis when baking",
        },
    ];

    fn validate(&self) -> Result<(), String> {
        let bad = |m: String| Err(m);
        if !(4..=32).contains(&self.grid) {
            return bad(format!("octahedral grid {}: must be 4 to 32", self.grid));
        }
        if !self.tile.is_power_of_two() || !(16..=512).contains(&self.tile) {
            return bad(format!(
                "octahedral tile {}: must be a power of two from 16 to 512",
                self.tile
            ));
        }
        if !(1..=crate::bake::MAX_SUPERSAMPLE).contains(&self.supersample) {
            return bad(format!(
                "octahedral supersample {}: must be 1 to {}",
                self.supersample,
                crate::bake::MAX_SUPERSAMPLE
            ));
        }
        let texels = (self.grid as u64 * self.tile as u64).pow(2);
        if texels > MAX_TEXELS {
            return bad(format!(
                "octahedral grid {} × tile {}: {} Mtexels per plant, more than {} — lower the grid or the tile",
                self.grid,
                self.tile,
                texels >> 20,
                MAX_TEXELS >> 20
            ));
        }
        Ok(())
    }
}

/// Draw parameters of `octahedral` (never re-bake).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OctahedralDrawParams {
    /// Depth-parallax refinements per view sample (0: sample where the ray meets the view's
    /// plane), 0 to 4.
    pub parallax_steps: u32,
    /// Views blended per pixel: 3 (the grid triangle) or 1 (the nearest view, no blending).
    pub views: u32,
    /// Shadow casters cover only the part of their sun-facing quad that their view can show
    /// (the box projected along it, widened by the parallax's reach) instead of the bounding
    /// square.
    pub tight_casters: bool,
}

impl Default for OctahedralDrawParams {
    fn default() -> Self {
        Self {
            parallax_steps: 2,
            views: 3,
            tight_casters: true,
        }
    }
}

impl ParamTable for OctahedralDrawParams {
    const DOCS: &'static [ParamDoc] = &[
        ParamDoc {
            key: "parallax_steps",
            unit: "steps",
            doc: "depth-parallax refinements per view sample (0: sample where the ray meets the view's plane; 0–4)",
        },
        ParamDoc {
            key: "views",
            unit: "views",
            doc: "views blended per pixel: 3 (the grid triangle) or 1 (the nearest view)",
        },
        ParamDoc {
            key: "tight_casters",
            unit: "bool",
            doc: "shadow casters cover only what their view can show (the box's projection and the parallax's reach), not the bounding square; false: the whole square (for comparisons)",
        },
    ];

    fn validate(&self) -> Result<(), String> {
        if self.parallax_steps > 4 {
            return Err(format!(
                "parallax_steps {}: must be 0 to 4",
                self.parallax_steps
            ));
        }
        if self.views != 1 && self.views != 3 {
            return Err(format!("views {}: must be 1 or 3", self.views));
        }
        Ok(())
    }
}

fn resolve(
    settings: &[&sylvan_scene::Setting],
) -> Result<(OctahedralBakeParams, OctahedralDrawParams), crate::RenderError> {
    params::resolve::<OctahedralBakeParams, OctahedralDrawParams>("octahedral", settings)
}

/// The registry entry.
pub const ENTRY: Entry = Entry {
    name: "octahedral",
    kind: Kind::PerTree,
    summary: "industry baseline: hemi-octahedral impostor, one quad per tree, 3 views blended with parallax",
    debug_color: [0.35, 1.0, 0.2],
    gpu_driven: true,
    schema: params::schema::<OctahedralBakeParams, OctahedralDrawParams>,
    check: |s| resolve(s).map(|_| ()),
    build: |cx| {
        let (bake, draw) = resolve(&cx.settings_for("octahedral"))?;
        let (assets, reports) = cx.load_assets::<OctahedralBake>(&bake)?;
        Ok(Built {
            technique: Box::new(Octahedral::new(
                cx.gpu, cx.frame, cx.plants, &assets, &bake, &draw,
            )?),
            reports,
        })
    },
    bake: Some(registry::bake_with::<OctahedralBake, OctahedralDrawParams>),
    casts_translucent: None,
    shaders: || vec![("octahedral", shader_source())],
};

/// The WGSL of `octahedral` as compiled: the frame's group 0, `bindings.wgsl` (group 1), then
/// `octahedral.wgsl`.
pub(crate) fn shader_source() -> String {
    crate::pipeline::with_frame(concat!(
        include_str!("bindings.wgsl"),
        include_str!("octahedral.wgsl")
    ))
}
