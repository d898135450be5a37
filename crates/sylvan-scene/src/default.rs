//! Defaults for everything a scene file may leave out, and the built-in scene used when the CLI
//! gets no scene file: a pleasant sunlit day over a forest on hills.

use crate::noise;
use crate::placement::{Density, DensityMap, Placement, SpeciesLayout, place_trees};
use crate::types::{Camera, Fog, PlantSource, Scene, Sky, Species, Sun, Terrain};
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

/// Extent of the built-in scene's terrain, metres.
pub const BUILTIN_SIZE_M: f32 = 1280.0;

impl Scene {
    /// The built-in scene: about 6,500 trees (pine, prunus and bush presets, in groves with
    /// clearings; pines favour the heights, prunus the valleys) on 1.28 km × 1.28 km of
    /// procedural hills with 110 m relief, the sun 40° high, and [`Camera::overview`].
    /// Needs no files; deterministic.
    pub fn builtin_default() -> Scene {
        let size = [BUILTIN_SIZE_M; 2];
        let terrain = Terrain::procedural(7, size, 110.0);
        let species = vec![
            species("pine", [12.0, 20.0]),
            species("prunus", [5.0, 9.0]),
            species("bush", [0.8, 2.2]),
        ];
        let (pine, prunus, bush) = builtin_density_maps(&terrain);
        let layouts = [
            SpeciesLayout {
                species: 0,
                height_m: species[0].height_m,
                density: pine,
            },
            SpeciesLayout {
                species: 1,
                height_m: species[1].height_m,
                density: prunus,
            },
            SpeciesLayout {
                species: 2,
                height_m: species[2].height_m,
                density: bush,
            },
        ];
        let placement = Placement {
            seed: 2024,
            ..Placement::default()
        };
        let trees = place_trees(&terrain, &layouts, &placement, &[])
            .expect("the built-in scene is within the limits")
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

/// Density maps of the built-in scene, from noise and elevation.
fn builtin_density_maps(terrain: &Terrain) -> (Density, Density, Density) {
    const RES: u32 = 129;
    let (lo, hi) = terrain.min_max();
    let n = (RES * RES) as usize;
    let (mut pine, mut prunus, mut bush) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    for row in 0..RES {
        for col in 0..RES {
            let x = col as f32 / (RES - 1) as f32 * terrain.size[0];
            let z = row as f32 / (RES - 1) as f32 * terrain.size[1];
            let elevation = (terrain.height_at(x, z) - lo) / (hi - lo).max(1e-3);
            let mix = noise::fbm(11, x as f64 / 260.0, z as f64 / 260.0, 3, 0.5) as f32;
            let glade = noise::fbm(23, x as f64 / 180.0, z as f64 / 180.0, 3, 0.5) as f32;
            let forest = smoothstep(-0.40, -0.18, glade);
            let upland = smoothstep(0.25, 0.65, elevation + 0.35 * mix);
            pine.push(forest * (0.3 + 0.7 * upland));
            prunus.push(forest * (1.0 - upland) * 0.9);
            bush.push(0.35 + 0.65 * (1.0 - forest));
        }
    }
    let map = |values| DensityMap {
        resolution: [RES, RES],
        values,
    };
    (
        Density::Map {
            map: map(pine),
            max_per_ha: 36.0,
        },
        Density::Map {
            map: map(prunus),
            max_per_ha: 32.0,
        },
        Density::Map {
            map: map(bush),
            max_per_ha: 12.0,
        },
    )
}
