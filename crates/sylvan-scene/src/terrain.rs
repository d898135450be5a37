//! Terrain queries (bilinear height, normal, extent) and seeded procedural generation: fBm mixed
//! with ridged multifractal noise, rescaled so peak-to-valley equals the requested relief.

use crate::noise;
use crate::types::Terrain;
use glam::Vec3;

/// Target grid spacing of procedural terrain, metres per sample.
pub const PROCEDURAL_SPACING_M: f32 = 5.0;
/// Most samples along one side of a procedural terrain (coarser spacing beyond).
pub const MAX_PROCEDURAL_RESOLUTION: u32 = 1025;
/// Most height samples in any terrain (heightmaps included): 64 Mi samples, 256 MiB of `f32`.
pub const MAX_TERRAIN_SAMPLES: u64 = 64 * 1024 * 1024;
/// Largest terrain extent along X or Z, metres.
pub const MAX_TERRAIN_SIZE_M: f32 = 500_000.0;

/// Parameters of a procedural terrain (`[terrain] procedural = { … }`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProceduralTerrain {
    /// Noise seed.
    pub seed: u64,
    /// Extent along X and Z, metres.
    pub size_m: [f32; 2],
    /// Peak-to-valley height difference, metres (heights span [0, relief_m]).
    pub relief_m: f32,
}

impl ProceduralTerrain {
    /// Grid resolution: one sample per [`PROCEDURAL_SPACING_M`], at most
    /// [`MAX_PROCEDURAL_RESOLUTION`] per side, at least 2.
    pub fn resolution(&self) -> [u32; 2] {
        self.size_m.map(|s| {
            let n = (s / PROCEDURAL_SPACING_M).ceil() as u32 + 1;
            n.clamp(2, MAX_PROCEDURAL_RESOLUTION)
        })
    }

    /// Generate the height grid. Deterministic for the same parameters.
    pub fn generate(&self) -> Terrain {
        let res = self.resolution();
        let [w, h] = res.map(|n| n as usize);
        // Hills a few hundred metres across, whatever the extent; a small terrain is one hill.
        let wavelength = (self.size_m[0].max(self.size_m[1]) as f64 / 2.0).clamp(50.0, 900.0);
        let spacing = (self.size_m[0] / (w - 1) as f32).max(self.size_m[1] / (h - 1) as f32);
        // Octaves down to about two grid cells.
        let octaves = ((wavelength / (2.0 * spacing as f64)).log2().floor() as i32 + 1).clamp(1, 8);
        let octaves = octaves as u32;
        let (seed, ridge_seed) = (self.seed, self.seed ^ 0xD1B5_4A32_D192_ED03);
        let mut heights = Vec::with_capacity(w * h);
        for row in 0..h {
            let z = row as f64 / (h - 1) as f64 * self.size_m[1] as f64 / wavelength;
            for col in 0..w {
                let x = col as f64 / (w - 1) as f64 * self.size_m[0] as f64 / wavelength;
                let rolling = noise::fbm(seed, x, z, octaves, 0.5);
                let ridges = noise::ridged(ridge_seed, x * 0.7, z * 0.7, octaves.min(5));
                heights.push((0.6 * rolling + 0.8 * ridges) as f32);
            }
        }
        let (lo, hi) = min_max(&heights);
        let scale = if hi > lo {
            self.relief_m / (hi - lo)
        } else {
            0.0
        };
        for v in &mut heights {
            *v = (*v - lo) * scale;
        }
        Terrain {
            size: self.size_m,
            resolution: res,
            heights,
        }
    }
}

fn min_max(v: &[f32]) -> (f32, f32) {
    v.iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &h| {
            (lo.min(h), hi.max(h))
        })
}

impl Terrain {
    /// A flat terrain at height `y`.
    pub fn flat(size: [f32; 2], y: f32) -> Self {
        Self {
            size,
            resolution: [2, 2],
            heights: vec![y; 4],
        }
    }

