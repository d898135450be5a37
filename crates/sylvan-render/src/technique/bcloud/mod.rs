//! Technique `billboard-cloud`: GPSS07, García, Patow, Szirmay-Kalos & Sbert, *Multi-layered
//! indirect texturing for tree rendering* (EG Natural Phenomena 2007).
//!
//! The leaves of a plant are clustered into a cloud of planes (§4.1, [`cluster`]); each plane
//! is a rectangle whose texture does not hold images of the leaves but *indexes* them (§4.2,
//! [`layers`]): a **hash grid** of cells, each the start and length of a **list** of the leaf
//! fragments overlapping it sorted front to back, each entry naming a **leaf record** (where
//! the leaf lies on the plane, its normal frame, colour and ambient occlusion), whose image is
//! fetched from the plant's own **leaves textures** (front, back, normal map). The fragment
//! shader (§5, fig. 7) walks the cell's list until an opaque leaf texel is found, with the
//! back-side image where a leaf is seen from behind — here through the plane's slab (below),
//! so leaves keep their exact positions, shapes and overlaps however close the camera comes
//! and from every side, at a few MB per plant.
//!
//! - **Shader LOD** (§5.1, figs. 9–10): the entries walked are `entries_per_px` × the
//!   projected diagonal of a hash cell in pixels (\[LB06\], from screen derivatives); when they
//!   run out before an opaque leaf the pixel takes the plane's low-resolution image (built from
//!   the same lists at bake time), which is alpha-tested by a hashed threshold so partial
//!   coverage stays partial on average. Below one entry only the low-resolution image is read.
//! - **Geometric LOD** (§6): three clouds of decreasing plane count (`planes`, `planes_mid`,
//!   `planes_far`), switched by apparent size (`mid_px_per_m`, `far_px_per_m`: pixels per metre
//!   at which the next cloud takes over) with a cross-fade; the farthest cloud keeps only its
//!   low-resolution images and is drawn with a cheaper pipeline (no list walk), and its switch
//!   distance is where the mid cloud's walk has already dropped to zero entries (checked).
//! - **Lighting** (§5.2): the reference's model (`geometry`'s leaf shading: Lambert in front,
//!   diffuse transmission behind, sky × occlusion, cascaded shadows, fog) with the leaf normal
//!   frame of the record bent by the plant's normal map; the occlusion is the reference's
//!   per-vertex term extrapolated to the leaf's box corners by least squares (fig. 11) and
//!   interpolated bilinearly, all evaluated at the point the pixel shows. Shadows: the clouds
//!   cast into the shared cascades with the same walk (its level of detail follows the shadow
//!   map's texels; leaf alpha at full resolution, as `geometry`'s casters; the written depth
//!   pushed away from the sun by a texel × (1 + the leaf's slope), as the slope-scaled depth
//!   bias `geometry`'s casters get), the far cloud with the low-resolution evaluation.
//! - **Wood**: the plant's wood mesh, drawn like `geometry`'s, and for the far cloud a
//!   simplified mesh holding only the branches of the first `far_wood_levels` levels (the
//!   trunk and main limbs; GPSS07 uses progressive meshes \[Hop96\]).
//! - **Atlases**: all planes of all species share one plane table, one hash table, one list
//!   buffer and one record buffer (GPSS07 §6's atlases, as storage buffers), and the
//!   low-resolution tiles two texture atlases, so one species' cloud is one draw per pass.
//!
//! Deviations (each a stated reason; see also [`layers`]): storage buffers instead of hash and
//! list textures (the same layout, read without filtering); records per leaf with 4-byte list
//! entries; **each plane drawn as the box of its leaves** (its rectangle × the heights its
//! leaves span; the inside faces, so the eye may be inside) and **each leaf drawn where the
//! pixel's ray meets the leaf's own fitted plane**, the ray followed through the box cell by
//! cell of the hash grid (at most 64 cells), instead of leaf images placed on a flat billboard
//! by an orientation index — GPSS07's images are displaced and re-shaped by the leaf's height
//! above and angle to its plane, and a plane seen edge-on covers almost nothing, which no
//! texture resolution recovers (measured on the chestnut at 800 px: 3.3× 1-spp geometry's ꟻLIP
//! with images placed on planes, 2.0× with rays met on flat planes, 1.77× through slabs);
//! fragments from the leaves' triangles (exact overlap) instead of depth-peeled point sprites;
//! clustering that also weighs a leaf's angle to its plane ([`cluster::EDGE_ON_WEIGHT`]);
//! **a bent leaf cut into flat parts** ([`cluster::parts`]: one affine image of the leaf
//! texture cannot follow a blade folded about its midrib — its fitted plane lies between the
//! halves, and its normal field averages them — so a leaf whose triangle normals spread is
//! cut along the line of its image that leaves the least spread, each part showing its side
//! of the image: the chestnut at 800 px 1.56× → 1.26× 1-spp geometry's ꟻLIP, for twice the
//! records); the
//! occlusion is the reference's own term so the technique matches its ground truth; the depth
//! written is the point shown, not the plane's (GPSS07), so crossing planes and the wood
//! occlude where the leaves lie (it costs the early depth test).
//!
//! **Cost**: per pixel of a box one hash read per cell crossed and up to `entries` record reads
//! and leaf texture fetches in all (or one low-resolution fetch); per tree 8 vertices and 12
//! triangles per occupied block (4 and 2 for the far cloud) plus its wood.
//! **Memory** per plant: [`bake::BillboardCloudBaked::bytes`] (planes, cells, lists, records,
//! tiles with mips) plus the leaf textures and wood. **Limits**: lists of at most 255 entries
//! per cell (the farthest dropped), 2²⁴ list entries per cloud, 1024² cells per plane, 64
//! cells per ray; the thin clusters span much of the crown, so planes are large and the fill
//! (a hash read per cell a box pixel's ray crosses) is the cost on a software rasteriser.
//!
//! **Measured** (lavapipe, release, `scripts/measure-bcloud.sh`, BENCHMARKS.md): the chestnut
//! (14,873 leaves, 29,746 flat parts in the near cloud) bakes in 1.6 s into 9.6 MB (polygonal
//! leaves 6.7 MB). ꟻLIP vs `geometry --spp 16` around one chestnut 800/400/200/100 px tall:
//! 0.072/0.077/0.098/0.119 (1-spp geometry 0.057/0.072/0.093/0.117, i.e. 1.26/1.07/1.05/1.02×);
//! leaf coverage within 1 % of geometry's; the same chestnut exported to `.glb` and read back:
//! 1.08/1.03× at 400/200 px (the importer's leaves are blades, `sylvan_plant::import`). Frame
//! time on chestnut grids: 1.6–2.2× geometry's for one tree filling the view, 0.42× at 100
//! trees, 0.08× at 1,000.

