//! Technique `boxtree`: LCV04 — Lluch, Camahort, Vivó, *An Image-Based Multiresolution Model
//! for Interactive Foliage Rendering*, WSCG 2004.
//!
//! Implements:
//! - §3.1/§3.2.1 the bounding-box hierarchy (built by `sylvan-plant`'s turtle, one node per
//!   branch);
//! - §3.2.4 the volume-ratio threshold choosing which boxes get images ([`bake::select_boxes`]);
//! - §3.2.2/§3.2.3 the images of each chosen box: orthographic, tightly framed, 64 or 128 px
//!   ([`BoxTreeBakeParams::tile`]), baked by the shared baker ([`crate::bake`]);
//! - §4 (fig. 3) the axis-aligned cross and (fig. 6) the six diagonally aligned planes
//!   ([`PlaneLayout`]); the default is the axis cross, which measured better overall: on the
//!   default forest at 1280×720 it meets the fidelity target (ꟻLIP 0.0575 against 1-spp
//!   geometry's 0.0500) at 7.6× geometry's speed, where diagonal planes are a little closer
//!   (0.0530) but draw twice the planes (4.9×); on a single tree seen level it is closer too;
//! - §4.1 the per-tree, per-frame traversal: a box is drawn as images beyond its LOD distance
//!   (where one texel covers one pixel), else opened; leaves nearest the viewer are real leaf
//!   geometry (fig. 8) ([`traverse`]);
//! - §4.2 alpha-blended transitions between levels over a distance band, and alpha blending of
//!   the planes of a box.
//!
//! Deviations, each for a measured or stated reason:
//! - **Lighting is not baked.** Images hold premultiplied albedo, coverage, normal and depth;
//!   texels are lit at run time with the reference's model (sun × shadow map, sky × crown
//!   occlusion, leaf translucency), so `boxtree` shades like `geometry` under any sun. LCV04
//!   bakes shaded colour.
//! - **Wood**: with `bake_wood` (default) a box's images include the wood inside it, and that
//!   wood is drawn as geometry only once the box is opened — the wood's simplification by
//!   distance. LCV04 always draws wood as geometry (`bake_wood = false` does that).
//! - **Box choice** compares a box's volume with its nearest *textured* ancestor, not its
//!   parent (see [`bake::select_boxes`]).
//! - **Plane weighting**: the paper blends the planes as they are; here each plane's optical
//!   depth is weighted by (view·normal)², normalised over the box's planes, so edge-on planes
//!   vanish and a box seen along a baked direction is exact.
//! - **Transitions** blend by optical depth (impostor) and by per-leaf presence (geometry)
//!   rather than by a plain alpha cross-fade, which would dip in opacity mid-band.
//! - Diagonal planes use one image per plane, seen mirrored from behind (normal reflected), so
//!   both layouts store six images per box as in the paper.
//!
//! Cost: drawn from the tiled world (GPU-driven, the default), the traversal runs in compute
//! passes over the world cull's lists (`gpu.rs`, `traverse.wgsl`: one invocation per listed
//! tree and pass walks its box tree in pre-order; impostors and opened boxes are counted into
//! segments — the camera's impostors by distance bucket, far first — and scattered into
//! compacted lists with their indirect draw arguments; the opened boxes' draws compacted per
//! (pass, mesh, species) so that one `multi_draw_indexed_indirect` draws a species' opened
//! boxes): the CPU records per (pass, species), never per box or tree. With `--cpu-driven` the
//! same traversal runs on the CPU ([`traverse`]) for every culled tree per pass, and the
//! residual geometry is one instanced draw per (species, opened box) for wood and for leaves.
//! Either way: impostors of all trees and species in one instanced draw per pass (sorted back
//! to front in the main pass).
//! Limits: at most [`MAX_BOXES`] boxes per plant; the atlas must fit the device's texture
//! size and array-layer limits (checked before allocating).

pub mod bake;
mod draw;
mod gpu;
pub mod traverse;

pub use crate::bake::views::PlaneLayout;
pub use bake::{BoxTreeBake, BoxTreeBaked};
pub use draw::BoxTree;

use super::Built;
use super::params::{self, ParamDoc, ParamTable};
use super::registry::{self, Entry, Kind};

/// Most boxes (and so images × 6) per plant.
pub const MAX_BOXES: u32 = 256;

/// Bake parameters of `boxtree` (the cache key).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoxTreeBakeParams {
    /// Image size in texels (LCV04 §3.2.3: 64 or 128; any power of two 16–512 accepted).
    pub tile: u32,
    /// Volume-ratio threshold (LCV04 §3.2.4).
    pub volume_threshold: f32,
    /// Fewest leaves a box needs to get images.
    pub min_leaves: u32,
    /// Most boxes per plant.
    pub max_boxes: u32,
    /// Plane arrangement.
    pub layout: PlaneLayout,
    /// Include the wood inside a box in its images (see the module docs).
    pub bake_wood: bool,
    /// Supersampling per axis when baking (coverage precision).
    pub supersample: u32,
}

impl Default for BoxTreeBakeParams {
    fn default() -> Self {
        Self {
            tile: 64,
            volume_threshold: 0.005,
            min_leaves: 32,
            max_boxes: 24,
            layout: PlaneLayout::Axis,
            bake_wood: true,
            supersample: 4,
        }
    }
}

