//! Tree representations, one module per paper, behind one trait.
//!
//! | `--technique` | module | paper |
//! |---|---|---|
//! | `geometry` | [`geometry`] | reference: full meshes, the ground truth |
//! | `boxtree` | [`boxtree`] | LCV04 |
//! | `hbt` | [`hbt`] | MNP01 (top level: BTF + reconstruction; no visibility cube-maps yet) |
//! | `billboard-cloud` | — | GPSS07 (not yet implemented) |
//! | `zfield` | — | BN12 §5 (not yet implemented) |
//! | `shadermap` | — | BN12 §6 (not yet implemented) |
//! | `auto` | [`lod`] | the LOD chain: a technique per distance band, cross-faded |

pub(crate) mod any;
pub mod boxtree;
pub(crate) mod common;
pub mod geometry;
pub mod hbt;
pub mod lod;

use crate::RenderError;
use crate::bake::codec::DecodeError;
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

/// What a technique may look at once per frame, before any pass is recorded.
pub struct FrameInput<'a> {
    /// Eye position (world).
    pub eye: glam::Vec3,
    /// Pixels covered by one metre at one metre's distance in the output image
    /// (`height / (2 tan(fov_y / 2))`).
    pub pixels_per_metre: f32,
    /// Unit vector towards the sun (world).
    pub sun_dir: glam::Vec3,
    /// This frame's culled instances (CPU copies per pass and species).
    pub instances: &'a Instances,
    /// World size of one shadow-map texel in each cascade (metres).
    pub shadow_texel_m: [f32; crate::frame::CASCADES],
    /// Eye distance where each cascade ends (metres).
    pub cascade_far: [f32; crate::frame::CASCADES],
}

/// What a technique needs to draw one pass.
pub struct DrawContext<'a> {
    /// Which pass: 0 the camera view, `1 + c` shadow cascade `c`.
    pub pass: usize,
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

/// A tree representation. Offline, [`Representation::bake`] turns one plant into a baked
/// asset (pure function of the plant and parameters, cached on disk by the shared baker with
/// [`Representation::encode`] / [`Representation::decode`]); [`Representation::prepare`]
/// uploads the assets of every species once; per frame, [`Representation::update`] sees the
/// culled instances and the draw calls record passes from prepared state only.
pub trait Representation: Sized {
    /// The `--technique` name.
    const NAME: &'static str;
    /// Version of the baked payload; bump when [`Representation::encode`]'s output changes.
    const FORMAT_VERSION: u32;
    /// Bake and draw parameters.
    type Params: Clone + Default + std::fmt::Debug;
    /// The baked asset of one plant.
    type Baked: Clone;
    /// Content hash of every input of [`Representation::bake`] (the cache key).
    fn input_hash(plant: &Plant, params: &Self::Params) -> u64;
    /// Bakes one plant; `progress(done, total)` reports work units as they complete.
    fn bake(
        gpu: &Gpu,
        plant: &Plant,
        params: &Self::Params,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<Self::Baked, RenderError>;
    /// Serialises a baked asset.
    fn encode(baked: &Self::Baked) -> Vec<u8>;
    /// Reads a baked asset back (every length and range checked).
    fn decode(bytes: &[u8]) -> Result<Self::Baked, DecodeError>;
    /// Uploads what the technique needs for `plants` (one per species) and their assets.
    fn prepare(
        gpu: &Gpu,
        frame: &FrameResources,
        plants: &[Plant],
        baked: &[Self::Baked],
        params: &Self::Params,
    ) -> Result<Self, RenderError>;
    /// Per-frame work before the passes are recorded (level-of-detail selection, uploads).
    fn update(&mut self, _gpu: &Gpu, _input: &FrameInput<'_>) -> Result<(), RenderError> {
        Ok(())
    }
    /// Records the main (camera) pass.
    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts;
    /// Records one shadow cascade pass (depth only).
    fn draw_shadow(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts;
    /// GPU memory held (bytes).
    fn bytes(&self) -> u64;
}
