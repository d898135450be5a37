//! CPU-side texture preparation shared by techniques: mip chains for alpha-tested RGBA8 images.

/// An RGBA8 image level.
#[derive(Debug, Clone, PartialEq)]
pub struct Level {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height * 4` bytes.
    pub rgba: Vec<u8>,
}

fn coverage(rgba: &[u8], scale: f32) -> f32 {
    let n = rgba.len() / 4;
    let covered = rgba
        .chunks_exact(4)
        .filter(|p| p[3] as f32 * scale >= 127.5)
        .count();
    covered as f32 / n.max(1) as f32
}

/// Builds a full mip chain for a cut-out texture: colour is averaged weighted by alpha (so
/// transparent texels do not darken edges), and each level's alpha is rescaled so that the
/// fraction of texels passing the 0.5 alpha test matches level 0 (coverage-preserving mips;
/// without it, alpha-tested foliage thins out with distance).
pub fn cutout_mips(base: Level) -> Vec<Level> {
    let target = coverage(&base.rgba, 1.0);
    let mut levels = vec![base];
    while let Some(prev) = levels.last().filter(|l| l.width > 1 || l.height > 1) {
        let (w, h) = ((prev.width / 2).max(1), (prev.height / 2).max(1));
        let mut rgba = vec![0u8; (w * h * 4) as usize];
        for y in 0..h {
            for x in 0..w {
                let mut acc = [0f32; 4];
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let sx = (2 * x + dx).min(prev.width - 1);
                    let sy = (2 * y + dy).min(prev.height - 1);
                    let p = &prev.rgba[((sy * prev.width + sx) * 4) as usize..][..4];
                    let a = p[3] as f32;
                    for c in 0..3 {
                        acc[c] += p[c] as f32 * a;
                    }
                    acc[3] += a;
                }
                let o = ((y * w + x) * 4) as usize;
                for c in 0..3 {
                    rgba[o + c] = if acc[3] > 0.0 {
                        (acc[c] / acc[3]).round() as u8
                    } else {
                        0
                    };
                }
                rgba[o + 3] = (acc[3] / 4.0).round() as u8;
            }
        }
        // Binary search the alpha scale that restores the level-0 coverage.
        let (mut lo, mut hi) = (0.25f32, 8.0f32);
        for _ in 0..16 {
            let mid = 0.5 * (lo + hi);
            if coverage(&rgba, mid) < target {
                lo = mid
            } else {
                hi = mid
            }
        }
        for p in rgba.chunks_exact_mut(4) {
            p[3] = (p[3] as f32 * hi).min(255.0) as u8;
        }
        levels.push(Level {
            width: w,
            height: h,
            rgba,
        });
    }
    levels
}

/// Uploads a mip chain as an `Rgba8UnormSrgb` 2D texture.
pub fn upload(gpu: &sylvan_gpu::Gpu, label: &str, levels: &[Level]) -> wgpu::Texture {
    let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: levels[0].width,
            height: levels[0].height,
            depth_or_array_layers: 1,
        },
        mip_level_count: levels.len() as u32,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8UnormSrgb,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    for (mip, l) in levels.iter().enumerate() {
        gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: mip as u32,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            &l.rgba,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(l.width * 4),
                rows_per_image: Some(l.height),
            },
            wgpu::Extent3d {
                width: l.width,
                height: l.height,
                depth_or_array_layers: 1,
            },
        );
    }
    texture
}

/// Checks a plant's leaf texture against its data and the device, and uploads it with
/// coverage-preserving mips; returns the texture and its bytes (all levels).
pub fn upload_leaf_texture(
    gpu: &sylvan_gpu::Gpu,
    label: &str,
    plant: &sylvan_plant::Plant,
) -> Result<(wgpu::Texture, u64), crate::RenderError> {
    let tex = &plant.leaf_texture;
    if tex.width == 0 || tex.height == 0 || tex.rgba.len() != (tex.width * tex.height * 4) as usize
    {
        return Err(crate::RenderError::Plant(format!(
            "{}: leaf texture size does not match its data",
            plant.name
        )));
    }
    gpu.check_texture_size("leaf texture", tex.width, tex.height)?;
    let levels = cutout_mips(Level {
        width: tex.width,
        height: tex.height,
        rgba: tex.rgba.clone(),
    });
    let bytes = levels.iter().map(|l| l.rgba.len() as u64).sum();
    Ok((upload(gpu, label, &levels), bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mips_preserve_alpha_test_coverage() {
        // A disc of radius 20 in 64²: ~31% coverage.
        let mut rgba = vec![0u8; 64 * 64 * 4];
        for y in 0..64 {
            for x in 0..64 {
                let (dx, dy) = (x as f32 - 31.5, y as f32 - 31.5);
                if dx * dx + dy * dy < 400.0 {
                    rgba[(y * 64 + x) * 4..][..4].copy_from_slice(&[40, 120, 30, 255]);
                }
            }
        }
        let levels = cutout_mips(Level {
            width: 64,
            height: 64,
            rgba,
        });
        assert_eq!(levels.len(), 7);
        let c0 = coverage(&levels[0].rgba, 1.0);
        for l in &levels[1..5] {
            assert!(
                (coverage(&l.rgba, 1.0) - c0).abs() < 0.08,
                "coverage drifted at {}²",
                l.width
            );
        }
        // Edge texels keep the leaf colour, not a dark mix with transparent black.
        assert!(
            levels[3]
                .rgba
                .chunks_exact(4)
                .filter(|p| p[3] > 0)
                .all(|p| p[1] >= 110)
        );
    }
}
