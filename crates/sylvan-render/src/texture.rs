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
    cutout_mips_to(base, 1)
}

/// [`cutout_mips`] down to the first level whose shorter side is `min_side` texels (or the
/// base level if it is smaller). Leaf textures stop at 4: below that a level has too few
/// texels to keep its coverage (a 1×1 level is all in or all out), and sub-pixel leaves
/// sampling a 4-texel-wide level keep the crown's coverage on average instead of vanishing.
pub fn cutout_mips_to(base: Level, min_side: u32) -> Vec<Level> {
    let target = coverage(&base.rgba, 1.0);
    let mut levels = vec![base];
    while let Some(prev) = levels
        .last()
        .filter(|l| (l.width > 1 || l.height > 1) && l.width.min(l.height) > min_side)
    {
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

/// Builds a mip chain for a tangent-space normal map (RGB = n · 0.5 + 0.5): each level is the
/// 2×2 mean of the one above, renormalised (so far leaves shade with their mean normal).
pub fn normal_mips(base: Level) -> Vec<Level> {
    let mut levels = vec![base];
    while let Some(prev) = levels.last().filter(|l| l.width > 1 || l.height > 1) {
        let (w, h) = ((prev.width / 2).max(1), (prev.height / 2).max(1));
        let mut rgba = vec![255u8; (w * h * 4) as usize];
        for y in 0..h {
            for x in 0..w {
                let mut n = [0f32; 3];
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let sx = (2 * x + dx).min(prev.width - 1);
                    let sy = (2 * y + dy).min(prev.height - 1);
                    let p = &prev.rgba[((sy * prev.width + sx) * 4) as usize..][..3];
                    for c in 0..3 {
                        n[c] += p[c] as f32 / 127.5 - 1.0;
                    }
                }
                let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt().max(1e-6);
                let o = ((y * w + x) * 4) as usize;
                for c in 0..3 {
                    rgba[o + c] = ((n[c] / len * 0.5 + 0.5) * 255.0).round() as u8;
                }
            }
        }
        levels.push(Level {
            width: w,
            height: h,
            rgba,
        });
    }
    levels
}

/// Uploads one level of `format` texels (`bytes`, layer-major, tightly packed) as a sampled
/// texture of `size` (width, height, depth or layers) and `dimension`.
pub fn upload_raw(
    gpu: &sylvan_gpu::Gpu,
    label: &str,
    size: [u32; 3],
    dimension: wgpu::TextureDimension,
    format: wgpu::TextureFormat,
    bytes: &[u8],
) -> wgpu::Texture {
    use wgpu::util::DeviceExt;
    gpu.device.create_texture_with_data(
        &gpu.queue,
        &wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: size[0],
                height: size[1],
                depth_or_array_layers: size[2],
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension,
            format,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        bytes,
    )
}

/// Uploads a mip chain as an `Rgba8UnormSrgb` 2D texture.
pub fn upload(gpu: &sylvan_gpu::Gpu, label: &str, levels: &[Level]) -> wgpu::Texture {
    upload_as(gpu, label, levels, wgpu::TextureFormat::Rgba8UnormSrgb)
}

/// Uploads a mip chain as a 2D texture of `format` (an RGBA8 format).
pub fn upload_as(
    gpu: &sylvan_gpu::Gpu,
    label: &str,
    levels: &[Level],
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
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
        format,
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

/// The shortest side of a leaf image's last mip level ([`cutout_mips_to`]), for single leaves
/// and leaf cards alike. A leaf card's chain used to run down to 1×1, where its
/// coverage-preserving mean is a faint smear the alpha test drops: far or small trees lost
/// every leaf at 1 spp (BENCHMARKS.md, "Leaf mips": trees-1k at 192×108, 1-spp `geometry`
/// ꟻLIP vs 16 spp 0.0338 → 0.0260).
pub const LEAF_MIN_MIP: u32 = 4;

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
    let levels = cutout_mips_to(
        Level {
            width: tex.width,
            height: tex.height,
            rgba: tex.rgba.clone(),
        },
        LEAF_MIN_MIP,
    );
    let bytes = levels.iter().map(|l| l.rgba.len() as u64).sum();
    Ok((upload(gpu, label, &levels), bytes))
}

/// A plant's leaf images on the GPU: front and back colour (sRGB, coverage-preserving mips of
/// the same alpha) and the tangent-space normal map (linear). A plant without a back image
/// gets its front image again, one without a normal map a flat 1×1 one.
pub struct LeafMaterial {
    /// Front side (its alpha is the cut-out of both sides).
    pub front: wgpu::TextureView,
    /// Back side.
    pub back: wgpu::TextureView,
    /// Normal map.
    pub normal: wgpu::TextureView,
    /// GPU bytes of all three (all levels).
    pub bytes: u64,
}

/// Checks and uploads a plant's leaf images ([`LeafMaterial`]).
pub fn upload_leaf_material(
    gpu: &sylvan_gpu::Gpu,
    label: &str,
    plant: &sylvan_plant::Plant,
) -> Result<LeafMaterial, crate::RenderError> {
    let (front, mut bytes) = upload_leaf_texture(gpu, label, plant)?;
    let front_size = (plant.leaf_texture.width, plant.leaf_texture.height);
    let check = |t: &sylvan_plant::LeafTexture, what: &str| {
        if t.rgba.len() != (t.width as usize * t.height as usize * 4)
            || (t.width, t.height) != front_size
        {
            return Err(crate::RenderError::Plant(format!(
                "{}: leaf {what} image size does not match the front image or its data",
                plant.name
            )));
        }
        Ok(())
    };
    let back = if plant.leaf_back.rgba.is_empty() {
        front.create_view(&Default::default())
    } else {
        check(&plant.leaf_back, "back")?;
        let levels = cutout_mips_to(
            Level {
                width: plant.leaf_back.width,
                height: plant.leaf_back.height,
                rgba: plant.leaf_back.rgba.clone(),
            },
            LEAF_MIN_MIP,
        );
        bytes += levels.iter().map(|l| l.rgba.len() as u64).sum::<u64>();
        upload(gpu, &format!("{label}_back"), &levels).create_view(&Default::default())
    };
    let normal_base = if plant.leaf_normal.rgba.is_empty() {
        Level {
            width: 1,
            height: 1,
            rgba: vec![128, 128, 255, 255],
        }
    } else {
        check(&plant.leaf_normal, "normal-map")?;
        Level {
            width: plant.leaf_normal.width,
            height: plant.leaf_normal.height,
            rgba: plant.leaf_normal.rgba.clone(),
        }
    };
    let levels = normal_mips(normal_base);
    bytes += levels.iter().map(|l| l.rgba.len() as u64).sum::<u64>();
    let normal = upload_as(
        gpu,
        &format!("{label}_normal"),
        &levels,
        wgpu::TextureFormat::Rgba8Unorm,
    )
    .create_view(&Default::default());
    Ok(LeafMaterial {
        front: front.create_view(&Default::default()),
        back,
        normal,
        bytes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_mips_stay_unit() {
        // A ridge: left half tilted one way, right half the other; the mean is flat.
        let mut rgba = vec![0u8; 8 * 8 * 4];
        for (i, p) in rgba.chunks_exact_mut(4).enumerate() {
            let x = if i % 8 < 4 { -0.6f32 } else { 0.6 };
            let z = (1.0 - x * x).sqrt();
            p.copy_from_slice(&[
                ((x * 0.5 + 0.5) * 255.0) as u8,
                128,
                ((z * 0.5 + 0.5) * 255.0) as u8,
                255,
            ]);
        }
        let levels = normal_mips(Level {
            width: 8,
            height: 8,
            rgba,
        });
        assert_eq!(levels.len(), 4);
        let last = &levels[3].rgba;
        assert!(
            (last[0] as i32 - 128).abs() <= 2 && last[2] >= 253,
            "{last:?}"
        );
    }

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
