//! Tree representations, one folder per technique, behind two traits and one registry.
//!
//! - [`crate::bake::Bake`] is the offline half: one plant → one cached asset.
//! - [`Technique`] is the frame: built once from a [`BuildContext`] (the scene, its terrain,
//!   the tree population, the band it serves, its settings), then per frame
//!   [`Technique::prepare_frame`] (may record compute passes into the frame's encoder) and
//!   [`Technique::draw`] for the camera pass and each shadow cascade.
//! - [`registry::REGISTRY`] lists every technique once (name, kind, constructor, parameter
//!   schema); the CLI, the `auto` chain, statistics and shader ids all come from it.
//!
//! | `--technique` | module | paper |
//! |---|---|---|
//! | `geometry` | [`geometry`] | reference: full meshes, the ground truth |
//! | `boxtree` | [`boxtree`] | LCV04 |
//! | `hbt` | [`hbt`] | MNP01 |
//! | `billboard-cloud` | [`bcloud`] | GPSS07 |
//! | `octahedral` | [`octahedral`] | industry baseline: hemi-octahedral impostor |
//! | `zfield` | [`zfield`] | BN12 §5, §8: z-fields, sun/sky lighting, per-tree coverage masks |
//! | `auto` | [`lod`] | the LOD chain: a technique per distance band, cross-faded |
//!
//! GPU-driven techniques (`Entry::gpu_driven`: every per-tree technique, and the chain) draw
//! the tiled world from [`DrawContext::culled`] ([`crate::world`]); with `--cpu-driven` they
//! get every tree on the CPU in [`FrameInput::instances`].
//!
//! Adding a technique: docs/DESIGN.md, "Adding a technique".

pub mod bcloud;
pub mod boxtree;
pub(crate) mod common;
pub mod geometry;
pub mod hbt;
pub mod lod;
pub mod octahedral;
pub mod params;
pub mod registry;
pub mod shadermap;
pub mod zfield;

use crate::RenderError;
use crate::bake::{BakeReport, CachePolicy};
use crate::frame::FrameResources;
use crate::instances::Instances;
use std::ops::Range;
use sylvan_gpu::Gpu;
use sylvan_plant::Plant;
use sylvan_scene::{Scene, Setting};

pub use registry::{Entry, Kind};

/// Progress of a bake: (plant name, done, total).
pub type BakeProgress<'a> = &'a mut dyn FnMut(&str, usize, usize);

/// The distance range a technique serves (the `auto` chain's band; `0..∞` alone).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BandRange {
    /// Start distance (metres).
    pub start: f32,
    /// End distance (metres, `f32::INFINITY` for an open end).
    pub end: f32,
    /// Where the band's presence falls to 0, when it is not ±[`lod::FADE`] of `end`: the band
    /// before a forest field stops at `end` (the field's start), its trees ending by
    /// [`BandRange::field_end`].
    pub end_fade: Option<[f32; 2]>,
    /// In a chain that ends in a forest field: how each tree of the band ends into it.
    pub field_end: Option<FieldEnd>,
}

/// How the trees of a chain that ends in a forest field end (BN12 §7, and §4's "trees under
/// 3 px are never drawn"): each tree has its own end `e = min(s_max, h · ppm / handover_px)`
/// (its height `h` in metres, `ppm` the output's pixels per metre at one metre), and fades
/// over `[0.8, 1] × e` (or stops at `e` when its technique fades itself,
/// [`Technique::fades_to_field`]) while the field takes its share.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldEnd {
    /// The field's start (metres): no tree is drawn beyond it.
    pub s_max: f32,
    /// The apparent height (pixels) under which a tree is left to the field (0: every tree
    /// is drawn to `s_max`).
    pub handover_px: f32,
    /// The technique fades its own trees ([`Technique::fades_to_field`]): presence stops at
    /// the tree's end.
    pub self_fading: bool,
}