impl ParamTable for BoxTreeBakeParams {
    const DOCS: &'static [ParamDoc] = &[
        ParamDoc {
            key: "tile",
            unit: "texels",
            doc: "image size per box face (LCV04 §3.2.3 uses 64 or 128; a power of two 16–512)",
        },
        ParamDoc {
            key: "volume_threshold",
            unit: "",
            doc: "a box gets images when its volume is at most this fraction of its nearest textured ancestor's (LCV04 §3.2.4)",
        },
        ParamDoc {
            key: "min_leaves",
            unit: "leaves",
            doc: "fewest leaves a box needs to get images",
        },
        ParamDoc {
            key: "max_boxes",
            unit: "boxes",
            doc: "most boxes per plant that get images",
        },
        ParamDoc {
            key: "layout",
            unit: "",
            doc: "plane arrangement: \"axis\" (LCV04 fig. 3), \"diagonal\" (fig. 6) or \"billboard\" (the naive one-image baseline)",
        },
        ParamDoc {
            key: "bake_wood",
            unit: "",
            doc: "bake the wood inside a box into its images (false: all wood stays geometry, as LCV04)",
        },
        ParamDoc {
            key: "supersample",
            unit: "per axis",
            doc: "samples per texel per axis when baking",
        },
    ];

    fn validate(&self) -> Result<(), String> {
        if !self.tile.is_power_of_two() || !(16..=512).contains(&self.tile) {
            return Err(format!(
                "tile {}: must be a power of two from 16 to 512 (LCV04 uses 64 or 128)",
                self.tile
            ));
        }
        if !(self.volume_threshold.is_finite() && (0.0..=1.0).contains(&self.volume_threshold)) {
            return Err(format!(
                "volume_threshold {}: must be between 0 and 1",
                self.volume_threshold
            ));
        }
        if !(1..=MAX_BOXES).contains(&self.max_boxes) {
            return Err(format!(
                "max_boxes {}: must be 1 to {MAX_BOXES}",
                self.max_boxes
            ));
        }
        if !(1..=crate::bake::MAX_SUPERSAMPLE).contains(&self.supersample) {
            return Err(format!(
                "supersample {}: must be 1 to {}",
                self.supersample,
                crate::bake::MAX_SUPERSAMPLE
            ));
        }
        Ok(())
    }
}

/// Draw parameters of `boxtree` (never re-bake).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoxTreeDrawParams {
    /// A box opens when one of its texels would cover more than this many pixels.
    pub texel_pixels: f32,
    /// Width of the transition band, relative to the LOD distance.
    pub band: f32,
    /// GPU-driven frame: records the impostor and opened-box lists hold at first (0: one
    /// impostor per listed tree and 16,384 opened boxes). They grow from what the GPU counted;
    /// a frame that outgrows them is drawn again by `Renderer::render` (an embedding caller
    /// misses the overflow for one frame).
    pub initial_lists: u32,
}

impl Default for BoxTreeDrawParams {
    fn default() -> Self {
        Self {
            texel_pixels: 0.8,
            band: 0.5,
            initial_lists: 0,
        }
    }
}

impl ParamTable for BoxTreeDrawParams {
    const DOCS: &'static [ParamDoc] = &[
        ParamDoc {
            key: "texel_pixels",
            unit: "px",
            doc: "a box opens when one of its texels would cover more than this many pixels (LCV04 §4.1)",
        },
        ParamDoc {
            key: "band",
            unit: "× LOD distance",
            doc: "width of the cross-fade band between levels (0 = hard switches; LCV04 §4.2)",
        },
        ParamDoc {
            key: "initial_lists",
            unit: "records",
            doc: "GPU-driven frame: records the impostor and opened-box lists hold at first (0: one impostor per listed tree, 16384 opened boxes); they grow from the GPU's counts, and a frame that outgrew them is drawn again",
        },
    ];

    fn validate(&self) -> Result<(), String> {
        if !(self.texel_pixels.is_finite() && self.texel_pixels > 0.05 && self.texel_pixels <= 64.0)
        {
            return Err(format!(
                "texel_pixels {}: must be above 0.05 and at most 64",
                self.texel_pixels
            ));
        }
        if !(self.band.is_finite() && (0.0..=4.0).contains(&self.band)) {
            return Err(format!("band {}: must be 0 to 4", self.band));
        }
        if self.initial_lists > 1 << 24 {
            return Err(format!(
                "initial_lists {}: must be at most 16777216 (0: sized from the first frame's lists)",
                self.initial_lists
            ));
        }
        Ok(())
    }
}

/// The registry entry.
pub const ENTRY: Entry = Entry {
    name: "boxtree",
    kind: Kind::PerTree,
    summary: "LCV04: a bounding-box hierarchy with six images per box, opened by distance",
    debug_color: [0.1, 0.5, 1.0],
    gpu_driven: true,
    schema: params::schema::<BoxTreeBakeParams, BoxTreeDrawParams>,
    check: |s| params::resolve::<BoxTreeBakeParams, BoxTreeDrawParams>("boxtree", s).map(|_| ()),
    build: |cx| {
        let (bake, draw) = params::resolve::<BoxTreeBakeParams, BoxTreeDrawParams>(
            "boxtree",
            &cx.settings_for("boxtree"),
        )?;
        let (assets, reports) = cx.load_assets::<BoxTreeBake>(&bake)?;
        Ok(Built {
            technique: Box::new(BoxTree::new(
                cx.gpu, cx.frame, cx.plants, &assets, &bake, &draw,
            )?),
            reports,
        })
    },
    bake: Some(registry::bake_with::<BoxTreeBake, BoxTreeDrawParams>),
    casts_translucent: None,
    shaders: || {
        vec![
            ("boxtree", shader_source()),
            (
                "boxtree_traverse",
                include_str!("traverse.wgsl").to_string(),
            ),
        ]
    },
};

/// The WGSL of `boxtree` as compiled: the frame's group 0, `bindings.wgsl` (group 1), then
/// `boxtree.wgsl`.
pub(crate) fn shader_source() -> String {
    crate::pipeline::with_frame(concat!(
        include_str!("bindings.wgsl"),
        include_str!("boxtree.wgsl")
    ))
}
