//! Technique `hbt`: MNP01 — Meyer, Neyret, Poulin, *Interactive Rendering of Trees with
//! Shading and Shadows*, EGWR 2001. Levels of the hierarchy: the tree, below it its main
//! branches and the rest of the plant, optionally (§7's third BTF level) each main branch's
//! small branches, and at the bottom the plant's own meshes.
//!
//! Implements:
//! - §3.1 the **bidirectional texture function** of a base object: one billboard per (view
//!   sample, light sample) pair of the shared direction sets ([`crate::directions`], 6/18/66/258
//!   samples), holding the object's colour lit by that light with **self-shadowing** inside it,
//!   plus the **ambient BTF** per view sample, sun and sky kept apart as §3.1 asks ([`bake`]);
//! - §6.1 building it (the lowest level, and by default every level): each view is
//!   rasterised once by the shared baker ([`crate::bake`]) into a
//!   supersampled albedo/normal/depth G-buffer; each light sample gets an orthographic depth map
//!   of the object (alpha-tested leaves, so alpha-aware); every covered G-buffer sample is lit
//!   with the reference's model (Lambert + leaf transmission) times its visibility from that
//!   light (5×5 PCF in the light's depth map: soft self-shadows), then box-filtered down to the
//!   tile and mip-mapped;
//! - §3.2/§7 the **level below** ([`HbtBakeParams::branches`]): representative main branches
//!   and the plant's rest, each with its BTF, and their placements ([`bake::branch_level`]);
//!   and (`levels` = 3, the default) §4's polygonal bottom: "the objects in the opened levels
//!   of the hierarchy, either polygonal meshes or BTF" — the plant's meshes, drawn with the
//!   `geometry` technique's pipelines;
//! - §7's **small-branch level** ([`HbtBakeParams::small_branches`], [`bake::small_level`]): each
//!   main branch's small branches with their BTFs, placements in the main branch's frame and
//!   cube-maps of the rest of the main branch; an opened tree opens each main branch into them
//!   by that branch's own texel size, and their visibility combines all three levels;
//! - §3.3/§6.2 the **hierarchy of visibility cube-maps** ([`visibility`]): for each branch
//!   placement (baked) and each placed tree (built when the scene is placed, [`scene`]), a
//!   cube-map at each of the 8 corners of its box holding the opacity of the rest of its level —
//!   the other branches of the tree, or the other trees and the terrain — from the occluders'
//!   own baked coverage;
//! - §4 **LOD by projected size**: a tree opens into the level below when one of its texels
//!   would cover more than [`HbtDrawParams::open_texel_pixels`] pixels, and into its meshes when
//!   one texel of its largest main branch would cover more than
//!   [`HbtDrawParams::mesh_texel_pixels`], each cross-faded over [`HbtDrawParams::band`] (billboards
//!   by optical depth, meshes by per-leaf presence); or, with [`HbtDrawParams::mesh_per_branch`]
//!   (MNP01's opened objects "either polygonal meshes or BTF"), each main branch of an opened
//!   tree into its own meshes where its own lowest texel would be, the plant's meshes split by
//!   placement ([`parts`]); §5 the meshes first (opaque), then every billboard (trees and
//!   opened trees' objects) back to front in one instanced draw;
//! - §4.1 and the appendix, **reconstruction**: per billboard and frame, the 3 view samples and
//!   3 light samples enclosing the (object-space) eye and sun directions with their barycentric
//!   weights (MNP01's precomputed table, [`crate::directions::DirectionLut::lookup`], on the
//!   CPU); the 9 products, those below [`HbtDrawParams::min_weight`] dropped and the rest
//!   renormalised ([`reconstruction_weights`]); 9 weighted fetches summed in one fragment (the
//!   order-independent weighted sum the appendix builds with "darken then add", done in one
//!   pass) and composited premultiplied over the background. Facing (billboard) or cross
//!   projection (§4.1, fig. 3.2), selectable ([`HbtProjection`]);
//! - §4.2 **lighting**: sun colour × direct BTF × sun transmittance + sky colour × ambient BTF
//!   × sky transmittance (+ ground colour × the ground-facing ambient image); the levels'
//!   cube-maps combined as `1 − Π(1 − opacity)` at the object's corners and interpolated
//!   trilinearly across the billboard; the sky transmittance is each cube-map's
//!   cosine-weighted upper-hemisphere mean. Moving the sun re-lights everything: only the sun's
//!   look-up in the cube-maps (when it moves) and the shadow maps change.
//!
//! Deviations, plainly:
//! - **Representative branches.** An L-system tree has as many distinct main branches as its
//!   parameters vary (26 on the pine, 223 on the prunus); MNP01's pine was built from a few
//!   instanced ones. At most [`HbtBakeParams::max_branch_objects`] are baked, and the others are
//!   drawn with the representative of their size group, scaled (16 by default: with 6, a pine
//!   70 px tall drawn from its branches was visibly wrong, ꟻLIP 0.059 against 0.049).
//! - **Two BTF levels by default, then meshes** (MNP01 §7 has three BTF levels: small
//!   branches too; here they are opt-in). The small branches of a main branch are the largest
//!   branch objects below it at most half its size ([`bake::SMALL_BRANCH_RATIO`]), not a fixed
//!   instancing depth: an L-system's bracket nesting makes each branch contain the rest of
//!   itself, a chain. The presets have almost none (the pine's main branches are single
//!   needled axes; only 3 of its 17 main-branch objects split, into a tip and a rest nearly as
//!   long as the branch; the prunus's and bush's main branches are leaf twigs), so they gain
//!   nothing; on `assets/plants/fir.lsys`, built as MNP01's pine, the level improves on the
//!   main branches alone (one fir 244 px tall: ꟻLIP 0.198 against 0.205) but stays far behind
//!   its meshes (0.101), and on the default view it makes the pine's meshes open later
//!   (0.048 against 0.044) — so it is off. A main branch's rest stays a BTF as long as the
//!   branch. The meshes open early — when the main branches' texels would cover 0.35 px, well before they
//!   are magnified: measured on the default view at 1280×720, magnified branch BTFs are both
//!   slower (overlapping billboards, 12 fetches per fragment) and further from the reference
//!   than the meshes (ꟻLIP 0.094 with the BTF levels only, 0.044 with meshes; BENCHMARKS.md).
//!   With the pine the branch level is then drawn only within the cross-fades (the prunus,
//!   whose branches are smaller against the tree, keeps a band of its own) — with
//!   `measured_switch` off: by default the presets skip it as dearer than their meshes (below).
//! - **A plant without main branches opens into its meshes where measured.** MNP01 opens
//!   levels where the billboard would be magnified; a plant whose level below is its rest
//!   alone (an imported mesh: no L-system branches) has nothing between its tree billboard and
//!   its meshes, and the presets' branch threshold, applied to a rest as large as the tree,
//!   meshed every tree of an imported broadleaf. The bake measures ([`bake::switch`]) how far
//!   the billboard and one-sample meshes each are from a 4×4-sampled rasterisation in ꟻLIP
//!   (albedo over a dark ground) at 16–256 px, and the meshes open where they become closer
//!   ([`HbtDrawParams::measured_switch`], default on).
//! - **A level below that costs more than the meshes is skipped** (a deviation from MNP01,
//!   whose three levels are fixed; #15: levels chosen from what they cost). Where the tree
//!   opens, the level below costs its billboards plus their fill (the bake's
//!   [`HbtBaked::branch_fill`]: how many times their quads cover the tree's, 1.9–5.9 on the
//!   presets) and the meshes their triangles ([`LevelCosts`], per-billboard, per-fragment and
//!   per-triangle costs fitted on lavapipe). Where the level below is dearer, the meshes —
//!   nearer the reference — dominate it, and the plant goes from its billboard to its meshes
//!   at the earlier of the measured crossing and the branch switch; the skipped level's BTFs
//!   and cube-maps are not uploaded (a plant without main branches likewise). On lavapipe every preset's
//!   level below is dearer (the chestnut's 1,458 branch billboards cost 46.6 ms where its
//!   182k triangles cost 34.4, the pine's 118 cost 9.8 ms where its 5.2k triangles cost 3.3,
//!   each alone at ≈ 90 px; `scripts/measure-hbt-level-costs.sh`): measured on `eval/broadleaf.toml` and `example.toml` at
//!   640×360 the frame is faster for an equal or lower ꟻLIP (BENCHMARKS.md, "the level below
//!   against the meshes"). A GPU whose fragments are cheaper against its triangles keeps the
//!   level where the constants say so; they are lavapipe's until measured there.
//! - **A tree opens into its meshes as a whole by default.** Branch by branch
//!   ([`HbtDrawParams::mesh_per_branch`], `--set hbt.mesh_per_branch=true`) is built: each triangle of the
//!   plant's own meshes is given to the root instance whose expansion has a triangle with the
//!   same centroid ([`parts`]), so each main branch draws its own polygons (not its
//!   representative's); the rest (trunk) and parts under 64 triangles open with the tree's
//!   first branch. Measured on the default view at 1280×720 it is slower for the same ꟻLIP —
//!   the presets' trees are 2.5–8k triangles, so the branches it keeps as BTFs cost more fill
//!   than their triangles would, and each (plant, part) is a draw (BENCHMARKS.md, "hbt meshes
//!   branch by branch") — so it is off; it is meant for trees of 10⁵ polygons.
//! - **Representatives are turned**: a group member is drawn with its representative scaled by
//!   the ratio of their diagonals and turned about its base so that its centroid points where
//!   the member's does (objects that differ only by the turn at their bracket — a bough left or
//!   right of its branch, a main branch pitched more or less — share one BTF).
//! - **By default each level is baked from geometry.** MNP01 §6.1 renders a higher level from
//!   the lower level's BTFs with the runtime algorithm so that levels shade alike:
//!   [`HbtBakeParams::tree_from_branches`] does that for the tree level (`compose.rs`, on the CPU)
//!   and, with small branches, for each main branch from its small branches.
//!   Measured, it switches to the branches more smoothly (ꟻLIP between the levels at the switch
//!   0.102 against 0.112) but is blurrier, the branches' reconstruction being resampled and
//!   reconstructed again (one pine 30 px tall, back-lit: 0.080 against 0.068; default view
//!   0.0516 against 0.0492 at 1280×720), so it is not the default.
//! - **Received sun shadows come from the cascaded shadow maps by default**
//!   ([`HbtShadows::Cascades`]), sampled once per fragment at the billboard point moved towards
//!   the sun just past the plane of the object's own caster (the sun-facing quad through its
//!   centre) plus [`HbtDrawParams::shadow_margin`] bounding radii (its own shadowing is in the
//!   BTF; neighbours between the point and the sun still shadow it point by point); the sky
//!   term still comes from the cube-maps. Before, the point moved a whole bounding radius,
//!   above a dense canopy for most of a crown (default scene against the 8192² reference:
//!   ꟻLIP 0.0607 → 0.0593 with the margin alone). MNP01's sun-from-cube-maps is
//!   [`HbtShadows::CubeMaps`]: measured, its 8-corner interpolation spreads a neighbour's
//!   shadow over the whole crown and under-darkens a tree in another's shadow (0.080 vs the
//!   reference's 0.289; cascades 0.301).
//! - Camera mips at the pixel footprint; [`HbtDrawParams::lod_bias`] −1 (as `zfield`'s) is
//!   0.0593 → 0.0585 on the same view for 2–4 % more frame time, so it is off.
//! - **Cube-maps are evaluated on the CPU** per texel from the occluders' baked coverage rather
//!   than rendered (§6.2); 8² per face by default (MNP01: 32², same ꟻLIP here at a quarter of
//!   the memory and build time). Occluders: at most 48 nearest within 5 bounding radii.
//! - **Shadow casting** (the ground's alpha shadow map, §5): trees cast into the cascades with
//!   stochastic (screen-door) alpha from the tree-level coverage of the view sample nearest the
//!   sun; trees opened into branches cast at the tree level; trees drawn as meshes cast as
//!   meshes into the cascades that shade their own leaves (by eye distance), elsewhere from
//!   their tree BTF; a tree meshed in part casts those parts as meshes there and its other
//!   branches as branch billboards.
//! - **Self-shadowing** uses depth maps with PCF rather than MNP01's ray tracer (§6.1).
//! - **Ambient occlusion inside an object** is the reference's crown-position estimate
//!   (`crown_occlusion` in `frame.wgsl`) evaluated at each baked sample (in the object's own
//!   box for the level below), so `hbt` and `geometry` agree; between objects and trees it is
//!   the cube-maps' sky term.
//! - **Cross projection** composites its 3 planes with premultiplied "over", each plane's
//!   opacity its share of the optical depth (as `boxtree`), not the appendix's exact weighted
//!   sum (which facing projection gets exactly).
//! - Leaf transmission is applied to wood too (the baker does not tell them apart), as in
//!   `boxtree`.
//! - **No scene-level cube-maps by default** ([`HbtDrawParams::scene_visibility`]): MNP01
//!   §3.3's top level — every placed tree's cube-maps against the other trees and the terrain —
//!   is built for every tree before the first frame (O(world): 6.6 s for the 7,665 trees of
//!   `assets/scenes/example.toml`, 362 s for 100k) and, measured, takes `hbt` further from the
//!   reference, whose sky term has no occlusion between trees (ꟻLIP 0.0728 with, 0.0711
//!   without at 640×360). It stays available with `--cpu-driven`; the branch level's baked
//!   cube-maps are kept.
//! - **GPU-driven** by default (`draw/gpu_frame.rs`, `draw/select.wgsl`): §4's selection and
//!   §4.1's look-ups run in compute passes over the world's culled lists, and everything is
//!   drawn indirect; the per-branch meshes, small branches, cross projection and cube-map sun
//!   are CPU-driven only (`--cpu-driven`; refused in one line otherwise).
//!
//! Cost: bake = V + L rasterisations plus a CPU lighting pass of V·L·(tile·ss)² samples per
//! object, plus the branch cube-maps and the measured mesh switch (19 rasterisations of 4 views
//! and 72 ꟻLIP evaluations, 2–12 s: 18 s for the chestnut's bake in all); per frame, 2
//! direction look-ups per billboard (CPU) and
//! 8 cube-map look-ups per opened branch, one instanced draw per pass, up to 9 + 3 texture
//! fetches per fragment; meshes as `geometry`. Memory (default, per plant): tree BTF 66 × 18 at
//! 32 px = 7.2 MB; up to 17 objects × 18 × 18 = 33 MB; the plant's meshes; branch cube-maps
//! 6·8² bytes × 8 corners per placement; the scene's cube-maps 3 KB per tree (CPU). With small
//! branches, up to 16 more representatives plus one rest per opening main branch, ~2 MB each
//! (the fir: 49 MB below the tree instead of 18 MB). Figures in BENCHMARKS.md.

