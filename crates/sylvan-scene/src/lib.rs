//! Scenes as plain data: the TOML scene file, terrain (procedural, 16-bit PNG, GeoTIFF),
//! species, seeded tree placement, camera and sun/sky. No GPU.
//!
//! CONTRACT used by `sylvan-render` and the CLI (fields may be added, not removed or renamed):
//! [`Scene`], [`Terrain`], [`Species`], [`PlantSource`], [`TreeInstance`], [`Sun`], [`Sky`],
//! [`Camera`], [`Fog`]; [`Scene::load`] and [`Scene::builtin_default`].

#![warn(missing_docs)]

mod csv;
mod default;
mod error;
mod file;
mod heightmap;
mod noise;
mod params;
mod path;
mod placement;
mod rng;
mod species;
mod terrain;
mod types;

pub use csv::{MAX_CSV_BYTES, MAX_CSV_ROWS};
pub use default::{BUILTIN_SIZE_M, DEFAULT_SUN_COLOR, preset_height_m};
pub use error::{ErrorKind, Location, SceneError, line_col};
pub use heightmap::MAX_IMAGE_DIM;
pub use params::{LodBand, Origin, ParamValue, Setting};
pub use path::{CameraKey, CameraPath, Interpolation};
pub use placement::{
    DEFAULT_DENSITY_PER_HA, Density, DensityMap, MAX_DENSITY_PER_HA, MAX_PATTERN_POINTS, MAX_TREES,
    Placed, Placement, PlacementError, PlacementMethod, SpeciesLayout, estimate_trees, peak_per_ha,
    place_trees, poisson_disk, poisson_tile,
};
pub use terrain::{
    MAX_PROCEDURAL_RESOLUTION, MAX_TERRAIN_SAMPLES, MAX_TERRAIN_SIZE_M, PROCEDURAL_SPACING_M,
    ProceduralTerrain,
};
pub use types::*;
