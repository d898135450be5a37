//! The renderer's technique slot: one of the implemented representations, chosen at run time,
//! with its assets baked or read from the cache.

use super::boxtree::{BoxTree, BoxTreeParams};
use super::geometry::Geometry;
use super::hbt::{Hbt, HbtParams};
use super::lod::{self, Band};
use super::{DrawContext, DrawCounts, FrameInput, Representation, TechniqueKind};
use crate::RenderError;
use crate::bake::{self, BakeReport, CachePolicy};
use crate::frame::FrameResources;
use crate::instances::Instances;
use sylvan_gpu::Gpu;
use sylvan_plant::Plant;

/// Progress of a bake: (plant name, done, total).
pub type BakeProgress<'a> = &'a mut dyn FnMut(&str, usize, usize);

/// One implemented technique, prepared.
pub(crate) enum AnyTechnique {
    Geometry(Geometry),
    BoxTree(Box<BoxTree>),
    Hbt(Box<Hbt>),
    Auto(Box<Chain>),
}

/// The `auto` chain: a technique and an instance list per band.
pub(crate) struct Chain {
    bands: Vec<Band>,
    techniques: Vec<AnyTechnique>,
    lists: Vec<Instances>,
}

/// What the renderer passes to [`AnyTechnique::prepare`].
pub(crate) struct PrepareInput<'a> {
    pub kind: TechniqueKind,
    pub boxtree: &'a BoxTreeParams,
    pub hbt: &'a HbtParams,
    pub policy: &'a CachePolicy,
    /// The scene's `[lod] chain` (for `auto`).
    pub lod_chain: &'a [String],
    /// The frame's instance list (its capacity sizes the chain's band lists; `hbt` builds its
    /// visibility cube-maps for its trees).
    pub instances: &'a Instances,
    /// The scene's terrain (`hbt`'s visibility cube-maps).
    pub terrain: Option<&'a sylvan_scene::Terrain>,
}

/// Bakes (or reads from the cache) `R`'s asset for each plant — once per distinct plant — and
/// prepares `R`.
pub(crate) fn prepare_baked<R: Representation>(
    gpu: &Gpu,
    frame: &FrameResources,
    plants: &[Plant],
    params: &R::Params,
    policy: &CachePolicy,
    progress: BakeProgress<'_>,
) -> Result<(R, Vec<BakeReport>), RenderError>
where
    R::Baked: Clone,
{
    let mut hashes: Vec<u64> = Vec::new();
    let mut baked: Vec<R::Baked> = Vec::with_capacity(plants.len());
    let mut reports = Vec::new();
    for plant in plants {
        let h = R::input_hash(plant, params);
        if let Some(i) = hashes.iter().position(|&x| x == h) {
            baked.push(baked[i].clone());
            hashes.push(h);
            continue;
        }
        let name = plant.name.clone();
        let (b, report) = bake::load_or_bake::<R>(gpu, plant, params, policy, &mut |d, t| {
            progress(&name, d, t)
        })?;
        baked.push(b);
        hashes.push(h);
        reports.push(report);
    }
    let r = R::prepare(gpu, frame, plants, &baked, params)?;
    Ok((r, reports))
}

impl AnyTechnique {
    pub(crate) fn prepare(
        gpu: &Gpu,
        frame: &FrameResources,
        plants: &[Plant],
        input: &PrepareInput<'_>,
        progress: BakeProgress<'_>,
    ) -> Result<(Self, Vec<BakeReport>), RenderError> {
        let policy = input.policy;
        match input.kind {
            TechniqueKind::Geometry => {
                let (g, r) = prepare_baked::<Geometry>(gpu, frame, plants, &(), policy, progress)?;
                Ok((Self::Geometry(g), r))
            }
            TechniqueKind::BoxTree => {
                let (b, r) =
                    prepare_baked::<BoxTree>(gpu, frame, plants, input.boxtree, policy, progress)?;
                Ok((Self::BoxTree(Box::new(b)), r))
            }
            TechniqueKind::Hbt => {
                let (mut h, r) =
                    prepare_baked::<Hbt>(gpu, frame, plants, input.hbt, policy, progress)?;
                h.place(input.instances, input.terrain);
                Ok((Self::Hbt(Box::new(h)), r))
            }
            TechniqueKind::Auto => {
                let bands = lod::parse_chain(input.lod_chain)?;
                let mut techniques = Vec::with_capacity(bands.len());
                let mut reports = Vec::new();
                let mut lists = Vec::with_capacity(bands.len());
                for band in &bands {
                    let sub = PrepareInput {
                        kind: band.technique,
                        ..*input
                    };
                    let (t, r) = Self::prepare(gpu, frame, plants, &sub, progress)?;
                    techniques.push(t);
                    reports.extend(r);
                    lists.push(Instances::derived(
                        gpu,
                        input.instances.capacity(),
                        input.instances.species_count(),
                    ));
                }
                Ok((
                    Self::Auto(Box::new(Chain {
                        bands,
                        techniques,
                        lists,
                    })),
                    reports,
                ))
            }
            other => Err(RenderError::NotImplemented(other.name())),
        }
    }

    /// Trees drawn in the camera view per technique name (for `auto`, per band technique).
    pub(crate) fn trees_drawn(&self, master: &Instances) -> Vec<(&'static str, u32)> {
        match self {
            Self::Auto(c) => {
                let mut out: Vec<(&'static str, u32)> = Vec::new();
                for (t, list) in c.techniques.iter().zip(&c.lists) {
                    let n = list.drawn();
                    match out.iter_mut().find(|(name, _)| *name == t.name()) {
                        Some(e) => e.1 += n,
                        None => out.push((t.name(), n)),
                    }
                }
                out
            }
            t => vec![(t.name(), master.drawn())],
        }
    }

    pub(crate) fn name(&self) -> &'static str {
        match self {
            Self::Geometry(_) => Geometry::NAME,
            Self::BoxTree(_) => BoxTree::NAME,
            Self::Hbt(_) => Hbt::NAME,
            Self::Auto(_) => "auto",
        }
    }