pub mod bake;
mod compose;
mod draw;
mod entry;
pub mod parts;
pub mod scene;
pub mod visibility;

pub use bake::{HbtBake, HbtBaked, reconstruction_weights};
pub use draw::{Hbt, LevelCosts};
pub use entry::ENTRY;

use super::params::{self, ParamDoc, ParamTable};
use crate::directions::MAX_LEVEL;

/// How the blended images are projected on screen (MNP01 §4.1, fig. 3.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
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
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum HbtShadows {
    /// MNP01 §3.3/§4.2: the hierarchy of visibility cube-maps (other trees and terrain at the
    /// top level, other branches below), which also scale the sky term.
    CubeMaps,
    /// The renderer's cascaded shadow maps, sampled just past the object's own caster towards
    /// the sun ([`HbtDrawParams::shadow_margin`]); the sky term still comes from the cube-maps.
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

/// Bake parameters of `hbt` (the cache key).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HbtBakeParams {
    /// View-direction set of the tree level: subdivision level 0..=3 (written as its count:
    /// 6, 18, 66 or 258).
    #[serde(rename = "views", with = "params::direction_count")]
    pub view_level: u32,
    /// Light-direction set of the tree level.
    #[serde(rename = "lights", with = "params::direction_count")]
    pub light_level: u32,
    /// Billboard size in texels (MNP01: 32 or 64; a power of two 8–256).
    pub tile: u32,
    /// G-buffer samples per tile texel, per axis.
    pub supersample: u32,
    /// Side of each light's self-shadow depth map (texels).
    pub shadow_resolution: u32,
    /// Bake the level below the tree: representative main branches and the plant's rest, with
    /// their visibility cube-maps (needed by draw `levels` 2; `levels` 3 opens into meshes
    /// from the branches, or from the tree without them).
    pub branches: bool,
    /// View-direction set of the level below.
    #[serde(rename = "branch_views", with = "params::direction_count")]
    pub branch_view_level: u32,
    /// Light-direction set of the level below.
    #[serde(rename = "branch_lights", with = "params::direction_count")]
    pub branch_light_level: u32,
    /// Most distinct main branches baked per plant (the rest are drawn with a scaled
    /// representative; see [`bake::branch_level`]).
    pub max_branch_objects: u32,
    /// Side of each visibility cube-map face (MNP01 uses 32).
    pub cube_resolution: u32,
    /// With branches: bake the tree level by rendering the level below with the runtime
    /// algorithm (MNP01 §6.1), so the two levels shade alike; otherwise from geometry. With
    /// [`HbtBakeParams::small_branches`], each main branch that has small branches is likewise
    /// rendered from them first.
    pub tree_from_branches: bool,
    /// With branches: also bake MNP01 §7's third BTF level, each main branch's small branches
    /// ([`bake::small_level`]); an opened tree then opens each main branch into them where
    /// that branch's texels would be magnified. Off by default: measured, it gains little on a
    /// plant built for it and nothing on the presets (module docs, BENCHMARKS.md).
    pub small_branches: bool,
    /// With `tree_from_branches`: the pair-weight threshold of the composition (MNP01 §4.1).
    pub compose_min_weight: f32,
}

