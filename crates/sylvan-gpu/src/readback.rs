//! Reading textures back to the CPU (tests, screenshots, offline bakes).

use crate::{Gpu, GpuError};

/// Reads `texture` (mip 0, layer 0) into tightly packed rows, for any uncompressed format.
/// Returns `width * height * block_size` bytes.
pub fn read_texture_bytes(gpu: &Gpu, texture: &wgpu::Texture) -> Result<Vec<u8>, GpuError> {
    let (width, height) = (texture.width(), texture.height());
    let format = texture.format();
    let block = format.block_copy_size(None).ok_or_else(|| {
        GpuError::Wgpu(format!(
            "cannot read back {format:?}: not a plain colour format"
        ))
    })?;
    let unpadded = width * block;
    let padded =
        unpadded.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: padded as u64 * height as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(height),
            },
        },
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
    );
    gpu.queue.submit([encoder.finish()]);
    let slice = buffer.slice(..);
    slice.map_async(wgpu::MapMode::Read, |_| {});
    gpu.wait()?;
    let data = slice
        .get_mapped_range()
        .map_err(|e| GpuError::Wgpu(e.to_string()))?;
    let mut bytes = Vec::with_capacity((unpadded * height) as usize);
    for row in data.chunks(padded as usize) {
        bytes.extend_from_slice(&row[..unpadded as usize]);
    }
    drop(data);
    buffer.unmap();
    Ok(bytes)
}

/// Reads a whole buffer (it needs `COPY_SRC` usage) back to the CPU, through a staging copy.
pub fn read_buffer_bytes(gpu: &Gpu, buffer: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
    let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("buffer_readback"),
        size: buffer.size(),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, buffer.size());
    gpu.queue.submit([encoder.finish()]);
    let slice = staging.slice(..);
    slice.map_async(wgpu::MapMode::Read, |_| {});
    gpu.wait()?;
    let bytes = slice
        .get_mapped_range()
        .map_err(|e| GpuError::Wgpu(e.to_string()))?
        .to_vec();
    staging.unmap();
    Ok(bytes)
}

/// Reads a 4-byte-per-texel texture (e.g. the sRGB output target) into an RGBA image.
pub fn read_rgba8(gpu: &Gpu, texture: &wgpu::Texture) -> Result<image::RgbaImage, GpuError> {
    let format = texture.format();
    if format.block_copy_size(None) != Some(4) {
        return Err(GpuError::Wgpu(format!(
            "read_rgba8 needs a 4-byte format, got {format:?}"
        )));
    }
    let pixels = read_texture_bytes(gpu, texture)?;
    image::RgbaImage::from_raw(texture.width(), texture.height(), pixels)
        .ok_or_else(|| GpuError::Wgpu("readback size mismatch".into()))
}