    /// A seeded procedural terrain (see [`ProceduralTerrain`]).
    pub fn procedural(seed: u64, size_m: [f32; 2], relief_m: f32) -> Self {
        ProceduralTerrain {
            seed,
            size_m,
            relief_m,
        }
        .generate()
    }

    /// Metres between neighbouring samples along X and Z.
    pub fn cell_size(&self) -> [f32; 2] {
        [
            self.size[0] / (self.resolution[0] - 1) as f32,
            self.size[1] / (self.resolution[1] - 1) as f32,
        ]
    }

    /// The height sample at column `col` (X) and row `row` (Z), clamped to the grid.
    pub fn sample(&self, col: u32, row: u32) -> f32 {
        let c = col.min(self.resolution[0] - 1) as usize;
        let r = row.min(self.resolution[1] - 1) as usize;
        self.heights[r * self.resolution[0] as usize + c]
    }

    /// Whether `(x, z)` lies on the terrain (edges included).
    pub fn contains(&self, x: f32, z: f32) -> bool {
        (0.0..=self.size[0]).contains(&x) && (0.0..=self.size[1]).contains(&z)
    }

    /// Height at `(x, z)`, bilinear between samples; positions outside are clamped to the edge.
    /// Exact at grid points.
    pub fn height_at(&self, x: f32, z: f32) -> f32 {
        bilinear(&self.heights, self.resolution, self.size, x, z)
    }

    /// Unit surface normal at `(x, z)` from central differences one cell apart.
    pub fn normal_at(&self, x: f32, z: f32) -> Vec3 {
        let [dx, dz] = self.cell_size();
        let (x, z) = (x.clamp(0.0, self.size[0]), z.clamp(0.0, self.size[1]));
        let (x0, x1) = ((x - dx).max(0.0), (x + dx).min(self.size[0]));
        let (z0, z1) = ((z - dz).max(0.0), (z + dz).min(self.size[1]));
        let sx = (self.height_at(x1, z) - self.height_at(x0, z)) / (x1 - x0);
        let sz = (self.height_at(x, z1) - self.height_at(x, z0)) / (z1 - z0);
        Vec3::new(-sx, 1.0, -sz).normalize()
    }

    /// Lowest and highest sample, metres.
    pub fn min_max(&self) -> (f32, f32) {
        min_max(&self.heights)
    }

    /// An upper bound of the surface's slope (rise over run) anywhere: the steepest step between
    /// neighbouring samples along X and along Z, combined. Bounds the bilinear surface and any
    /// triangulation of the grid (each triangle's gradient is made of one X and one Z step).
    pub fn max_slope(&self) -> f32 {
        let [w, h] = self.resolution.map(|r| r as usize);
        let [dx, dz] = self.cell_size();
        let (mut gx, mut gz) = (0.0f32, 0.0f32);
        for r in 0..h {
            for c in 0..w {
                let v = self.heights[r * w + c];
                if c + 1 < w {
                    gx = gx.max((self.heights[r * w + c + 1] - v).abs());
                }
                if r + 1 < h {
                    gz = gz.max((self.heights[(r + 1) * w + c] - v).abs());
                }
            }
        }
        (gx / dx).hypot(gz / dz)
    }
}