impl Default for HbtBakeParams {
    fn default() -> Self {
        Self {
            // 66 views: with 18 (45° apart) the blend of 3 differing silhouettes blurs trees
            // and their shadows (FLIP on the default view 0.107 with 18, 0.082 with 66).
            view_level: 2,
            light_level: 1,
            tile: 32,
            supersample: 4,
            shadow_resolution: 256,
            branches: true,
            branch_view_level: 1,
            branch_light_level: 1,
            max_branch_objects: 16,
            cube_resolution: 8,
            tree_from_branches: false,
            small_branches: false,
            compose_min_weight: 0.05,
        }
    }
}

impl ParamTable for HbtBakeParams {
    const DOCS: &'static [ParamDoc] = &[
        ParamDoc {
            key: "views",
            unit: "directions",
            doc: "view samples of the tree's BTF (MNP01 §3.1): 6, 18, 66 or 258",
        },
        ParamDoc {
            key: "lights",
            unit: "directions",
            doc: "light samples of the tree's BTF: 6, 18, 66 or 258",
        },
        ParamDoc {
            key: "tile",
            unit: "texels",
            doc: "billboard size (MNP01 uses 32 or 64; a power of two 8–256)",
        },
        ParamDoc {
            key: "supersample",
            unit: "per axis",
            doc: "G-buffer samples per texel per axis when baking",
        },
        ParamDoc {
            key: "shadow_resolution",
            unit: "texels",
            doc: "side of each light's self-shadow depth map",
        },
        ParamDoc {
            key: "branches",
            unit: "",
            doc: "bake the level below the tree: main branches with their visibility cube-maps (MNP01 §3.2)",
        },
        ParamDoc {
            key: "branch_views",
            unit: "directions",
            doc: "view samples of the branch BTFs: 6, 18, 66 or 258",
        },
        ParamDoc {
            key: "branch_lights",
            unit: "directions",
            doc: "light samples of the branch BTFs: 6, 18, 66 or 258",
        },
        ParamDoc {
            key: "max_branch_objects",
            unit: "objects",
            doc: "most distinct main branches baked per plant (others drawn with a scaled representative)",
        },
        ParamDoc {
            key: "cube_resolution",
            unit: "texels",
            doc: "visibility cube-map face size (MNP01 §3.3 uses 32)",
        },
        ParamDoc {
            key: "tree_from_branches",
            unit: "",
            doc: "bake the tree level by rendering its branches with the runtime algorithm (MNP01 §6.1) instead of from geometry",
        },
        ParamDoc {
            key: "small_branches",
            unit: "",
            doc: "also bake MNP01 §7's small-branch level below each main branch",
        },
        ParamDoc {
            key: "compose_min_weight",
            unit: "",
            doc: "with tree_from_branches: view × light pair weights below this are dropped when composing",
        },
    ];

    fn validate(&self) -> Result<(), String> {
        if !(1..=64).contains(&self.max_branch_objects) {
            return Err(format!(
                "max_branch_objects {}: must be 1 to 64",
                self.max_branch_objects
            ));
        }
        if !(2..=bake::MAX_CUBE_RESOLUTION).contains(&self.cube_resolution) {
            return Err(format!(
                "cube_resolution {}: must be 2 to {} (MNP01 uses 32)",
                self.cube_resolution,
                bake::MAX_CUBE_RESOLUTION
            ));
        }
        for (key, level) in [
            ("views", self.view_level),
            ("lights", self.light_level),
            ("branch_views", self.branch_view_level),
            ("branch_lights", self.branch_light_level),
        ] {
            if level > MAX_LEVEL {
                return Err(format!("{key}: must be 6, 18, 66 or 258 directions"));
            }
        }
        if !self.tile.is_power_of_two() || !(8..=256).contains(&self.tile) {
            return Err(format!(
                "tile {}: must be a power of two from 8 to 256 (MNP01 uses 32 or 64)",
                self.tile
            ));
        }
        if !(1..=crate::bake::MAX_SUPERSAMPLE).contains(&self.supersample) {
            return Err(format!(
                "supersample {}: must be 1 to {}",
                self.supersample,
                crate::bake::MAX_SUPERSAMPLE
            ));
        }
        if !(16..=crate::bake::MAX_TILE).contains(&self.shadow_resolution) {
            return Err(format!(
                "shadow_resolution {}: must be 16 to {}",
                self.shadow_resolution,
                crate::bake::MAX_TILE
            ));
        }
        if !(self.compose_min_weight.is_finite() && (0.0..0.5).contains(&self.compose_min_weight)) {
            return Err(format!(
                "compose_min_weight {}: must be at least 0 and below 0.5",
                self.compose_min_weight
            ));
        }
        Ok(())
    }
}

