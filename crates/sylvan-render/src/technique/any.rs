//! The renderer's technique slot: one of the implemented representations, chosen at run time,
//! with its assets baked or read from the cache.

use super::boxtree::{BoxTree, BoxTreeParams};
use super::geometry::Geometry;
use super::{DrawContext, DrawCounts, FrameInput, Representation, TechniqueKind};
use crate::RenderError;
use crate::bake::{self, BakeReport, CachePolicy};
use crate::frame::FrameResources;
use sylvan_gpu::Gpu;
use sylvan_plant::Plant;

/// Progress of a bake: (plant name, done, total).
pub type BakeProgress<'a> = &'a mut dyn FnMut(&str, usize, usize);

/// One implemented technique, prepared.
pub(crate) enum AnyTechnique {
    Geometry(Geometry),
    BoxTree(Box<BoxTree>),
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
        kind: TechniqueKind,
        boxtree: &BoxTreeParams,
        policy: &CachePolicy,
        progress: BakeProgress<'_>,
    ) -> Result<(Self, Vec<BakeReport>), RenderError> {
        match kind {
            TechniqueKind::Geometry => {
                let (g, r) = prepare_baked::<Geometry>(gpu, frame, plants, &(), policy, progress)?;
                Ok((Self::Geometry(g), r))
            }
            TechniqueKind::BoxTree => {
                let (b, r) =
                    prepare_baked::<BoxTree>(gpu, frame, plants, boxtree, policy, progress)?;
                Ok((Self::BoxTree(Box::new(b)), r))
            }
            other => Err(RenderError::NotImplemented(other.name())),
        }
    }

    pub(crate) fn name(&self) -> &'static str {
        match self {
            Self::Geometry(_) => Geometry::NAME,
            Self::BoxTree(_) => BoxTree::NAME,
        }
    }

    pub(crate) fn update(&mut self, gpu: &Gpu, input: &FrameInput<'_>) -> Result<(), RenderError> {
        match self {
            Self::Geometry(t) => t.update(gpu, input),
            Self::BoxTree(t) => t.update(gpu, input),
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
        }
    }

    pub(crate) fn bytes(&self) -> u64 {
        match self {
            Self::Geometry(t) => t.bytes(),
            Self::BoxTree(t) => t.bytes(),
        }
    }

    /// Instance-buffer re-allocations (growth) so far.
    pub(crate) fn reallocations(&self) -> u32 {
        match self {
            Self::Geometry(_) => 0,
            Self::BoxTree(t) => t.reallocations(),
        }
    }
}