    pub(crate) fn update(&mut self, gpu: &Gpu, input: &FrameInput<'_>) -> Result<(), RenderError> {
        match self {
            Self::Geometry(t) => t.update(gpu, input),
            Self::BoxTree(t) => t.update(gpu, input),
            Self::Hbt(t) => t.update(gpu, input),
            Self::Auto(c) => {
                lod::split(gpu, &c.bands, &mut c.lists, input.instances, input.eye);
                for (t, list) in c.techniques.iter_mut().zip(&c.lists) {
                    let sub = FrameInput {
                        instances: list,
                        ..*input
                    };
                    t.update(gpu, &sub)?;
                }
                Ok(())
            }
        }
    }

    pub(crate) fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        ctx: &DrawContext<'_>,
    ) -> DrawCounts {
        match self {
            Self::Geometry(t) => t.draw(pass, ctx),
            Self::BoxTree(t) => t.draw(pass, ctx),
            Self::Hbt(t) => t.draw(pass, ctx),
            Self::Auto(c) => c.each(ctx, |t, sub| t.draw(pass, sub)),
        }
    }

    pub(crate) fn draw_shadow(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        ctx: &DrawContext<'_>,
    ) -> DrawCounts {
        match self {
            Self::Geometry(t) => t.draw_shadow(pass, ctx),
            Self::BoxTree(t) => t.draw_shadow(pass, ctx),
            Self::Hbt(t) => t.draw_shadow(pass, ctx),
            Self::Auto(c) => c.each(ctx, |t, sub| t.draw_shadow(pass, sub)),
        }
    }

    pub(crate) fn bytes(&self) -> u64 {
        match self {
            Self::Geometry(t) => t.bytes(),
            Self::BoxTree(t) => t.bytes(),
            Self::Hbt(t) => t.bytes(),
            Self::Auto(c) => {
                c.techniques.iter().map(AnyTechnique::bytes).sum::<u64>()
                    + c.lists.iter().map(|l| l.buffer().size()).sum::<u64>()
            }
        }
    }

    /// A picture of the baked images, for techniques that bake (the first band's, for `auto`).
    pub(crate) fn atlas_preview(&self) -> Option<&image::RgbaImage> {
        match self {
            Self::BoxTree(t) => Some(t.atlas_preview()),
            Self::Auto(c) => c.techniques.iter().find_map(AnyTechnique::atlas_preview),
            _ => None,
        }
    }

    /// `hbt`'s visibility structure and the trees drawn from lower levels this frame; zeros
    /// for other techniques.
    pub(crate) fn hierarchy_stats(&self) -> HierarchyStats {
        match self {
            Self::Hbt(t) => HierarchyStats {
                visibility_bytes: t.visibility_bytes(),
                visibility_ms: t.visibility_build_ms(),
                trees_opened: t.opened(),
                trees_meshed: t.meshed(),
                branches_opened: t.branches_opened(),
                branches_meshed: t.branches_meshed(),
            },
            Self::Auto(c) => c.techniques.iter().map(AnyTechnique::hierarchy_stats).fold(
                HierarchyStats::default(),
                |a, b| HierarchyStats {
                    visibility_bytes: a.visibility_bytes + b.visibility_bytes,
                    visibility_ms: a.visibility_ms + b.visibility_ms,
                    trees_opened: a.trees_opened + b.trees_opened,
                    trees_meshed: a.trees_meshed + b.trees_meshed,
                    branches_opened: a.branches_opened + b.branches_opened,
                    branches_meshed: a.branches_meshed + b.branches_meshed,
                },
            ),
            _ => HierarchyStats::default(),
        }
    }

    /// Instance-buffer re-allocations (growth) so far.
    pub(crate) fn reallocations(&self) -> u32 {
        match self {
            Self::Geometry(_) => 0,
            Self::BoxTree(t) => t.reallocations(),
            Self::Hbt(t) => t.reallocations(),
            Self::Auto(c) => c.techniques.iter().map(AnyTechnique::reallocations).sum(),
        }
    }
}

impl Chain {
    /// Calls `f` for each band's technique with the pass context re-pointed at its list.
    fn each(
        &self,
        ctx: &DrawContext<'_>,
        mut f: impl FnMut(&AnyTechnique, &DrawContext<'_>) -> DrawCounts,
    ) -> DrawCounts {
        let mut counts = DrawCounts::default();
        for (t, list) in self.techniques.iter().zip(&self.lists) {
            let sub = DrawContext {
                pass: ctx.pass,
                frame_bind: ctx.frame_bind,
                instances: list,
                ranges: &list.ranges[ctx.pass],
            };
            counts += f(t, &sub);
        }
        counts
    }
}

/// What [`AnyTechnique::hierarchy_stats`] reports.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct HierarchyStats {
    /// CPU bytes of the visibility cube-maps.
    pub(crate) visibility_bytes: u64,
    /// Milliseconds to build the scene's.
    pub(crate) visibility_ms: f64,
    /// Trees opened into a lower level (branches or meshes), this frame.
    pub(crate) trees_opened: u32,
    /// Trees drawn as their meshes (fully or in transition), this frame's camera pass.
    pub(crate) trees_meshed: u32,
    /// Main branches drawn as their small branches (fully or in transition), this frame.
    pub(crate) branches_opened: u32,
    /// Placements of opened trees drawn as their meshes (fully or in transition), this frame.
    pub(crate) branches_meshed: u32,
}