pub mod bake;
pub mod cluster;
mod draw;
pub mod layers;

pub use bake::{BillboardCloudBake, BillboardCloudBaked};
pub use draw::BillboardCloud;

use super::Built;
use super::params::{self, ParamDoc, ParamTable};
use super::registry::{self, Entry, Kind};

/// Bake parameters of `billboard-cloud`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BillboardCloudBakeParams {
    /// Planes of the near cloud (GPSS07: 60–260).
    pub planes: u32,
    /// Planes of the mid cloud.
    pub planes_mid: u32,
    /// Planes of the far cloud (low-resolution images only).
    pub planes_far: u32,
    /// Hash cells of the near cloud over all its planes (the mid cloud gets a quarter, the far
    /// a sixteenth); the cell size follows from the planes' area.
    pub cells: u32,
    /// Low-resolution tile size of the near cloud's planes (the others get twice this).
    pub tile: u32,
    /// Low-resolution samples per texel per axis.
    pub supersample: u32,
    /// Clustering refinements.
    pub iterations: u32,
}

impl Default for BillboardCloudBakeParams {
    fn default() -> Self {
        Self {
            planes: 260,
            planes_mid: 96,
            planes_far: 32,
            cells: 1 << 18,
            tile: 16,
            supersample: 4,
            iterations: 10,
        }
    }
}

impl ParamTable for BillboardCloudBakeParams {
    const DOCS: &'static [ParamDoc] = &[
        ParamDoc {
            key: "planes",
            unit: "planes",
            doc: "billboards of the near cloud (4–1024; GPSS07 uses 60–260)",
        },
        ParamDoc {
            key: "planes_mid",
            unit: "planes",
            doc: "billboards of the mid cloud (4–1024)",
        },
        ParamDoc {
            key: "planes_far",
            unit: "planes",
            doc: "billboards of the far cloud, drawn from low-resolution images only (1–1024)",
        },
        ParamDoc {
            key: "cells",
            unit: "cells",
            doc: "hash cells of the near cloud over all planes (mid: a quarter, far: a sixteenth; 1024–16777216)",
        },
        ParamDoc {
            key: "tile",
            unit: "texels",
            doc: "low-resolution image per plane and side of the near cloud (a power of two 4–128; the others twice)",
        },
        ParamDoc {
            key: "supersample",
            unit: "per axis",
            doc: "samples per low-resolution texel per axis (1–8)",
        },
        ParamDoc {
            key: "iterations",
            unit: "iterations",
            doc: "clustering refinements (0–100)",
        },
    ];

    fn validate(&self) -> Result<(), String> {
        let range = |k: &str, v: u32, lo: u32, hi: u32| {
            if (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(format!("billboard-cloud {k} {v}: must be {lo} to {hi}"))
            }
        };
        range("planes", self.planes, 4, 1024)?;
        range("planes_mid", self.planes_mid, 4, 1024)?;
        range("planes_far", self.planes_far, 1, 1024)?;
        range("cells", self.cells, 1024, 1 << 24)?;
        range("tile", self.tile, 4, 128)?;
        if !self.tile.is_power_of_two() {
            return Err(format!(
                "billboard-cloud tile {}: must be a power of two",
                self.tile
            ));
        }
        range("supersample", self.supersample, 1, 8)?;
        range("iterations", self.iterations, 0, 100)?;
        Ok(())
    }
}

