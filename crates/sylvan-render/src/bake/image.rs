//! CPU side of a bake: resolving supersampled renders into tiles, dilating, mip-mapping and
//! quantising.
//!
//! A tile holds two images of the same size:
//! - **colour**: premultiplied linear albedo and coverage. Premultiplied data filters correctly
//!   (a transparent texel contributes nothing), so mips and bilinear sampling have no dark
//!   fringes and need no dilation.
//! - **normal/depth**: the unit normal facing the bake camera (xyz, coverage-weighted average,
//!   renormalised) and the depth in the box along the view (w, 0 near face … 1 far face). It is
//!   not premultiplied, so texels with no coverage are **dilated** from covered neighbours, so
//!   filtering at silhouettes never mixes in a meaningless value.

/// One resolved image (floats, row 0 at the top).
#[derive(Debug, Clone, PartialEq)]
pub struct TileImage {
    /// Width = height in texels.
    pub size: u32,
    /// Premultiplied linear albedo, coverage in `a`.
    pub color: Vec<[f32; 4]>,
    /// Unit normal (xyz) and depth in [0, 1] (w), meaningful where coverage > 0.
    pub normal_depth: Vec<[f32; 4]>,
}

/// One mip level of a tile, quantised for upload: colour sRGB-encoded premultiplied RGBA8,
/// normal as `n * 0.5 + 0.5` with depth in alpha (RGBA8 unorm).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TileLevel {
    /// Width = height in texels.
    pub size: u32,
    /// `size² × 4` bytes.
    pub color: Vec<u8>,
    /// `size² × 4` bytes.
    pub normal: Vec<u8>,
}

impl TileLevel {
    /// Writes a tile's mip chain (as [`TileLevel::decode_chain`] reads it back).
    pub fn encode_chain(e: &mut super::codec::Encoder, levels: &[TileLevel]) {
        e.u64(levels.len() as u64);
        for l in levels {
            e.u32(l.size);
            e.bytes(&l.color);
            e.bytes(&l.normal);
        }
    }

    /// Reads a full mip chain of a `tile`-texel tile, checking the level count and every
    /// level's size and byte lengths.
    pub fn decode_chain(
        d: &mut super::codec::Decoder<'_>,
        tile: u32,
    ) -> Result<Vec<TileLevel>, super::codec::DecodeError> {
        let bad = |m: String| super::codec::DecodeError(m);
        if tile == 0 || !tile.is_power_of_two() {
            return Err(bad(format!("tile size {tile} is not a power of two")));
        }
        let nlev = d.u64()?;
        if nlev != tile.ilog2() as u64 + 1 {
            return Err(bad(format!("{nlev} mip levels for a {tile}-texel tile")));
        }
        let mut levels = Vec::with_capacity(nlev as usize);
        for m in 0..nlev as u32 {
            let size = d.u32()?;
            let color = d.bytes()?.to_vec();
            let normal = d.bytes()?.to_vec();
            let want = (tile >> m).max(1);
            if size != want
                || color.len() != (size * size * 4) as usize
                || normal.len() != color.len()
            {
                return Err(bad(format!("mip {m} has the wrong size")));
            }
            levels.push(TileLevel {
                size,
                color,
                normal,
            });
        }
        Ok(levels)
    }
}

impl TileImage {
    /// Coverage: the mean alpha.
    pub fn coverage(&self) -> f32 {
        self.color.iter().map(|c| c[3]).sum::<f32>() / self.color.len().max(1) as f32
    }

