//! Defaults for everything a scene file may leave out, and the built-in scenes: the forest the
//! CLI shows when it gets no scene file (a sunlit day over 100 km² of wooded hills, to the
//! horizon) and the small grove the tests and the older benchmarks use.

use crate::noise;
use crate::params::{Origin, ParamValue, Setting};
use crate::placement::{
    Density, DensityMap, Placement, PlacementMethod, SeededForest, SpeciesLayout, place_trees,
};
use crate::types::{Camera, Fog, PlantSource, Scene, Sky, Species, Sun, Terrain, World};
use glam::Vec3;

/// Default sun colour: linear irradiance of a clear mid-day sun, slightly warm.
pub const DEFAULT_SUN_COLOR: [f32; 3] = [3.0, 2.85, 2.6];

impl Default for Sun {
    /// South-east-ish (azimuth 140°), 40° high, warm white.
    fn default() -> Self {
        Self {
            azimuth_deg: 140.0,
            elevation_deg: 40.0,
            color: DEFAULT_SUN_COLOR,
        }
    }
}

impl Default for Sky {
    /// Blue zenith, pale hazy horizon, greenish-brown bounce from the forest floor.
    fn default() -> Self {
        Self {
            zenith: [0.30, 0.50, 0.95],
            horizon: [0.78, 0.85, 0.95],
            ground: [0.24, 0.23, 0.15],
            ground_occlusion: true,
            ground_contrast: 0.5,
        }
    }
}

impl Default for Fog {
    /// Light aerial perspective: half the colour is haze at 3 km.
    fn default() -> Self {
        Self {
            half_distance_m: 3000.0,
        }
    }
}

/// Default height range for a species by preset name, metres.
pub fn preset_height_m(plant: &PlantSource) -> [f32; 2] {
    match plant {
        PlantSource::Preset(p) if p == "pine" => [12.0, 20.0],
        PlantSource::Preset(p) if p == "prunus" => [5.0, 9.0],
        PlantSource::Preset(p) if p == "bush" => [1.0, 2.5],
        _ => [8.0, 16.0],
    }
}

impl Camera {
    /// A camera looking across `terrain` from a raised position near its (0, 0) corner towards
    /// the far side, pitched slightly down so near trees fill the foreground and the far edge
    /// and horizon stay in view.
    pub fn overview(terrain: &Terrain) -> Self {
        let [sx, sz] = terrain.size;
        let (_, top) = terrain.min_max();
        let (ex, ez) = (sx * 0.1, sz * 0.07);
        let ground = terrain.height_at(ex, ez);
        let raise = (0.035 * sx.max(sz)).clamp(15.0, 60.0);
        let eye = Vec3::new(ex, ground.max(top * 0.45) + raise, ez);
        let (tx, tz) = (sx * 0.62, sz * 0.75);
        let dist = Vec3::new(tx - ex, 0.0, tz - ez).length();
        let look_at = Vec3::new(tx, eye.y - dist * 7f32.to_radians().tan(), tz);
        Self {
            position: eye,
            look_at,
            fov_deg: 55.0,
        }
    }
}

/// Extent of the built-in grove's terrain ([`Scene::builtin_grove`]), metres.
pub const BUILTIN_SIZE_M: f32 = 1280.0;

/// Extent of the built-in forest's terrain ([`Scene::builtin_default`]), metres.
pub const BUILTIN_FOREST_SIZE_M: f32 = 10240.0;

/// The built-in forest's LOD chain: full geometry near, LCV04's box trees in the middle
/// distance, BN12's z-fields to 1 km and its shader-map beyond, to the horizon. The middle
/// band's technique and its end were chosen by measurement (`scripts/measure-chain.sh`,
/// BENCHMARKS.md "The built-in forest's chain, measured"): of octahedral, hbt, boxtree,
/// billboard-cloud and zfield in 40–150 m, boxtree was the closest to 16-spp geometry (ꟻLIP
/// 1.20× that of geometry drawing the band; the octahedral impostor 1.65×) and as fast as the
/// fastest on lavapipe; handing over to z-fields at 120 m rather than 150 m was closer still
/// (box trees' coarse images lose to z-fields beyond ~120 m, z-fields to box trees nearer).
pub const BUILTIN_FOREST_CHAIN: [&str; 4] = [
    "geometry:0-40",
    "boxtree:40-120",
    "zfield:120-1000",
    "shadermap:1000-",
];

