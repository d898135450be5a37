//! Tree representations, one module per paper, behind one trait.
//!
//! | `--technique` | module | paper |
//! |---|---|---|
//! | `geometry` | [`geometry`] | reference: full meshes, the ground truth |
//! | `boxtree` | — | LCV04 (not yet implemented) |
//! | `hbt` | — | MNP01 (not yet implemented) |
//! | `billboard-cloud` | — | GPSS07 (not yet implemented) |
//! | `zfield` | — | BN12 §5 (not yet implemented) |
//! | `shadermap` | — | BN12 §6 (not yet implemented) |
//! | `auto` | — | the LOD chain (not yet implemented) |

pub mod geometry;

use crate::RenderError;
use crate::frame::FrameResources;
use crate::instances::Instances;
use std::ops::Range;
use sylvan_gpu::Gpu;
use sylvan_plant::Plant;

/// A technique name accepted by `--technique`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TechniqueKind {
    /// Full geometry (the reference).
    Geometry,
    /// LCV04 box-tree impostors.
    BoxTree,
    /// MNP01 hierarchical bidirectional textures.
    Hbt,
    /// GPSS07 billboard clouds with indirect texturing.
    BillboardCloud,
    /// BN12 z-fields.
    ZField,
    /// BN12 shader-maps.
    ShaderMap,
    /// The LOD chain.
    Auto,
}

impl TechniqueKind {
    /// Every technique, in `--technique` spelling.
    pub const ALL: [(&'static str, TechniqueKind); 7] = [
        ("geometry", TechniqueKind::Geometry),
        ("boxtree", TechniqueKind::BoxTree),
        ("hbt", TechniqueKind::Hbt),
        ("billboard-cloud", TechniqueKind::BillboardCloud),
        ("zfield", TechniqueKind::ZField),
        ("shadermap", TechniqueKind::ShaderMap),
        ("auto", TechniqueKind::Auto),
    ];

    /// Parses a `--technique` name; the error lists the valid names.
    pub fn parse(name: &str) -> Result<Self, RenderError> {
        Self::ALL
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, k)| *k)
            .ok_or_else(|| RenderError::UnknownTechnique(name.to_string()))
    }

    /// The `--technique` spelling.
    pub fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(_, k)| *k == self)
            .map(|(n, _)| *n)
            .unwrap_or("?")
    }
}

/// What a technique needs to draw one pass.
pub struct DrawContext<'a> {
    /// Group-0 bind group for this pass (main or cascade).
    pub frame_bind: &'a wgpu::BindGroup,
    /// The frame's culled instances.
    pub instances: &'a Instances,
    /// `ranges[species]`: this pass's instances per species.
    pub ranges: &'a [Range<u32>],
}

/// What a technique reports back about a pass.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DrawCounts {
    /// Draw calls recorded.
    pub draw_calls: u32,
    /// Triangles submitted.
    pub triangles: u64,
}

impl std::ops::AddAssign for DrawCounts {
    fn add_assign(&mut self, o: Self) {
        self.draw_calls += o.draw_calls;
        self.triangles += o.triangles;
    }
}

/// A tree representation: built once from the plants (`prepare`, which uploads everything), then
/// drawn every frame from its prepared state and the frame's instances only. Techniques that
/// need an offline bake add it with the shared baker (see `docs/DESIGN.md`).
pub trait Representation: Sized {
    /// The `--technique` name.
    const NAME: &'static str;
    /// Uploads what the technique needs for `plants` (one per species).
    fn prepare(gpu: &Gpu, frame: &FrameResources, plants: &[Plant]) -> Result<Self, RenderError>;
    /// Records the main (camera) pass.
    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts;
    /// Records one shadow cascade pass (depth only).
    fn draw_shadow(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts;
    /// GPU memory held (bytes).
    fn bytes(&self) -> u64;
}
