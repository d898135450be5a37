//! A scene's forest as the tables see it: its species mix (weights, heights), pattern radius
//! and peak density, and the tables baked for it (`sylvan bake --technique shadermap`).

use super::density::DensityRaster;
use super::measure::{ForestMix, MixSpecies, load_or_measure, mean_albedo};
use super::{ShaderMapBakeParams, ShaderMapDrawParams, ShaderMapTables};
use crate::RenderError;
use crate::bake::{BakeReport, CachePolicy, load_or_bake};
use crate::technique::params::resolve;
use crate::technique::zfield::{ZFieldBake, ZFieldBakeParams, ZFieldDrawParams};
use sylvan_plant::Plant;
use sylvan_scene::{Scene, Setting};

/// One species of a scene's mix: its index in `Scene::species`, share and height range.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneSpecies {
    /// Index into `Scene::species` (and the plants).
    pub species: usize,
    /// Its share of the trees (mean density or count).
    pub weight: f32,
    /// Heights, metres.
    pub height_m: [f32; 2],
}

/// A scene's forest for the tables.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneMix {
    /// The species with trees.
    pub species: Vec<SceneSpecies>,
    /// Poisson pattern radius, metres.
    pub radius_m: f32,
    /// Peak density, trees per m².
    pub lambda_max: f32,
}

/// The mix of `scene`: from its density-driven species when it has them (mean densities as
/// weights, the layouts' heights, the forest's own pattern radius), else from its placed trees
/// (counts, height extremes); the peak density is the highest of the field's density raster
/// ([`DensityRaster`], at its effective densities for `plants`, one per species) and, for
/// seeded species, their maps' peak — so the field never looks the tables up beyond their last
/// node.
pub fn scene_mix(scene: &Scene, plants: &[Plant]) -> Result<SceneMix, RenderError> {
    let raster = DensityRaster::of_scene(scene, plants, &[]);
    let raster_peak = raster.peak_effective();
    if let Some(seeded) = &scene.seeded {
        let layouts = seeded.layouts();
        let species: Vec<SceneSpecies> = layouts
            .iter()
            .filter(|l| l.density.mean_per_ha() > 0.0)
            .map(|l| SceneSpecies {
                species: l.species as usize,
                weight: l.density.mean_per_ha(),
                height_m: l.height_m,
            })
            .collect();
        if !species.is_empty() {
            return Ok(SceneMix {
                species,
                radius_m: seeded.min_spacing_m(),
                lambda_max: (sylvan_scene::peak_per_ha(layouts) * 1e-4).max(raster_peak),
            });
        }
    }
    if scene.trees.is_empty() {
        return Err(RenderError::Option(
            "the scene has no trees — shadermap tables are measured for a scene's forest".into(),
        ));
    }
    let mut species: Vec<SceneSpecies> = Vec::new();
    for t in &scene.trees {
        let s = t.species as usize;
        match species.iter_mut().find(|x| x.species == s) {
            Some(x) => {
                x.weight += 1.0;
                x.height_m = [x.height_m[0].min(t.height), x.height_m[1].max(t.height)];
            }
            None => species.push(SceneSpecies {
                species: s,
                weight: 1.0,
                height_m: [t.height, t.height],
            }),
        }
    }
    Ok(SceneMix {
        species,
        radius_m: sylvan_scene::pattern_radius_m(raster.max(0)),
        lambda_max: raster_peak,
    })
}

/// The tables for `scene` (plants: one per species): the `zfield` bakes of its species (read
/// or baked, `zfield.*` settings apply), then the tables (`shadermap.*` settings); with them,
/// each species' mean albedo (linear RGB, from its `zfield` bake as the tables' ρ̄ is; the
/// mix's ρ̄ for a species without trees), indexed like `plants`.
///
/// `settings` are the scene's own `[technique.*]` tables then the command line's; the `zfield`
/// bakes go through `zfield_policy` (the cache), the tables through `tables_policy` (the
/// cache, or the file `sylvan bake --out` names).
pub fn bake_scene(
    gpu: &sylvan_gpu::Gpu,
    scene: &Scene,
    plants: &[Plant],
    settings: &[Setting],
    zfield_policy: &CachePolicy,
    tables_policy: &CachePolicy,
    progress: &mut dyn FnMut(&str, usize, usize),
) -> Result<(ShaderMapTables, BakeReport, Vec<[f32; 3]>), RenderError> {
    let of =
        |name: &str| -> Vec<&Setting> { settings.iter().filter(|s| s.technique == name).collect() };
    let params = self::params(settings)?;
    let (zbake, zdraw) = resolve::<ZFieldBakeParams, ZFieldDrawParams>("zfield", &of("zfield"))?;
    let mix = scene_mix(scene, plants)?;
    let mut zfields = Vec::with_capacity(mix.species.len());
    for s in &mix.species {
        let plant = plants
            .get(s.species)
            .ok_or_else(|| RenderError::Plant(format!("species {} has no plant", s.species)))?;
        let (z, _) = load_or_bake::<ZFieldBake>(gpu, plant, &zbake, zfield_policy, &mut |d, t| {
            progress(&plant.name, d, t)
        })?;
        zfields.push(z);
    }
    let forest = ForestMix {
        species: mix
            .species
            .iter()
            .zip(&zfields)
            .map(|(s, z)| MixSpecies {
                plant: &plants[s.species],
                zfield: z,
                weight: s.weight,
                height_m: s.height_m,
            })
            .collect(),
        zfield_bake: zbake,
        zfield_draw: zdraw,
        radius_m: mix.radius_m,
        lambda_max: mix.lambda_max,
    };
    let (tables, report) = load_or_measure(gpu, &forest, &params, tables_policy, &mut |d, t| {
        progress("shadermap tables", d, t)
    })?;
    let mut albedo = vec![tables.tree_albedo; plants.len()];
    for (s, z) in mix.species.iter().zip(&zfields) {
        albedo[s.species] = mean_albedo(z).map(|v| v as f32);
    }
    Ok((tables, report, albedo))
}

/// The table parameters `settings` give (defaults for the keys they do not set).
pub fn params(settings: &[Setting]) -> Result<ShaderMapBakeParams, RenderError> {
    let mine: Vec<&Setting> = settings
        .iter()
        .filter(|s| s.technique == "shadermap")
        .collect();
    resolve::<ShaderMapBakeParams, ShaderMapDrawParams>("shadermap", &mine).map(|(b, _)| b)
}

/// Checks `shadermap.*` settings without a GPU.
pub fn check_settings(settings: &[&Setting]) -> Result<(), RenderError> {
    resolve::<ShaderMapBakeParams, ShaderMapDrawParams>("shadermap", settings).map(|_| ())
}
