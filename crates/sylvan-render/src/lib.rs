//! Sylvan's frame renderer: terrain, sky, cascaded sun shadows, distance fog, and the tree
//! representations of `technique/` behind one trait.
//!
//! ```no_run
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let gpu = sylvan_gpu::Gpu::new()?;
//! let scene = sylvan_scene::Scene::builtin_default();
//! let plants = sylvan_render::load_plants(&scene)?;
//! // `auto`: the scene's LOD chain (the built-in forest: geometry near, the shader-map far).
//! let options = sylvan_render::RenderOptions {
//!     width: 640,
//!     height: 360,
//!     technique: "auto".into(),
//!     ..Default::default()
//! };
//! let mut renderer = sylvan_render::Renderer::new(&gpu, &scene, &plants, &options)?;
//! let stats = renderer.render(&gpu, &scene.camera, &scene.sun)?;
//! let image = renderer.read_image(&gpu)?;
//! # Ok(()) }
//! ```
//!
//! Conventions: metres, Y up, right-handed; linear HDR in the main pass (reversed-Z depth),
//! tone-mapped to sRGB in the resolve.

pub mod bake;
pub mod directions;
mod error;
pub mod frame;
pub mod instances;
pub mod pipeline;
mod renderer;
mod sky;
pub mod technique;
mod terrain;
pub mod texture;
pub mod world;

pub use error::RenderError;
pub use frame::DebugView;
pub use pipeline::{ColorOutput, DepthConvention, MainTarget};
pub use renderer::{
    CameraMatrices, FrameStats, Layers, PreparedFrame, RenderOptions, Renderer, Seeds, load_plants,
};
pub use technique::DrawCounts;
pub use technique::{Technique, registry};
