//! `hbt`'s registry entry: parameters, construction and `sylvan bake`'s summary.

use super::{Hbt, HbtBake, HbtBakeParams, HbtDrawParams};
use crate::RenderError;
use crate::technique::Built;
use crate::technique::params;
use crate::technique::registry::{BakeJob, BakeSummary, Entry, Kind};

fn resolve(
    settings: &[&sylvan_scene::Setting],
) -> Result<(HbtBakeParams, HbtDrawParams), RenderError> {
    params::resolve::<HbtBakeParams, HbtDrawParams>("hbt", settings)
}

/// The registry entry.
pub const ENTRY: Entry = Entry {
    name: "hbt",
    kind: Kind::PerTree,
    summary: "MNP01: hierarchical bidirectional textures with visibility cube-maps, down to meshes",
    debug_color: [0.9, 0.1, 0.9],
    schema: params::schema::<HbtBakeParams, HbtDrawParams>,
    check: |s| resolve(s).map(|_| ()),
    build: |cx| {
        let (bake, draw) = resolve(&cx.settings_for("hbt"))?;
        let (assets, reports) = cx.load_assets::<HbtBake>(&bake)?;
        let mut h = Hbt::new(cx.gpu, cx.frame, cx.plants, &assets, &bake, &draw)?;
        h.place(cx.population, Some(&cx.scene.terrain));
        Ok(Built {
            technique: Box::new(h),
            reports,
        })
    },
    bake: Some(bake_summary),
    shaders: || vec![("hbt", super::shader_source())],
};

fn bake_summary(job: BakeJob<'_>) -> Result<BakeSummary, RenderError> {
    let (bake, _) = resolve(job.settings)?;
    let (b, report) =
        crate::bake::load_or_bake::<HbtBake>(job.gpu, job.plant, &bake, job.policy, job.progress)?;
    let (tree_bytes, branch_bytes) = b.image_bytes();
    let cube_bytes = (b.cubes.len() + b.small.cubes.len()) as u64;
    let images = b.direct.len()
        + b.ambient.len()
        + b.objects
            .iter()
            .chain(&b.small.objects)
            .map(|o| o.direct.len() + o.ambient.len())
            .sum::<usize>();
    let mut fields = serde_json::Map::new();
    let mut put = |k: &str, v: serde_json::Value| {
        fields.insert(k.into(), v);
    };
    put("views", b.views().into());
    put("lights", b.lights().into());
    put("branch_objects", b.objects.len().into());
    put("branch_placements", b.placements.len().into());
    put("small_objects", b.small.objects.len().into());
    put("small_placements", b.small.placements.len().into());
    put("tree_bytes", tree_bytes.into());
    put("branch_bytes", branch_bytes.into());
    put("cube_bytes", cube_bytes.into());
    Ok(BakeSummary {
        line: format!(
            "{} views × {} lights + {} ambient images of {}² for the tree ({:.1} MB), {} branch objects for {} placements ({:.1} MB, cube-maps {:.2} MB), {images} images in all",
            b.views(),
            b.lights(),
            b.ambient.len(),
            b.tile,
            tree_bytes as f64 / 1e6,
            b.objects.len(),
            b.placements.len(),
            branch_bytes as f64 / 1e6,
            cube_bytes as f64 / 1e6,
        ),
        report,
        image_bytes: tree_bytes + branch_bytes + cube_bytes,
        images,
        tile: b.tile,
        fields,
    })
}
