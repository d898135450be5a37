//! The scene's data types. Units metres, world Y up, right-handed; the terrain covers
//! X ∈ [0, size_x], Z ∈ [0, size_z].

use glam::Vec3;
use std::path::PathBuf;

/// A whole scene: everything a frame needs except the plants' geometry.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The ground.
    pub terrain: Terrain,
    /// Species, indexed by [`TreeInstance::species`].
    pub species: Vec<Species>,
    /// The trees placed when the scene was loaded (positions files, and every density-driven
    /// tree under `poisson` placement), in load order.
    pub trees: Vec<TreeInstance>,
    /// The density-driven trees of `tiled` or `wang` placement, produced for any rectangle on
    /// demand (never all at once for a large world); `None` under `poisson` placement.
    pub seeded: Option<std::sync::Arc<crate::placement::SeededForest>>,
    /// The sun.
    pub sun: Sun,
    /// Sky and ambient colours.
    pub sky: Sky,
    /// Distance fog.
    pub fog: Fog,
    /// The default camera.
    pub camera: Camera,
    /// The `[lod] chain` entries as written (e.g. `"geometry:0-60"`); empty when absent.
    pub lod_chain: Vec<String>,
    /// The LOD chain as `[[lod.band]]` tables, each with its own parameters; empty when absent
    /// (a scene has `lod_chain` or `lod_bands`, not both).
    pub lod_bands: Vec<crate::params::LodBand>,
    /// Every `[technique.NAME]` table's settings, in file order.
    pub technique_params: Vec<crate::params::Setting>,
    /// How the world is split into tiles and how much of it is kept (`[world]`).
    pub world: World,
    /// The file the scene came from (`None` for the built-in scene).
    pub source: Option<PathBuf>,
}

/// The `[world]` table: the tiles trees are produced in, how far they are drawn, and the memory
/// the tile cache may hold. Used by GPU-driven techniques, which draw a world tile by tile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct World {
    /// Side of a tile, metres.
    pub tile_m: f32,
    /// Trees are drawn (and their tiles produced) up to this distance from the eye, metres;
    /// infinite draws the whole terrain.
    pub tree_distance_m: f32,
    /// Tiles are produced this far beyond `tree_distance_m` ahead of need, metres.
    pub prefetch_m: f32,
    /// Most memory the tile cache may hold (CPU and GPU copies of the trees), MiB.
    pub cache_mib: u32,
}

impl Default for World {
    fn default() -> Self {
        Self {
            tile_m: 256.0,
            tree_distance_m: f32::INFINITY,
            prefetch_m: 256.0,
            cache_mib: 1024,
        }
    }
}

/// A regular height grid over X ∈ `[0, size[0]]`, Z ∈ `[0, size[1]]`.
#[derive(Debug, Clone)]
pub struct Terrain {
    /// Extent in metres along X and Z.
    pub size: [f32; 2],
    /// Samples along X (columns) and Z (rows), each ≥ 2.
    pub resolution: [u32; 2],
    /// Heights in metres, row-major: `heights[row * resolution[0] + col]`, row 0 at Z = 0,
    /// column 0 at X = 0.
    pub heights: Vec<f32>,
}

/// Where a species' plant comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum PlantSource {
    /// A built-in preset by name (`pine`, `prunus`, `bush`).
    Preset(String),
    /// A `.lsys`, `.glb`, `.gltf` or `.obj` file (already resolved against the scene's folder).
    File(PathBuf),
}

/// One kind of tree.
#[derive(Debug, Clone)]
pub struct Species {
    /// Name from the scene file.
    pub name: String,
    /// The plant model.
    pub plant: PlantSource,
    /// Each tree is scaled to a height in this range (metres).
    pub height_m: [f32; 2],
}

/// One placed tree.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TreeInstance {
    /// Trunk base, on the terrain surface (metres).
    pub position: Vec3,
    /// Target height in metres (the plant is scaled uniformly to it).
    pub height: f32,
    /// Rotation about +Y in radians.
    pub rotation: f32,
    /// Index into [`Scene::species`].
    pub species: u32,
    /// Per-tree random seed (colour variation): a tree placed at load gets its index in
    /// [`Scene::trees`]; a seeded tree a hash of where it came from.
    pub seed: u32,
}

/// The sun. Azimuth is measured from +Z towards +X; elevation above the horizon; degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sun {
    /// Degrees from +Z towards +X.
    pub azimuth_deg: f32,
    /// Degrees above the horizon.
    pub elevation_deg: f32,
    /// Linear RGB irradiance colour (scaled so a surface facing the sun gets ~ this value).
    pub color: [f32; 3],
}

/// Sky and ambient light (linear RGB).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sky {
    /// Colour at the zenith.
    pub zenith: [f32; 3],
    /// Colour at the horizon (also the fog colour).
    pub horizon: [f32; 3],
    /// Light bounced from the ground (lower hemisphere of the ambient term).
    pub ground: [f32; 3],
    /// The ground's sky is occluded by the trees around it (BN12 eq. 10–12): darker in a
    /// forest, and darker under crowns than between them.
    pub ground_occlusion: bool,
    /// BN12's contrast factor a3 (eq. 10): how much darker the ground is under crowns than
    /// between them, 0 to 4 (default 0.5: under a lone crown Δ = 1 − a3, about the sky the
    /// foot of a trunk sees past a crown as wide as it is high above the ground).
    pub ground_contrast: f32,
}

/// Exponential distance fog.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fog {
    /// Distance in metres at which half the colour is fog (0 disables fog).
    pub half_distance_m: f32,
}

/// A perspective camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position (metres).
    pub position: Vec3,
    /// Point looked at (metres).
    pub look_at: Vec3,
    /// Vertical field of view in degrees.
    pub fov_deg: f32,
}

impl Scene {
    /// Every tree at once: [`Scene::trees`], then the seeded forest produced over the whole
    /// terrain. Errors beyond [`crate::MAX_TREES`] (draw a large tiled world tile by tile).
    pub fn all_trees(&self) -> Result<Vec<TreeInstance>, crate::PlacementError> {
        let Some(forest) = &self.seeded else {
            return Ok(self.trees.clone());
        };
        let estimated = forest.estimated_trees() + self.trees.len() as f64;
        let limit = crate::MAX_TREES as f64;
        if estimated > limit {
            return Err(crate::PlacementError::TooManyTrees { estimated, limit });
        }
        let mut all = self.trees.clone();
        all.reserve((forest.estimated_trees() * 1.05) as usize);
        let size = glam::Vec2::from(self.terrain.size);
        forest.produce(&self.terrain, glam::Vec2::ZERO, size, &mut all);
        Ok(all)
    }

    /// Expected number of trees in all (placed and seeded).
    pub fn estimated_trees(&self) -> f64 {
        self.trees.len() as f64 + self.seeded.as_ref().map_or(0.0, |f| f.estimated_trees())
    }
}

impl Sun {
    /// Unit vector from the ground towards the sun.
    pub fn direction(&self) -> Vec3 {
        let (az, el) = (
            self.azimuth_deg.to_radians(),
            self.elevation_deg.to_radians(),
        );
        Vec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos())
    }
}