/// Draw parameters of `hbt` (never re-bake).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HbtDrawParams {
    /// Levels of the hierarchy drawn: 1, the tree; 2, also the level below (when baked),
    /// opened when the tree's texels would be magnified; 3, also the plant's own meshes (MNP01
    /// §4's polygonal bottom), opened when the largest main branch's texels would be (without a
    /// level below: the tree's).
    pub levels: u32,
    /// A tree opens into its branches when one of its texels would cover more than this many
    /// pixels (MNP01 §4: when the billboard would be magnified).
    pub open_texel_pixels: f32,
    /// (`levels` = 3) a tree is drawn as its meshes when one texel of its largest main branch
    /// would cover more than this many pixels (a plant without a level below: when its tree
    /// texel would cover more than [`HbtDrawParams::open_texel_pixels`]).
    pub mesh_texel_pixels: f32,
    /// (`levels` = 3) an opened tree draws each placement of the level below (main branch or
    /// rest) as its meshes where that placement's own lowest BTF texel would cover more than
    /// [`HbtDrawParams::mesh_texel_pixels`] (MNP01 §4: opened objects are "either polygonal
    /// meshes or BTF"); off, the tree opens into its meshes as a whole, by its largest main
    /// branch's texel.
    pub mesh_per_branch: bool,
    /// (`levels` = 3) a plant without main branches — its level below is its rest alone, as an
    /// imported mesh's is, or none — opens straight into its meshes where, measured at bake
    /// time ([`bake::switch`]), one-sample meshes get closer to the reference than its
    /// billboard (`sylvan bake --technique hbt --json`: `mesh_switch_texel_px`); off, it opens
    /// into its rest at [`HbtDrawParams::open_texel_pixels`] and its meshes at
    /// [`HbtDrawParams::mesh_texel_pixels`] of the rest's texel, thresholds tuned on the presets.
    /// On, a plant whose level below costs more than its meshes where the tree opens
    /// ([`LevelCosts`]: its billboards and their fill against its triangles) skips that level
    /// the same way, its meshes opening at the earlier of the measured crossing and the branch
    /// switch (`plants_without_branch_level` in the statistics); not with
    /// [`HbtDrawParams::mesh_per_branch`].
    pub measured_switch: bool,
    /// The cross-fade band around those switches, relative (0 = hard switch).
    pub band: f32,
    /// Received sun shadows from cube-maps or cascades.
    pub shadows: HbtShadows,
    /// MNP01 §3.3's top level: every placed tree's visibility cube-maps against the other
    /// trees and the terrain (their sky term; with [`HbtShadows::CubeMaps`] also the sun, and
    /// then always built). CPU-driven frames only: built for every placed tree before the first
    /// frame, they grow with the world.
    pub scene_visibility: bool,
    /// Pair weights below this are dropped and the rest renormalised (MNP01 §4.1).
    pub min_weight: f32,
    /// Facing or cross projection.
    pub projection: HbtProjection,
    /// A baseline: reconstruct every tree under this fixed world direction (unit, towards the
    /// light) whatever the sun — a view-only impostor baked under one light, as octahedral
    /// impostors are. `None` (the default) follows the sun.
    pub fixed_light: Option<[f32; 3]>,
    /// Mip bias of the camera pass (negative: sharper), −4 to 4.
    pub lod_bias: f32,
    /// ([`HbtShadows::Cascades`]) a billboard point takes its received sun shadow this far
    /// (in the object's bounding radii) past the plane of its own shadow caster towards the
    /// sun, 0 to 2.
    pub shadow_margin: f32,
}

