//! The one list of techniques. Everything that enumerates techniques — `--technique`, the
//! `auto` chain, `sylvan params`, `sylvan bake`, statistics, the shader-visible technique ids
//! and the "colour by technique" debug view — reads [`REGISTRY`]. A technique is its folder
//! plus one line here.

use super::params::ParamSpec;
use super::params::ParamTable;
use super::{BuildContext, Built};
use crate::RenderError;
use crate::bake::{AssetSummary, Bake, BakeReport, CachePolicy};
use sylvan_gpu::Gpu;
use sylvan_plant::Plant;
use sylvan_scene::Setting;

/// What a technique draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Trees, from the instance lists it is handed (may be a band of the `auto` chain).
    PerTree,
    /// A field over the terrain (BN12's shader-map): no per-tree lists.
    Field,
    /// A chain of other techniques by distance (`auto`).
    Chain,
}

/// What `sylvan bake` needs to bake one plant for a technique.
pub struct BakeJob<'a> {
    /// The device.
    pub gpu: &'a Gpu,
    /// The plant.
    pub plant: &'a Plant,
    /// Settings for this technique (`--set`), in order.
    pub settings: &'a [&'a Setting],
    /// Where the asset goes.
    pub policy: &'a CachePolicy,
    /// Bake progress (done, total).
    pub progress: &'a mut dyn FnMut(usize, usize),
}

/// What a bake made, for `sylvan bake`'s line and JSON.
pub struct BakeSummary {
    /// How the asset was obtained.
    pub report: BakeReport,
    /// The asset, described by its technique ([`crate::bake::Bake::describe`]).
    pub asset: AssetSummary,
}

/// The `bake` of a registry entry for a technique baking with `B` and drawing with `D`
/// parameters: the `--set` settings resolved, the asset baked or read, and described.
pub fn bake_with<B: Bake, D: ParamTable>(job: BakeJob<'_>) -> Result<BakeSummary, RenderError> {
    let (params, _) = super::params::resolve::<B::Params, D>(B::NAME, job.settings)?;
    let (asset, report) =
        crate::bake::load_or_bake::<B>(job.gpu, job.plant, &params, job.policy, job.progress)?;
    Ok(BakeSummary {
        report,
        asset: B::describe(&asset),
    })
}

