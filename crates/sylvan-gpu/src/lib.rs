//! The only door to the GPU in Sylvan: a wgpu device on any adapter (a real GPU, Mesa's lavapipe
//! Vulkan or llvmpipe GL), offscreen colour/depth targets, supersample resolve, readback to
//! `image`, GPU timestamp timers with a wall-clock fallback, and shader loading.
//!
//! Nothing here knows about trees. Choose a backend with `WGPU_BACKEND=vulkan|gl|metal|dx12`.
//! With no adapter at all, [`Gpu::new`] returns [`GpuError::NoAdapter`], whose message names the
//! Debian packages to install.

mod context;
pub mod layout;
mod readback;
mod resolve;
mod target;
mod timer;

pub use context::{Gpu, GpuError, INSTALL_HINT};
pub use readback::{read_buffer_bytes, read_rgba8, read_texture_bytes};
pub use resolve::{OUTPUT_FORMAT, RESOLVE_WGSL, Resolver};
pub use target::{DEPTH_FORMAT, RenderTarget};
pub use timer::{FrameTimer, MAX_MARKS, TimerKind};
pub use wgpu;

/// Creates a shader module from WGSL source, labelled for error messages.
pub fn shader(gpu: &Gpu, label: &str, source: &str) -> wgpu::ShaderModule {
    gpu.device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        })
}
