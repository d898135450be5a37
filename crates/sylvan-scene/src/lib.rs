//! Scenes as plain data: the TOML scene file, terrain (procedural, 16-bit PNG, GeoTIFF),
//! species, seeded tree placement, camera and sun/sky. No GPU.
//!
//! CONTRACT used by `sylvan-render` and the CLI (fields may be added, not removed or renamed):
//! [`Scene`], [`Terrain`], [`Species`], [`PlantSource`], [`TreeInstance`], [`Sun`], [`Sky`],
//! [`Camera`], [`Fog`]; [`Scene::load`] and [`Scene::builtin_default`].

mod types;
pub use types::*;
