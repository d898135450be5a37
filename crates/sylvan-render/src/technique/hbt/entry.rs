//! `hbt`'s registry entry: parameters and construction.

use super::{Hbt, HbtBake, HbtBakeParams, HbtDrawParams};
use crate::RenderError;
use crate::technique::Built;
use crate::technique::params;
use crate::technique::registry::{self, Entry, Kind};

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
    gpu_driven: true,
    schema: params::schema::<HbtBakeParams, HbtDrawParams>,
    check: |s| resolve(s).map(|_| ()),
    build: |cx| {
        let (bake, draw) = resolve(&cx.settings_for("hbt"))?;
        let (assets, reports) = cx.load_assets::<HbtBake>(&bake)?;
        let mut h = Hbt::new(cx.gpu, cx.frame, cx.plants, &assets, &bake, &draw)?;
        // MNP01 §3.3's scene-level cube-maps, when asked for: CPU-driven only (every tree
        // placed up front; the GPU-driven frame refuses them, draw/gpu_frame.rs).
        let scene = draw.scene_visibility || draw.shadows == super::HbtShadows::CubeMaps;
        if scene && cx.population.placed_trees().next().is_some() {
            h.place(cx.population, Some(&cx.scene.terrain));
        }
        Ok(Built {
            technique: Box::new(h),
            reports,
        })
    },
    bake: Some(registry::bake_with::<HbtBake, HbtDrawParams>),
    casts_translucent: None,
    shaders: || {
        vec![
            ("hbt", super::shader_source()),
            ("hbt_select", super::draw::select_source()),
        ]
    },
};