/// Draw parameters of `billboard-cloud` (never re-bake).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BillboardCloudDrawParams {
    /// List entries walked per pixel of a hash cell's projected diagonal (GPSS07 §5.1's
    /// factor); 0 draws the low-resolution images only.
    pub entries_per_px: f32,
    /// Apparent size (pixels per metre) below which the mid cloud takes over.
    pub mid_px_per_m: f32,
    /// Apparent size below which the far cloud takes over.
    pub far_px_per_m: f32,
    /// Branch levels of the far cloud's simplified wood (0: the trunk only).
    pub far_wood_levels: u32,
}

impl Default for BillboardCloudDrawParams {
    fn default() -> Self {
        Self {
            entries_per_px: 8.0,
            mid_px_per_m: 24.0,
            far_px_per_m: 6.0,
            far_wood_levels: 2,
        }
    }
}

impl ParamTable for BillboardCloudDrawParams {
    const DOCS: &'static [ParamDoc] = &[
        ParamDoc {
            key: "entries_per_px",
            unit: "entries/px",
            doc: "list entries walked per pixel of a hash cell's projected diagonal (0–64; 0: low-resolution images only)",
        },
        ParamDoc {
            key: "mid_px_per_m",
            unit: "px/m",
            doc: "apparent size below which the mid cloud takes over",
        },
        ParamDoc {
            key: "far_px_per_m",
            unit: "px/m",
            doc: "apparent size below which the far cloud (low-resolution only) takes over",
        },
        ParamDoc {
            key: "far_wood_levels",
            unit: "levels",
            doc: "branch levels kept in the far cloud's wood (0: trunk only; 0–16)",
        },
    ];

    fn validate(&self) -> Result<(), String> {
        if !(0.0..=64.0).contains(&self.entries_per_px) {
            return Err(format!(
                "billboard-cloud entries_per_px {}: must be 0 to 64",
                self.entries_per_px
            ));
        }
        if !(self.far_px_per_m > 0.0
            && self.mid_px_per_m > self.far_px_per_m
            && self.mid_px_per_m.is_finite())
        {
            return Err(format!(
                "billboard-cloud mid_px_per_m {} and far_px_per_m {}: need mid > far > 0",
                self.mid_px_per_m, self.far_px_per_m
            ));
        }
        if self.far_wood_levels > 16 {
            return Err(format!(
                "billboard-cloud far_wood_levels {}: must be 0 to 16",
                self.far_wood_levels
            ));
        }
        Ok(())
    }
}

fn resolve(
    settings: &[&sylvan_scene::Setting],
) -> Result<(BillboardCloudBakeParams, BillboardCloudDrawParams), crate::RenderError> {
    params::resolve::<BillboardCloudBakeParams, BillboardCloudDrawParams>(
        "billboard-cloud",
        settings,
    )
}

/// The registry entry.
pub const ENTRY: Entry = Entry {
    name: "billboard-cloud",
    kind: Kind::PerTree,
    summary: "GPSS07: billboard clouds whose planes index the leaves (hash / lists / leaf records), 3 clouds + shader LOD",
    debug_color: [1.0, 0.2, 0.8],
    gpu_driven: true,
    schema: params::schema::<BillboardCloudBakeParams, BillboardCloudDrawParams>,
    check: |s| resolve(s).map(|_| ()),
    build: |cx| {
        let (bake, draw) = resolve(&cx.settings_for("billboard-cloud"))?;
        let (assets, reports) = cx.load_assets::<BillboardCloudBake>(&bake)?;
        Ok(Built {
            technique: Box::new(BillboardCloud::new(
                cx.gpu,
                cx.frame,
                cx.plants,
                &assets,
                &draw,
                cx.population,
                cx.band,
            )?),
            reports,
        })
    },
    bake: Some(registry::bake_with::<BillboardCloudBake, BillboardCloudDrawParams>),
    casts_translucent: None,
    shaders: || vec![("billboard-cloud", shader_source())],
};

/// The WGSL of `billboard-cloud` as compiled: the frame's group 0, `bindings.wgsl` (groups 1
/// and 2), the shared leaf material, then `bcloud.wgsl`.
pub(crate) fn shader_source() -> String {
    crate::pipeline::with_frame(concat!(
        include_str!("bindings.wgsl"),
        include_str!("bcloud.wgsl")
    ))
}