impl Default for HbtDrawParams {
    fn default() -> Self {
        Self {
            // Measured on the default view at 1280×720 (BENCHMARKS.md): with the meshes below
            // the branches ꟻLIP 0.050 at 5.5× geometry's speed; without, 0.098 at 4.6×.
            levels: 3,
            open_texel_pixels: 2.0,
            // Measured on the default view at 1280×720, same speed: 0.35 ꟻLIP 0.044, 0.5 0.049,
            // 1.0 0.075 and slower (more branch billboards); one pine 60 px tall, back-lit, is
            // closer than boxtree only at 0.35. The pine's branch level is then drawn only
            // within its cross-fades (BENCHMARKS.md).
            mesh_texel_pixels: 0.35,
            // Measured on the default view at 1280×720: branch by branch 1.2× slower at the
            // same ꟻLIP (more branch BTF fill and draws; BENCHMARKS.md).
            mesh_per_branch: false,
            // Measured: an imported 205k-triangle chestnut (no main branches) drew every tree
            // of broadleaf.toml as meshes with the presets' thresholds (BENCHMARKS.md).
            measured_switch: true,
            band: 0.3,
            // Measured: MNP01's 8-corner interpolation under-darkens a tree in another's shadow
            // (0.080 vs the reference's 0.289 on the test grove; cascades 0.301), see BENCHMARKS.md.
            shadows: HbtShadows::Cascades,
            // Measured (640×360, ꟻLIP vs 16-spp geometry): without them `hbt` is closer to the
            // reference, whose sky term has no occlusion between trees — 0.0711 against 0.0728
            // on assets/scenes/example.toml, 0.0934 against 0.0936 on eval/broadleaf.toml — and
            // starts 6.6 s sooner on the former (BENCHMARKS.md, "`hbt` GPU-driven").
            scene_visibility: false,
            min_weight: 0.05,
            projection: HbtProjection::Facing,
            fixed_light: None,
            // Measured (BENCHMARKS.md, "hbt on the default scene against a converged
            // reference"): −1 takes the default scene's ꟻLIP against the 8192² reference from
            // 0.0593 to 0.0585 (with `shadow_margin` 0.3) and costs 2–4 % of the frame on
            // example.toml, where #15's ≥ 5× bar is marginal: off.
            lod_bias: 0.0,
            // Measured there: 1 (about the point a radius out, as before) 0.0609, 0.3 0.0593,
            // 0.1 0.0601, 0.02 0.0609 (too close: the object's own caster at its centre plane
            // shadows it again through the 3×3 PCF).
            shadow_margin: 0.3,
        }
    }
}

