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
mod wang;

pub use csv::{MAX_CSV_BYTES, MAX_CSV_ROWS};
pub use default::{
    BUILTIN_FOREST_CHAIN, BUILTIN_FOREST_PARAMS, BUILTIN_FOREST_SIZE_M, BUILTIN_SIZE_M,
    DEFAULT_SUN_COLOR, preset_height_m,
};
pub use error::{ErrorKind, Location, SceneError, line_col};
pub use file::{MAX_COLOR, MAX_ELEVATION_M, MAX_SCENE_BYTES, MAX_SPECIES};
pub use heightmap::MAX_IMAGE_DIM;
pub use heightmap::MAX_RASTER_BYTES;
pub use params::{LodBand, Origin, ParamValue, Setting};
pub use path::{CameraKey, CameraPath, Interpolation};
pub use placement::{
    CandidateRun, DEFAULT_DENSITY_PER_HA, Density, DensityMap, MAX_DENSITY_PER_HA,
    MAX_PATTERN_POINTS, MAX_TREES, MAX_WORLD_TREES, Placed, Placement, PlacementError,
    PlacementMethod, SeededForest, SpeciesLayout, estimate_trees, pattern_radius_m, peak_per_ha,
    place_trees, poisson_disk, poisson_tile,
};
pub use species::{MAX_TREE_HEIGHT_M, PRESETS};
pub use terrain::{
    MAX_PROCEDURAL_RESOLUTION, MAX_TERRAIN_SAMPLES, MAX_TERRAIN_SIZE_M, PROCEDURAL_SPACING_M,
    ProceduralTerrain,
};
pub use types::*;
pub use wang::WangSet;

/// Entry points for the fuzz targets (`fuzz/`) and their stable-Rust corpus test: each parses
/// untrusted bytes the way a scene load does and must return, never panic.
#[doc(hidden)]
pub mod fuzzing {
    use crate::error::Location;
    use std::path::Path;

    /// A positions CSV on a 1 km flat terrain.
    pub fn positions_csv(text: &str) {
        let t = crate::Terrain::flat([1000.0, 1000.0], 0.0);
        let at = Location::file(Path::new("fuzz.toml"));
        let _ =
            crate::csv::parse_positions(text, Path::new("fuzz.csv"), &at, &t, 0, [5.0, 10.0], 1);
    }

    /// A heightmap file's bytes (PNG or GeoTIFF), made into a 100 m terrain; then the same
    /// bytes as a density map.
    pub fn heightmap(bytes: &[u8]) {
        use crate::heightmap::{Purpose, decode_gray};
        let p = Path::new("fuzz.tif");
        let at = Location::file(p);
        if let Ok(r) = decode_gray(bytes, p, Purpose::Heightmap, &at) {
            let _ = r.into_terrain([100.0, 100.0], Some([0.0, 50.0]));
        }
        let _ = decode_gray(bytes, p, Purpose::DensityMap, &at);
    }

    /// Trees a fuzzed scene may place at load. A valid scene of 800k trees takes over
    /// libFuzzer's 10 s under AddressSanitizer (about 1 s in a release build): not a hang, but
    /// it would stop the campaign, so the fuzz entry point refuses it as "too many trees".
    pub const FUZZ_TREE_LIMIT: usize = 20_000;

    /// A scene file's text (files it names resolve against a folder that does not exist),
    /// with at most [`FUZZ_TREE_LIMIT`] trees placed.
    pub fn scene(text: &str) -> Result<crate::Scene, crate::SceneError> {
        crate::file::parse_scene(text, Path::new("/nonexistent/fuzz.toml"), FUZZ_TREE_LIMIT)
    }

    /// A camera-path file's text.
    pub fn camera_path(text: &str) {
        let _ = crate::CameraPath::parse(text, Path::new("fuzz-path.toml"));
    }
}