/// One technique.
pub struct Entry {
    /// `--technique` name.
    pub name: &'static str,
    /// What it draws.
    pub kind: Kind,
    /// One line for `sylvan params` and `--help`.
    pub summary: &'static str,
    /// Its colour in the "colour by technique" debug view (linear RGB).
    pub debug_color: [f32; 3],
    /// Draws the tiled world from the GPU cull's lists ([`super::DrawContext::culled`]): the
    /// CPU never touches a tree per frame, and no tree is placed before it comes within range.
    /// Otherwise every tree is placed when the renderer is made and handed over on the CPU.
    pub gpu_driven: bool,
    /// Every parameter with its default, unit and doc.
    pub schema: fn() -> Vec<ParamSpec>,
    /// Checks settings for this technique without a GPU (unknown keys, types, ranges).
    pub check: fn(&[&Setting]) -> Result<(), RenderError>,
    /// Builds it for a scene.
    pub build: fn(&mut BuildContext<'_>) -> Result<Built, RenderError>,
    /// Bakes one plant (`None`: nothing to bake).
    pub bake: Option<fn(BakeJob<'_>) -> Result<BakeSummary, RenderError>>,
    /// Whether it casts translucent shadows with these settings (the scene's and the command
    /// line's, every technique's): the renderer then gives the cascades their translucent
    /// layer (BN12 §5's soft shadows, `PassKind::ShadowTranslucent`); `None`: it never does.
    pub casts_translucent: Option<SettingsPredicate>,
    /// Its WGSL modules as compiled (frame bindings prepended), by label, for naga tests.
    pub shaders: fn() -> Vec<(&'static str, String)>,
}

/// A question about a technique answered from its settings alone (no GPU).
pub type SettingsPredicate = fn(&[Setting]) -> Result<bool, RenderError>;

/// Every technique, in `--technique` order. A technique's shader-visible id is its index.
pub static REGISTRY: &[Entry] = &[
    super::geometry::ENTRY,
    super::boxtree::ENTRY,
    super::hbt::ENTRY,
    super::octahedral::ENTRY,
    super::bcloud::ENTRY,
    super::zfield::ENTRY,
    super::shadermap::ENTRY,
    super::lod::ENTRY,
];

/// The entry named `name`.
pub fn find(name: &str) -> Result<&'static Entry, RenderError> {
    REGISTRY
        .iter()
        .find(|e| e.name == name)
        .ok_or_else(|| RenderError::UnknownTechnique(name.to_string()))
}

/// Every name, in order.
pub fn names() -> Vec<&'static str> {
    REGISTRY.iter().map(|e| e.name).collect()
}

/// ` (did you mean 'hbt'?)` for a near miss, else empty.
pub fn nearest_hint(name: &str) -> String {
    match super::params::nearest(name, names()) {
        Some(n) if strsim_close(name, n) => format!(" (did you mean '{n}'?)"),
        _ => String::new(),
    }
}

fn strsim_close(a: &str, b: &str) -> bool {
    let common = a.chars().zip(b.chars()).take_while(|(x, y)| x == y).count();
    common >= 2 || a.contains(b) || b.contains(a)
}

/// The shader-visible id of technique `name` (its index in [`REGISTRY`]).
pub fn id(name: &str) -> i32 {
    REGISTRY
        .iter()
        .position(|e| e.name == name)
        .map_or(-1, |i| i as i32)
}

/// WGSL prepended to every frame shader: a `TECHNIQUE_<NAME>` constant per technique and
/// `technique_color`, both from [`REGISTRY`].
pub fn wgsl_prelude() -> String {
    let mut s = String::from("// Generated from the technique registry (technique/registry.rs).\n");
    let ident = |n: &str| n.to_uppercase().replace('-', "_");
    for (i, e) in REGISTRY.iter().enumerate() {
        s += &format!("const TECHNIQUE_{}: i32 = {i};\n", ident(e.name));
    }
    s += "fn technique_color(technique: i32) -> vec3<f32> {\n    switch technique {\n";
    for (i, e) in REGISTRY.iter().enumerate() {
        let [r, g, b] = e.debug_color;
        s += &format!(
            "        case {i}: {{ return vec3<f32>({r:?}, {g:?}, {b:?}); }}   // {}\n",
            e.name
        );
    }
    s += "        default: { return vec3<f32>(1.0, 1.0, 1.0); }\n    }\n}\n";
    s
}

/// Checks every setting against its technique's schema: a setting for an unknown technique,
/// an unknown key or a bad value is an error naming where it was written.
pub fn check_settings(settings: &[Setting]) -> Result<(), RenderError> {
    for s in settings {
        if find(&s.technique).is_err() {
            return Err(RenderError::Param(format!(
                "{}: unknown technique `{}`{} — use one of: {}",
                s.origin,
                s.technique,
                nearest_hint(&s.technique),
                names().join(", ")
            )));
        }
    }
    for e in REGISTRY {
        let mine: Vec<&Setting> = settings.iter().filter(|s| s.technique == e.name).collect();
        (e.check)(&mine)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::technique::params::ParamKind;

    #[test]
    fn names_are_unique_and_schemas_documented() {
        let mut names = names();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), REGISTRY.len());
        for e in REGISTRY {
            let rows = (e.schema)();
            let mut keys: Vec<_> = rows.iter().map(|r| r.key.as_str()).collect();
            keys.sort();
            keys.dedup();
            assert_eq!(
                keys.len(),
                rows.len(),
                "{}: a key is both bake and draw",
                e.name
            );
            for r in &rows {
                assert!(!r.doc.is_empty(), "{}.{} has no doc", e.name, r.key);
                assert_ne!(
                    r.default, "(missing)",
                    "{}.{} is not a field",
                    e.name, r.key
                );
                assert!(matches!(r.kind, ParamKind::Bake | ParamKind::Draw));
            }
        }
    }

    #[test]
    fn prelude_names_every_technique() {
        let p = wgsl_prelude();
        for e in REGISTRY {
            assert!(p.contains(&format!("// {}", e.name)));
        }
        assert!(p.contains("const TECHNIQUE_GEOMETRY: i32 = 0;"));
    }
}