impl ParamTable for HbtDrawParams {
    const DOCS: &'static [ParamDoc] = &[
        ParamDoc {
            key: "levels",
            unit: "",
            doc: "levels drawn: 1 the tree, 2 also its main branches, 3 also the plant's meshes (MNP01 §4)",
        },
        ParamDoc {
            key: "open_texel_pixels",
            unit: "px",
            doc: "a tree opens into its branches when one of its texels would cover more than this",
        },
        ParamDoc {
            key: "mesh_texel_pixels",
            unit: "px",
            doc: "(levels 3) a tree is drawn as meshes when a texel of its largest main branch would cover more than this",
        },
        ParamDoc {
            key: "mesh_per_branch",
            unit: "",
            doc: "(levels 3) open an opened tree into its meshes branch by branch instead of as a whole",
        },
        ParamDoc {
            key: "measured_switch",
            unit: "",
            doc: "(levels 3) a plant without main branches, or whose branch level costs more than its meshes, opens from its billboard into its meshes where they get closer to the reference, measured at bake time",
        },
        ParamDoc {
            key: "band",
            unit: "× switch",
            doc: "cross-fade band around each level switch (0 = hard switches)",
        },
        ParamDoc {
            key: "shadows",
            unit: "",
            doc: "received sun shadows from \"cascades\" (measured closer) or \"cubemaps\" (MNP01 §3.3)",
        },
        ParamDoc {
            key: "min_weight",
            unit: "",
            doc: "view × light pair weights below this are dropped and the rest renormalised (MNP01 §4.1)",
        },
        ParamDoc {
            key: "projection",
            unit: "",
            doc: "blended images on one \"facing\" quad or on \"cross\" planes (MNP01 fig. 3.2)",
        },
        ParamDoc {
            key: "scene_visibility",
            unit: "",
            doc: "MNP01 §3.3's scene-level cube-maps of every placed tree (sky term; always with shadows=cubemaps); CPU-driven only (--cpu-driven)",
        },
        ParamDoc {
            key: "fixed_light",
            unit: "direction",
            doc: "baseline: reconstruct under this fixed light [x, y, z] whatever the sun (unset: follow the sun)",
        },
        ParamDoc {
            key: "lod_bias",
            unit: "mips",
            doc: "mip bias of the camera pass (negative: sharper; −4 to 4)",
        },
        ParamDoc {
            key: "shadow_margin",
            unit: "× radius",
            doc: "(shadows cascades) a billboard point takes its received shadow this far past its own caster's plane towards the sun",
        },
    ];

    fn validate(&self) -> Result<(), String> {
        if !(1..=3).contains(&self.levels) {
            return Err(format!(
                "levels {}: must be 1 (the tree), 2 (tree and main branches) or 3 (also the plant's meshes)",
                self.levels
            ));
        }
        if !(self.open_texel_pixels.is_finite() && (0.1..=16.0).contains(&self.open_texel_pixels)) {
            return Err(format!(
                "open_texel_pixels {}: must be 0.1 to 16",
                self.open_texel_pixels
            ));
        }
        if !(self.mesh_texel_pixels.is_finite() && (0.1..=16.0).contains(&self.mesh_texel_pixels)) {
            return Err(format!(
                "mesh_texel_pixels {}: must be 0.1 to 16",
                self.mesh_texel_pixels
            ));
        }
        if !(self.band.is_finite() && (0.0..=0.9).contains(&self.band)) {
            return Err(format!("band {}: must be 0 to 0.9", self.band));
        }
        if !(self.min_weight.is_finite() && (0.0..0.5).contains(&self.min_weight)) {
            return Err(format!(
                "min_weight {}: must be at least 0 and below 0.5",
                self.min_weight
            ));
        }
        if !(self.lod_bias.is_finite() && (-4.0..=4.0).contains(&self.lod_bias)) {
            return Err(format!("lod_bias {}: must be −4 to 4", self.lod_bias));
        }
        if !(self.shadow_margin.is_finite() && (0.0..=2.0).contains(&self.shadow_margin)) {
            return Err(format!(
                "shadow_margin {}: must be 0 to 2",
                self.shadow_margin
            ));
        }
        if let Some(l) = self.fixed_light
            && !(l.iter().all(|c| c.is_finite()) && glam::Vec3::from(l).length() > 1e-6)
        {
            return Err(format!("fixed_light {l:?}: must be a non-zero direction"));
        }
        Ok(())
    }
}

/// The WGSL of `hbt` as compiled: the frame's group 0, `bindings.wgsl` (group 1), then `hbt.wgsl`.
pub(crate) fn shader_source() -> String {
    crate::pipeline::with_frame(concat!(
        include_str!("bindings.wgsl"),
        include_str!("hbt.wgsl")
    ))
}