    /// Resolves a `size·ss` square block of `stride`-wide raw samples starting at column
    /// `x0`: raw colour is (albedo, 1) where a surface was hit and 0 elsewhere; raw
    /// normal/depth is (n, depth).
    pub fn resolve(
        raw_color: &[[f32; 4]],
        raw_normal: &[[f32; 4]],
        stride: usize,
        x0: usize,
        size: u32,
        ss: u32,
    ) -> Self {
        let (n, ss) = (size as usize, ss as usize);
        let inv = 1.0 / (ss * ss) as f32;
        let mut color = vec![[0.0; 4]; n * n];
        let mut normal_depth = vec![[0.0; 4]; n * n];
        for y in 0..n {
            for x in 0..n {
                let mut c = [0.0f32; 4];
                let mut nd = [0.0f32; 4];
                for sy in 0..ss {
                    for sx in 0..ss {
                        let i = (y * ss + sy) * stride + x0 + x * ss + sx;
                        let (rc, rn) = (raw_color[i], raw_normal[i]);
                        if rc[3] > 0.0 {
                            for k in 0..4 {
                                c[k] += rc[k];
                                nd[k] += rn[k];
                            }
                        }
                    }
                }
                let hits = c[3];
                color[y * n + x] = c.map(|v| v * inv);
                if hits > 0.0 {
                    normal_depth[y * n + x] = normalise(nd, hits);
                }
            }
        }
        Self {
            size,
            color,
            normal_depth,
        }
    }

    /// The full mip chain down to 1×1, quantised.
    pub fn levels(&self) -> Vec<TileLevel> {
        let mut out = Vec::new();
        let mut level = self.clone();
        loop {
            let mut filled = level.normal_depth.clone();
            dilate(&level.color, &mut filled, level.size as usize);
            out.push(TileLevel {
                size: level.size,
                color: level
                    .color
                    .iter()
                    .flat_map(|c| [srgb8(c[0]), srgb8(c[1]), srgb8(c[2]), unorm8(c[3])])
                    .collect(),
                normal: filled
                    .iter()
                    .flat_map(|n| {
                        [
                            unorm8(n[0] * 0.5 + 0.5),
                            unorm8(n[1] * 0.5 + 0.5),
                            unorm8(n[2] * 0.5 + 0.5),
                            unorm8(n[3]),
                        ]
                    })
                    .collect(),
            });
            if level.size == 1 {
                return out;
            }
            level = level.half();
        }
    }

    /// The next mip: colour box-filtered (it is premultiplied), normal/depth averaged weighted
    /// by coverage.
    fn half(&self) -> Self {
        let (n, h) = (self.size as usize, (self.size as usize / 2).max(1));
        let mut color = vec![[0.0; 4]; h * h];
        let mut normal_depth = vec![[0.0; 4]; h * h];
        for y in 0..h {
            for x in 0..h {
                let mut c = [0.0f32; 4];
                let mut nd = [0.0f32; 4];
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let i = ((2 * y + dy).min(n - 1)) * n + (2 * x + dx).min(n - 1);
                    let a = self.color[i][3];
                    for k in 0..4 {
                        c[k] += self.color[i][k] * 0.25;
                        nd[k] += self.normal_depth[i][k] * a;
                    }
                }
                color[y * h + x] = c;
                if c[3] > 0.0 {
                    normal_depth[y * h + x] = normalise(nd, c[3] * 4.0);
                }
            }
        }
        Self {
            size: h as u32,
            color,
            normal_depth,
        }
    }
}

/// Normal renormalised, depth divided by the weight.
fn normalise(nd: [f32; 4], weight: f32) -> [f32; 4] {
    let len = (nd[0] * nd[0] + nd[1] * nd[1] + nd[2] * nd[2]).sqrt();
    let (x, y, z) = if len > 1e-6 {
        (nd[0] / len, nd[1] / len, nd[2] / len)
    } else {
        (0.0, 1.0, 0.0)
    };
    [x, y, z, (nd[3] / weight).clamp(0.0, 1.0)]
}