/// Bilinear lookup in a row-major grid covering `[0, size[0]] × [0, size[1]]` with samples on the
/// edges (column 0 at X = 0, last column at X = size[0]); clamped outside. Shared with density
/// maps.
pub(crate) fn bilinear(values: &[f32], res: [u32; 2], size: [f32; 2], x: f32, z: f32) -> f32 {
    let w = res[0] as usize;
    let fx = ((x / size[0]).clamp(0.0, 1.0) * (res[0] - 1) as f32).max(0.0);
    let fz = ((z / size[1]).clamp(0.0, 1.0) * (res[1] - 1) as f32).max(0.0);
    let (c0, r0) = (fx.floor() as usize, fz.floor() as usize);
    let c1 = (c0 + 1).min(w - 1);
    let r1 = (r0 + 1).min(res[1] as usize - 1);
    let (tx, tz) = (fx - c0 as f32, fz - r0 as f32);
    let at = |c: usize, r: usize| values[r * w + c];
    let top = at(c0, r0) + (at(c1, r0) - at(c0, r0)) * tx;
    let bottom = at(c0, r1) + (at(c1, r1) - at(c0, r1)) * tx;
    top + (bottom - top) * tz
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn max_slope_bounds_every_cell() {
        assert_eq!(Terrain::flat([100.0, 100.0], 3.0).max_slope(), 0.0);
        let t = Terrain {
            size: [20.0, 10.0],
            resolution: [3, 2],
            heights: vec![0.0, 1.0, 2.0, 10.0, 11.0, 12.0],
        };
        // Steps of 1 m over 10 m along X and 10 m over 10 m along Z.
        assert!((t.max_slope() - 0.1f32.hypot(1.0)).abs() < 1e-6);
        let p = Terrain::procedural(7, [2000.0, 2000.0], 300.0);
        let g = p.max_slope();
        for i in 0..500 {
            let (x, z) = ((i * 37 % 1999) as f32 + 0.5, (i * 91 % 1999) as f32 + 0.25);
            let (a, b) = (p.height_at(x, z), p.height_at(x + 0.7, z - 0.4));
            assert!((a - b).abs() <= g * 0.7f32.hypot(0.4) * 1.0001, "{i}");
        }
    }

    #[test]
    fn height_at_is_exact_at_grid_points_and_bilinear_between() {
        let t = Terrain {
            size: [20.0, 10.0],
            resolution: [3, 2],
            heights: vec![0.0, 1.0, 2.0, 10.0, 11.0, 12.0],
        };
        assert_eq!(t.height_at(0.0, 0.0), 0.0);
        assert_eq!(t.height_at(10.0, 0.0), 1.0);
        assert_eq!(t.height_at(20.0, 10.0), 12.0);
        assert_eq!(t.height_at(10.0, 10.0), 11.0);
        assert!((t.height_at(5.0, 5.0) - 5.5).abs() < 1e-5);
        // Clamped outside.
        assert_eq!(t.height_at(-5.0, -5.0), 0.0);
        assert_eq!(t.height_at(99.0, 99.0), 12.0);
        assert_eq!(t.min_max(), (0.0, 12.0));
    }

    #[test]
    fn normal_tilts_away_from_the_slope() {
        let t = Terrain {
            size: [10.0, 10.0],
            resolution: [2, 2],
            heights: vec![0.0, 10.0, 0.0, 10.0],
        };
        let n = t.normal_at(5.0, 5.0);
        assert!((n.length() - 1.0).abs() < 1e-5);
        assert!(n.x < -0.5 && n.z.abs() < 1e-5, "{n}");
        assert_eq!(Terrain::flat([5.0, 5.0], 2.0).normal_at(1.0, 1.0), Vec3::Y);
    }

    #[test]
    fn procedural_spans_the_relief_and_is_deterministic() {
        let p = ProceduralTerrain {
            seed: 7,
            size_m: [1000.0, 600.0],
            relief_m: 150.0,
        };
        assert_eq!(p.resolution(), [201, 121]);
        let a = p.generate();
        let b = p.generate();
        assert_eq!(a.heights, b.heights);
        let (lo, hi) = a.min_max();
        assert!(lo.abs() < 1e-3 && (hi - 150.0).abs() < 1e-3);
        let c = ProceduralTerrain { seed: 8, ..p }.generate();
        assert_ne!(a.heights, c.heights);
        let big = ProceduralTerrain {
            seed: 1,
            size_m: [100_000.0, 100.0],
            relief_m: 1.0,
        };
        assert_eq!(big.resolution(), [MAX_PROCEDURAL_RESOLUTION, 21]);
    }
}
