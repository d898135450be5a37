//! Plants as plain data: L-systems, the turtle, the plant hierarchy with instancing, the
//! bounding-box tree (LCV04 §3), meshes, and glTF/OBJ import/export. No GPU.
//!
//! CONTRACT used by `sylvan-render` (fields may be added, not removed or renamed):
//! [`Plant`] with `wood` and `leaves` [`Mesh`]es (metres, Y up, trunk base at the origin),
//! `leaf_texture` (RGBA8, sRGB colour, straight alpha; leaf UVs index it), `bbox_min/max`;
//! [`preset`] and [`load`] build one.

mod mesh;
pub use mesh::{LeafTexture, Mesh, Plant};

/// Errors from building or loading a plant. Display is one line: `FILE:LINE:COL: what — fix`
/// where a location applies.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlantError {
    /// Unknown preset name.
    #[error("unknown plant preset '{0}' — use one of: pine, prunus, bush")]
    UnknownPreset(String),
}

/// A built-in plant by name (`pine`, `prunus`, `bush`).
pub fn preset(name: &str) -> Result<Plant, PlantError> {
    Err(PlantError::UnknownPreset(name.to_string()))
}

/// Loads a plant from a `.lsys`, `.glb`, `.gltf` or `.obj` file.
pub fn load(path: &std::path::Path) -> Result<Plant, PlantError> {
    Err(PlantError::UnknownPreset(path.display().to_string()))
}