impl FieldEnd {
    /// Where the trees' fade starts, relative to their end (BN12 §7's 0.8).
    pub const FADE_START: f32 = 0.8;

    /// Metres of distance per metre of tree height at which a tree is `handover_px` tall in
    /// an output of `pixels_per_metre` (0: no pixel rule). The GPU cull takes the same
    /// factor, so CPU and GPU lists agree to the bit.
    pub fn per_height(&self, pixels_per_metre: f32) -> f32 {
        if self.handover_px > 0.0 {
            pixels_per_metre / self.handover_px
        } else {
            0.0
        }
    }

    /// The end of a tree `height_m` tall, for [`FieldEnd::per_height`] `k`.
    pub fn tree_end(&self, height_m: f32, k: f32) -> f32 {
        if k > 0.0 {
            self.s_max.min(height_m * k)
        } else {
            self.s_max
        }
    }

    /// The presence factor of a tree `height_m` tall at `distance` (trunk base), for
    /// [`FieldEnd::per_height`] `k` (as `cull.wgsl` computes it).
    pub fn presence(&self, distance: f32, height_m: f32, k: f32) -> f32 {
        let e = self.tree_end(height_m, k);
        if self.self_fading {
            if distance >= e { 0.0 } else { 1.0 }
        } else {
            1.0 - common::smoothstep(Self::FADE_START * e, e, distance)
        }
    }

    /// The row the GPU cull takes: x [`FieldEnd::per_height`], y `s_max`, z 1 when self-fading.
    pub fn gpu_row(&self, pixels_per_metre: f32) -> [f32; 4] {
        [
            self.per_height(pixels_per_metre),
            self.s_max,
            if self.self_fading { 1.0 } else { 0.0 },
            0.0,
        ]
    }
}

impl BandRange {
    /// Every distance.
    pub const ALL: Self = Self {
        start: 0.0,
        end: f32::INFINITY,
        end_fade: None,
        field_end: None,
    };

    /// `start..end` with the chain's usual cross-fades.
    pub fn new(start: f32, end: f32) -> Self {
        Self {
            start,
            end,
            end_fade: None,
            field_end: None,
        }
    }

    /// The band's presence window as the `auto` chain fades it ([`crate::world::ListRequest`]'s
    /// `window`): rising over ±[`lod::FADE`] of its start, falling over ±`FADE` of its end
    /// (or over `end_fade`); open below a start of 0 and above an infinite end.
    pub fn window(&self) -> [f32; 4] {
        let (lo, hi) = (1.0 - lod::FADE, 1.0 + lod::FADE);
        let open_start = self.start <= 0.0;
        let open_end = !self.end.is_finite();
        let [fall0, fall1] = match (open_end, self.end_fade) {
            (true, _) => [1e30, 1e30],
            (false, Some(f)) => f,
            (false, None) => [self.end * lo, self.end * hi],
        };
        [
            if open_start { -1e30 } else { self.start * lo },
            if open_start { -1e30 } else { self.start * hi },
            fall0,
            fall1,
        ]
    }

    /// The presence of a tree at `distance` under [`BandRange::window`] (as `cull.wgsl`'s
    /// `ramp` computes it on the GPU), without the field's per-tree end.
    pub fn presence(&self, distance: f32) -> f32 {
        let [a, b, c, d] = self.window();
        common::smoothstep(a, b, distance) * (1.0 - common::smoothstep(c, d, distance))
    }

    /// [`BandRange::presence`] times the field's end ([`FieldEnd::presence`]) for a tree
    /// `height_m` tall, `k` its [`FieldEnd::per_height`].
    pub fn tree_presence(&self, distance: f32, height_m: f32, k: f32) -> f32 {
        let p = self.presence(distance);
        match self.field_end {
            Some(f) if p > 0.0 => p * f.presence(distance, height_m, k),
            _ => p,
        }
    }
}