/// The built-in forest's own `[technique.shadermap]` settings: BN12's tables at 8 view and
/// light zeniths and 8 azimuths (of 16), so a first run on a CPU driver bakes them in about
/// 4 minutes instead of 18 (lavapipe, 2 cores; ꟻLIP 0.013 between the two on the default view,
/// BENCHMARKS "The built-in forest"). `--set shadermap.theta=16 --set shadermap.phi=16` gives
/// the paper's resolution.
pub const BUILTIN_FOREST_PARAMS: [(&str, i64); 2] = [("theta", 8), ("phi", 8)];

impl Scene {
    /// The built-in scene, shown when the CLI gets no scene file: a forest to the horizon —
    /// 10.24 km × 10.24 km of procedural hills (300 m relief) wooded with pine on the heights,
    /// beech on the slopes, prunus in the valleys and bushes in the clearings and meadows, from
    /// procedural density maps (≈ 4.9 M trees, [`Scene::estimated_trees`]), `wang` placement
    /// produced tile by tile as they come within range (nothing is placed at load; seeded on
    /// the GPU by the renderer's tiled world), drawn by
    /// [`BUILTIN_FOREST_CHAIN`] (`--technique auto`) with [`BUILTIN_FOREST_PARAMS`]. The sun is 40° high; the camera
    /// ([`Camera::overview`]) looks across the hills from a raised corner. Needs no files;
    /// deterministic.
    pub fn builtin_default() -> Scene {
        let size = [BUILTIN_FOREST_SIZE_M; 2];
        let terrain = Terrain::procedural(7, size, 300.0);
        let species = vec![
            species("pine", [12.0, 20.0]),
            species("beech", [14.0, 24.0]),
            species("prunus", [5.0, 9.0]),
            species("bush", [0.8, 2.2]),
        ];
        let maps: [DensityMap; 4] = density_maps(&terrain, &FOREST_MAPS);
        let layouts = layouts_of(&species, maps, [420.0, 320.0, 300.0, 260.0]);
        let seeded = SeededForest::with_method(size, &layouts, 2024, PlacementMethod::Wang, &[])
            .expect("the built-in forest is within the limits")
            .map(std::sync::Arc::new);
        Scene {
            camera: Camera::overview(&terrain),
            terrain,
            species,
            trees: Vec::new(),
            seeded,
            world: World {
                tile_m: 256.0,
                tree_distance_m: 1100.0,
                ..World::default()
            },
            sun: Sun::default(),
            sky: Sky::default(),
            fog: Fog::default(),
            lod_chain: BUILTIN_FOREST_CHAIN.iter().map(|s| s.to_string()).collect(),
            lod_bands: Vec::new(),
            technique_params: BUILTIN_FOREST_PARAMS
                .iter()
                .map(|&(key, value)| Setting {
                    technique: "shadermap".into(),
                    key: key.into(),
                    value: ParamValue::Int(value),
                    origin: Origin::Arg(format!("the built-in forest's shadermap.{key}={value}")),
                })
                .collect(),
            source: None,
        }
    }

    /// The small built-in grove (the built-in scene before the forest): about 6,400 trees
    /// (pine, prunus and bush presets, in groves with clearings; pines favour the heights,
    /// prunus the valleys), all placed at load, on 1.28 km × 1.28 km of procedural hills with
    /// 110 m relief, the sun 40° high, and [`Camera::overview`]. Tests and the benchmarks of
    /// single techniques use it. Needs no files; deterministic.
    pub fn builtin_grove() -> Scene {
        let size = [BUILTIN_SIZE_M; 2];
        let terrain = Terrain::procedural(7, size, 110.0);
        let species = vec![
            species("pine", [12.0, 20.0]),
            species("prunus", [5.0, 9.0]),
            species("bush", [0.8, 2.2]),
        ];
        let maps: [DensityMap; 3] = density_maps(&terrain, &GROVE_MAPS);
        let layouts = layouts_of(&species, maps, [36.0, 32.0, 12.0]);
        let placement = Placement {
            seed: 2024,
            ..Placement::default()
        };
        let trees = place_trees(&terrain, &layouts, &placement, &[])
            .expect("the built-in grove is within the limits")
            .trees;
        Scene {
            camera: Camera::overview(&terrain),
            terrain,
            species,
            trees,
            seeded: None,
            world: Default::default(),
            sun: Sun::default(),
            sky: Sky::default(),
            fog: Fog::default(),
            lod_chain: Vec::new(),
            lod_bands: Vec::new(),
            technique_params: Vec::new(),
            source: None,
        }
    }
}