/// Fills texels without coverage from covered neighbours, ring by ring (up to 8 rings, then
/// the tile's mean), so bilinear filtering at silhouettes reads plausible normals and depths.
fn dilate(color: &[[f32; 4]], nd: &mut [[f32; 4]], n: usize) {
    let mut known: Vec<bool> = color.iter().map(|c| c[3] > 0.0).collect();
    if !known.iter().any(|&k| k) {
        nd.fill([0.0, 1.0, 0.0, 0.5]);
        return;
    }
    for _ in 0..8 {
        let mut next = known.clone();
        let mut changed = false;
        for y in 0..n {
            for x in 0..n {
                if known[y * n + x] {
                    continue;
                }
                let mut acc = [0.0f32; 4];
                let mut cnt = 0.0;
                for (dx, dy) in [
                    (-1i32, 0i32),
                    (1, 0),
                    (0, -1),
                    (0, 1),
                    (-1, -1),
                    (1, 1),
                    (-1, 1),
                    (1, -1),
                ] {
                    let (sx, sy) = (x as i32 + dx, y as i32 + dy);
                    if sx < 0 || sy < 0 || sx >= n as i32 || sy >= n as i32 {
                        continue;
                    }
                    let j = sy as usize * n + sx as usize;
                    if known[j] {
                        for k in 0..4 {
                            acc[k] += nd[j][k];
                        }
                        cnt += 1.0;
                    }
                }
                if cnt > 0.0 {
                    nd[y * n + x] = normalise(acc, cnt);
                    next[y * n + x] = true;
                    changed = true;
                }
            }
        }
        known = next;
        if !changed {
            break;
        }
    }
    let (mut mean, mut cnt) = ([0.0f32; 4], 0.0);
    for (v, k) in nd.iter().zip(&known) {
        if *k {
            for c in 0..4 {
                mean[c] += v[c];
            }
            cnt += 1.0;
        }
    }
    let mean = normalise(mean, cnt);
    for (v, k) in nd.iter_mut().zip(&known) {
        if !*k {
            *v = mean;
        }
    }
}

fn unorm8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// A linear value in [0, 1] as an 8-bit sRGB code.
pub(crate) fn srgb8(linear: f32) -> u8 {
    let l = linear.clamp(0.0, 1.0);
    let s = if l <= 0.003_130_8 {
        l * 12.92
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    };
    unorm8(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn half_covered(size: u32) -> TileImage {
        let n = size as usize;
        let mut color = vec![[0.0; 4]; n * n];
        let mut nd = vec![[0.0; 4]; n * n];
        for y in 0..n {
            for x in 0..n / 2 {
                color[y * n + x] = [0.2, 0.4, 0.1, 1.0];
                nd[y * n + x] = [0.0, 0.0, 1.0, 0.25];
            }
        }
        TileImage {
            size,
            color,
            normal_depth: nd,
        }
    }

    #[test]
    fn mips_preserve_coverage_and_colour() {
        let t = half_covered(16);
        let levels = t.levels();
        assert_eq!(levels.len(), 5);
        for l in &levels {
            let a: f32 = l.color.chunks(4).map(|p| p[3] as f32 / 255.0).sum::<f32>()
                / (l.size * l.size) as f32;
            assert!((a - 0.5).abs() < 0.01, "level {} coverage {a}", l.size);
        }
        // 1×1: premultiplied green 0.4 × 0.5 coverage = 0.2 linear.
        let g = levels[4].color[1] as f32 / 255.0;
        let lin = ((g + 0.055) / 1.055).powf(2.4);
        assert!((lin - 0.2).abs() < 0.01, "{lin}");
    }

    #[test]
    fn dilation_fills_uncovered_normals() {
        let levels = half_covered(8).levels();
        // Every texel, covered or not, carries the covered normal (0, 0, 1) and depth 0.25.
        for p in levels[0].normal.chunks(4) {
            assert_eq!(&p[..3], &[128, 128, 255]);
            assert_eq!(p[3], 64);
        }
    }

    #[test]
    fn resolve_averages_supersamples() {
        // 2×2 samples for one texel, one covered.
        let raw_c = vec![[0.5, 0.5, 0.5, 1.0], [0.0; 4], [0.0; 4], [0.0; 4]];
        let raw_n = vec![[1.0, 0.0, 0.0, 0.5], [0.0; 4], [0.0; 4], [0.0; 4]];
        let t = TileImage::resolve(&raw_c, &raw_n, 2, 0, 1, 2);
        assert_eq!(t.color[0], [0.125, 0.125, 0.125, 0.25]);
        assert_eq!(t.normal_depth[0], [1.0, 0.0, 0.0, 0.5]);
    }
}