/// Everything a technique is built from.
pub struct BuildContext<'a> {
    /// The device.
    pub gpu: &'a Gpu,
    /// Group-0 layouts and the shadow maps.
    pub frame: &'a FrameResources,
    /// The scene (terrain, species, sun, …).
    pub scene: &'a Scene,
    /// One plant per species.
    pub plants: &'a [Plant],
    /// The tree population (every placed tree; per-frame lists are derived from it).
    pub population: &'a Instances,
    /// The distance band this technique draws.
    pub band: BandRange,
    /// The forest field the chain ends in (BN12's shader-map), for the per-tree techniques
    /// that converge to it (`zfield`'s eq. 22–23 and fade); `None` alone or without one.
    pub field: Option<&'a shadermap::field::ForestField>,
    /// Settings in force (the scene's tables, the band's, `--set`), in the order they apply;
    /// a technique reads those for its own name ([`BuildContext::settings_for`]).
    pub settings: &'a [Setting],
    /// The command line's settings alone (a chain re-applies them over each band's).
    pub overrides: &'a [Setting],
    /// Where baked assets are cached.
    pub policy: &'a CachePolicy,
    /// Bake progress.
    pub progress: BakeProgress<'a>,
}

impl BuildContext<'_> {
    /// The settings addressed to technique `name`, in order.
    pub fn settings_for(&self, name: &str) -> Vec<&Setting> {
        self.settings
            .iter()
            .filter(|s| s.technique == name)
            .collect()
    }

    /// Bakes (or reads from the cache) `B`'s asset for each plant — once per distinct plant
    /// and parameters.
    pub fn load_assets<B: crate::bake::Bake>(
        &mut self,
        params: &B::Params,
    ) -> Result<(Vec<B::Asset>, Vec<BakeReport>), RenderError> {
        let mut keys: Vec<u64> = Vec::with_capacity(self.plants.len());
        let mut assets: Vec<B::Asset> = Vec::with_capacity(self.plants.len());
        let mut reports = Vec::new();
        for plant in self.plants {
            let key = crate::bake::cache_key::<B>(plant, params);
            if let Some(i) = keys.iter().position(|&k| k == key) {
                assets.push(assets[i].clone());
                keys.push(key);
                continue;
            }
            let name = plant.name.clone();
            let progress = &mut self.progress;
            let (asset, report) = crate::bake::load_or_bake::<B>(
                self.gpu,
                plant,
                params,
                self.policy,
                &mut |d, t| progress(&name, d, t),
            )?;
            assets.push(asset);
            keys.push(key);
            reports.push(report);
        }
        Ok((assets, reports))
    }
}

/// A technique built by its registry entry, with how its assets were obtained.
pub struct Built {
    /// The technique.
    pub technique: Box<dyn Technique>,
    /// One report per distinct baked asset.
    pub reports: Vec<BakeReport>,
}

