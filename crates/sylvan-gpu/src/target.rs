//! Offscreen colour + depth targets.

use crate::{Gpu, GpuError};

/// Depth format used by every Sylvan pass.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// An offscreen colour target with a matching depth buffer, both `width × height`.
pub struct RenderTarget {
    /// Colour texture (render attachment, sampled, copy source).
    pub color: wgpu::Texture,
    /// View of `color`.
    pub color_view: wgpu::TextureView,
    /// Depth texture.
    pub depth: wgpu::Texture,
    /// View of `depth`.
    pub depth_view: wgpu::TextureView,
    /// Colour format.
    pub format: wgpu::TextureFormat,
    /// Size in pixels.
    pub width: u32,
    /// Size in pixels.
    pub height: u32,
}

impl RenderTarget {
    /// Creates a target, checking the size against the device limits first.
    pub fn new(
        gpu: &Gpu,
        label: &str,
        width: u32,
        height: u32,
        format: wgpu::TextureFormat,
    ) -> Result<Self, GpuError> {
        gpu.check_texture_size(label, width, height)?;
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let color = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let depth = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: DEPTH_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        Ok(Self {
            color_view: color.create_view(&Default::default()),
            depth_view: depth.create_view(&Default::default()),
            color,
            depth,
            format,
            width,
            height,
        })
    }

    /// Bytes of GPU memory the target holds.
    pub fn bytes(&self) -> u64 {
        let px = self.width as u64 * self.height as u64;
        px * (self.format.block_copy_size(None).unwrap_or(4) as u64 + 4)
    }
}