/// One layout per species: its map in [0, 1] scaled to `max_per_ha` at 1.
fn layouts_of<const N: usize>(
    species: &[Species],
    maps: [DensityMap; N],
    max_per_ha: [f32; N],
) -> Vec<SpeciesLayout> {
    maps.into_iter()
        .zip(max_per_ha)
        .enumerate()
        .map(|(i, (map, max_per_ha))| SpeciesLayout {
            species: i as u32,
            height_m: species[i].height_m,
            density: Density::Map { map, max_per_ha },
        })
        .collect()
}

fn species(name: &str, height_m: [f32; 2]) -> Species {
    Species {
        name: name.into(),
        plant: PlantSource::Preset(name.into()),
        height_m,
    }
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// How a built-in scene's density maps are drawn from noise and elevation (lengths in metres).
struct MapRecipe {
    /// Samples per side.
    resolution: u32,
    /// Feature size of the noise that mixes species (upland against valley), metres.
    mix_m: f64,
    /// Feature size of the clearings, metres.
    glade_m: f64,
    /// Feature size of the open country (meadows kilometres across), metres; 0: none.
    open_m: f64,
}

/// The grove's maps (unchanged since the grove was the default scene).
const GROVE_MAPS: MapRecipe = MapRecipe {
    resolution: 129,
    mix_m: 260.0,
    glade_m: 180.0,
    open_m: 0.0,
};

/// The forest's maps: 20 m texels over 10 km, larger stands, open country between woods.
const FOREST_MAPS: MapRecipe = MapRecipe {
    resolution: 513,
    mix_m: 700.0,
    glade_m: 260.0,
    open_m: 2600.0,
};

/// The density maps of a built-in scene, in [0, 1]: `N = 3` gives pine, prunus, bush (the
/// grove); `N = 4` pine, beech, prunus, bush (the forest: beech takes the drier half of the
/// low ground).
fn density_maps<const N: usize>(terrain: &Terrain, recipe: &MapRecipe) -> [DensityMap; N] {
    let res = recipe.resolution;
    let (lo, hi) = terrain.min_max();
    let n = (res * res) as usize;
    let mut values: [Vec<f32>; N] = std::array::from_fn(|_| Vec::with_capacity(n));
    for row in 0..res {
        for col in 0..res {
            let x = col as f32 / (res - 1) as f32 * terrain.size[0];
            let z = row as f32 / (res - 1) as f32 * terrain.size[1];
            let elevation = (terrain.height_at(x, z) - lo) / (hi - lo).max(1e-3);
            let (xf, zf) = (x as f64, z as f64);
            let mix = noise::fbm(11, xf / recipe.mix_m, zf / recipe.mix_m, 3, 0.5) as f32;
            let glade = noise::fbm(23, xf / recipe.glade_m, zf / recipe.glade_m, 3, 0.5) as f32;
            let mut forest = smoothstep(-0.40, -0.18, glade);
            if recipe.open_m > 0.0 {
                let open = noise::fbm(31, xf / recipe.open_m, zf / recipe.open_m, 3, 0.5) as f32;
                forest *= smoothstep(-0.35, -0.15, open);
            }
            let upland = smoothstep(0.25, 0.65, elevation + 0.35 * mix);
            let low = forest * (1.0 - upland);
            let pine = forest * (0.3 + 0.7 * upland);
            let bush = 0.35 + 0.65 * (1.0 - forest);
            if N == 3 {
                values[0].push(pine);
                values[1].push(low * 0.9);
                values[2].push(bush);
            } else {
                let beech = smoothstep(-0.15, 0.25, mix);
                values[0].push(pine);
                values[1].push(low * beech);
                values[2].push(low * (1.0 - beech) * 0.9);
                values[3].push(bush);
            }
        }
    }
    values.map(|values| DensityMap {
        resolution: [res, res],
        values,
    })
}