/// The frame half of a technique. Object-safe: the renderer holds a `Box<dyn Technique>`.
/// Per-tree techniques draw the instance lists they are handed; a technique that is a field
/// over the terrain (BN12's shader-map) ignores them and draws its own geometry in the passes.
pub trait Technique: Send {
    /// The registry name.
    fn name(&self) -> &'static str;
    /// Per-frame work before any pass: level-of-detail selection, uploads, and compute passes
    /// recorded into `encoder` (submitted before the frame's render passes).
    fn prepare_frame(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        input: &FrameInput<'_>,
    ) -> Result<(), RenderError>;
    /// Records one pass: the camera view ([`DrawContext::shadow_cascade`] is `None`) or a
    /// shadow cascade (depth only).
    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts;
    /// The technique's own statistics of the last frame, as named values.
    fn stats(&self) -> Vec<(&'static str, f64)> {
        Vec::new()
    }
    /// GPU memory held (bytes).
    fn bytes(&self) -> u64;
    /// Trees drawn in the camera view per technique name (a chain reports each band's).
    fn trees_drawn(&self, instances: &Instances) -> Vec<(&'static str, u32)> {
        vec![(self.name(), instances.drawn())]
    }
    /// Statistics per technique name (a chain reports each band's technique).
    fn stats_by_technique(&self) -> Vec<(&'static str, Vec<(&'static str, f64)>)> {
        vec![(self.name(), self.stats())]
    }
    /// A picture of the baked images, for techniques that bake.
    fn atlas_preview(&self) -> Option<&image::RgbaImage> {
        None
    }
    /// Times a per-frame buffer had to grow so far.
    fn reallocations(&self) -> u32 {
        0
    }
    /// After the frame's submission has completed (`Renderer::render`): reads back what the
    /// technique's own GPU passes counted. True when the frame drew less than it listed (a
    /// GPU-written list outgrew its buffer, now grown): the renderer draws the frame again.
    fn finish_frame(&mut self, _gpu: &Gpu) -> Result<bool, RenderError> {
        Ok(false)
    }
    /// Triangles of the last frame read back that the technique's own GPU passes listed in
    /// pass `pass` (beyond those of its [`Technique::indirect_draws`], which the world counts).
    fn own_triangles(&self, _pass: usize) -> u64 {
        0
    }
    /// A GPU-driven technique's draws per (pass, species) list, in the order it draws them
    /// ([`crate::world::Culled::args`]'s `k`); empty for a technique fed on the CPU.
    fn indirect_draws(&self) -> Vec<crate::world::IndirectDraw> {
        Vec::new()
    }
    /// How a GPU-driven technique wants its lists: per species (default), or one mixed list
    /// per pass, the camera's sorted back to front.
    fn list_layout(&self) -> crate::world::ListLayout {
        crate::world::ListLayout::default()
    }
    /// What a GPU-driven technique asks of the cull: by default one request of its layout and
    /// draws over every distance; a chain asks one per band ([`DrawContext::culled`] holds
    /// their lists in this order).
    fn list_requests(&self) -> Vec<crate::world::ListRequest> {
        vec![crate::world::ListRequest {
            technique: self.name(),
            layout: self.list_layout(),
            draws: self.indirect_draws(),
            window: crate::world::ListRequest::ALL,
            field_end: None,
        }]
    }
    /// This frame's window per [`Technique::list_requests`] entry, for a technique whose
    /// windows follow the view's apparent size (`pixels_per_metre` as in [`FrameInput`]);
    /// `None`: the windows of `list_requests` hold.
    fn list_windows(&self, _pixels_per_metre: f32) -> Option<Vec<[f32; 4]>> {
        None
    }
    /// The forest field the terrain is shaded with (BN12's shader-map), if the technique has
    /// one: the renderer builds the terrain's pipeline with it.
    fn field(&self) -> Option<&shadermap::field::ForestField> {
        None
    }
    /// Whether the technique fades its own trees out towards the forest field it was built
    /// with (BN12 §7: opacity × (1 − smoothstep(0.8, 1, s/s_max)), s the tree's distance, the
    /// ground taking eq. 26–27): the chain then stops its band at `s_max` instead of fading its presence.
    fn fades_to_field(&self) -> bool {
        false
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
    /// The GPU cull's lists of this frame, one per [`Technique::list_requests`] entry
    /// (recorded before `prepare_frame`: compute passes may read them); empty when the trees
    /// come from `instances`.
    pub culled: &'a [crate::world::Culled<'a>],
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
    /// The GPU cull's lists and indirect arguments, one per [`Technique::list_requests`]
    /// entry (GPU-driven techniques; empty when the trees come from `instances`).
    pub culled: &'a [crate::world::Culled<'a>],
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

impl DrawContext<'_> {
    /// The shadow cascade this pass renders, or `None` for the camera view.
    pub fn shadow_cascade(&self) -> Option<usize> {
        self.pass.checked_sub(1)
    }
}
