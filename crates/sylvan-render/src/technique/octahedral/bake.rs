//! The hemi-octahedral view grid (CPU side; `octahedral.wgsl` mirrors `hemi_oct_encode` and
//! `view_weights`), and the bake: one orthographic tile per grid view through the shared baker.

use super::OctahedralBakeParams;
use crate::RenderError;
use crate::bake::codec::{DecodeError, Decoder, Encoder};
use crate::bake::image::TileLevel;
use crate::bake::views::PlaneFrame;
use crate::bake::{BakeRequest, PlantBaker};
use crate::technique::params::ParamTable;
use glam::{Vec2, Vec3};
use sylvan_gpu::Gpu;
use sylvan_plant::Plant;

/// Bumped whenever the payload below or the baker's output changes.
pub const FORMAT_VERSION: u32 = 1;

/// Unit direction (y up, `y ≥ 0`; lower directions are folded onto the horizon) → point of the
/// hemi-octahedral square `[-1, 1]²`: `(x, z) / (|x| + |y| + |z|)` rotated by 45° so the
/// diamond `|x| + |z| ≤ 1` fills the square. The square's border is the horizon.
pub fn hemi_oct_encode(d: Vec3) -> Vec2 {
    let d = Vec3::new(d.x, d.y.max(0.0), d.z);
    let p = Vec2::new(d.x, d.z) / (d.x.abs() + d.y + d.z.abs()).max(1e-9);
    Vec2::new(p.x + p.y, p.x - p.y)
}

/// The inverse of [`hemi_oct_encode`]: a point of `[-1, 1]²` → unit direction with `y ≥ 0`.
pub fn hemi_oct_decode(e: Vec2) -> Vec3 {
    let (x, z) = ((e.x + e.y) * 0.5, (e.x - e.y) * 0.5);
    Vec3::new(x, 1.0 - x.abs() - z.abs(), z).normalize()
}

/// Direction of grid view `(i, j)` of a `grid × grid` grid (views at the grid's corners, so
/// `i = 0` and `i = grid − 1` lie on the horizon).
pub fn grid_direction(grid: u32, i: u32, j: u32) -> Vec3 {
    let s = 2.0 / (grid - 1) as f32;
    hemi_oct_decode(Vec2::new(i as f32 * s - 1.0, j as f32 * s - 1.0))
}

/// The 3 grid views `(i, j)` whose blend shows direction `d`, with barycentric weights (≥ 0,
/// sum 1): the corners of the triangle of `d`'s grid cell (split along its (0,0)–(1,1)
/// diagonal) that contains it. On a grid direction one weight is 1.
pub fn view_weights(grid: u32, d: Vec3) -> [((u32, u32), f32); 3] {
    let n = (grid - 1) as f32;
    let g = ((hemi_oct_encode(d) + 1.0) * 0.5 * n).clamp(Vec2::ZERO, Vec2::splat(n));
    let cell = g.floor().min(Vec2::splat(n - 1.0));
    let f = g - cell;
    let (i, j) = (cell.x as u32, cell.y as u32);
    if f.x + f.y < 1.0 {
        [
            ((i, j), 1.0 - f.x - f.y),
            ((i + 1, j), f.x),
            ((i, j + 1), f.y),
        ]
    } else {
        [
            ((i + 1, j + 1), f.x + f.y - 1.0),
            ((i + 1, j), 1.0 - f.y),
            ((i, j + 1), 1.0 - f.x),
        ]
    }
}

/// The shared frame of every view: the square enclosing the bounding box's circumscribed
/// sphere, seen along `dir`.
pub fn view_frame(plant: &Plant, dir: Vec3) -> PlaneFrame {
    let (min, max) = (Vec3::from(plant.bbox_min), Vec3::from(plant.bbox_max));
    PlaneFrame::for_sphere(dir, (min + max) * 0.5, (max - min).length() * 0.5)
}

/// The baked asset of one plant.
#[derive(Debug, Clone, PartialEq)]
pub struct OctahedralBaked {
    /// Views per grid side.
    pub grid: u32,
    /// Tile size in texels.
    pub tile: u32,
    /// Model-space centre of the frames (the bounding-box centre).
    pub centre: [f32; 3],
    /// Half side (and half depth) of every frame: the bounding sphere's radius.
    pub radius: f32,
    /// `tiles[j * grid + i]`: the mip chain of view `(i, j)`.
    pub tiles: Vec<Vec<TileLevel>>,
}

impl OctahedralBaked {
    /// Bytes of image data (all mips, colour and normal).
    pub fn image_bytes(&self) -> u64 {
        self.tiles
            .iter()
            .flatten()
            .map(|l| (l.color.len() + l.normal.len()) as u64)
            .sum()
    }
}

/// `octahedral`'s offline half: one plant's grid of views.
pub struct OctahedralBake;

impl crate::bake::Bake for OctahedralBake {
    const NAME: &'static str = "octahedral";
    const FORMAT_VERSION: u32 = FORMAT_VERSION;
    type Params = OctahedralBakeParams;
    type Asset = OctahedralBaked;

    fn describe(b: &OctahedralBaked) -> crate::bake::AssetSummary {
        let mut fields = serde_json::Map::new();
        fields.insert("grid".into(), b.grid.into());
        fields.insert("views".into(), b.tiles.len().into());
        crate::bake::AssetSummary {
            line: format!(
                "{} views ({}×{} grid) of {}²",
                b.tiles.len(),
                b.grid,
                b.grid,
                b.tile
            ),
            image_bytes: b.image_bytes(),
            images: b.tiles.len(),
            tile: b.tile,
            fields,
        }
    }

    /// Bakes `plant`: every grid view, whole plant (wood and leaves), through the shared baker.
    fn bake(
        gpu: &Gpu,
        plant: &Plant,
        p: &OctahedralBakeParams,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<OctahedralBaked, RenderError> {
        let requests: Vec<BakeRequest> = (0..p.grid * p.grid)
            .map(|k| {
                let d = grid_direction(p.grid, k % p.grid, k / p.grid);
                BakeRequest::whole(plant, view_frame(plant, d))
            })
            .collect();
        let frame = requests[0].frame;
        let baker = PlantBaker::new(gpu, plant, p.tile, p.supersample)?;
        let total = requests.len();
        let images = baker.bake(gpu, &requests, |done| progress(done, total))?;
        Ok(OctahedralBaked {
            grid: p.grid,
            tile: p.tile,
            centre: frame.centre.to_array(),
            radius: frame.half.x,
            tiles: images.iter().map(|t| t.levels()).collect(),
        })
    }
}

impl crate::bake::codec::Codec for OctahedralBaked {
    /// The payload written to the cache.
    fn encode(&self) -> Vec<u8> {
        let mut e = Encoder::default();
        e.u32(self.grid);
        e.u32(self.tile);
        e.f32s(&self.centre);
        e.f32(self.radius);
        e.u64(self.tiles.len() as u64);
        for levels in &self.tiles {
            TileLevel::encode_chain(&mut e, levels);
        }
        e.buf
    }

    /// Reads a payload back, checking every count and size.
    fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        let bad = |m: String| DecodeError(m);
        let mut d = Decoder::new(bytes);
        let grid = d.u32()?;
        let tile = d.u32()?;
        let p = OctahedralBakeParams {
            grid,
            tile,
            supersample: 1,
        };
        p.validate().map_err(bad)?;
        let centre: [f32; 3] = d
            .f32s()?
            .try_into()
            .map_err(|_| bad("centre is not 3 floats".into()))?;
        let radius = d.f32()?;
        if !(radius.is_finite() && radius > 0.0) || centre.iter().any(|c| !c.is_finite()) {
            return Err(bad(format!("frame radius {radius} or centre is not valid")));
        }
        let n = d.u64()?;
        if n != (grid * grid) as u64 {
            return Err(bad(format!("{n} tiles for a {grid}×{grid} grid")));
        }
        let tiles = (0..n)
            .map(|_| TileLevel::decode_chain(&mut d, tile))
            .collect::<Result<Vec<_>, _>>()?;
        d.finish()?;
        Ok(Self {
            grid,
            tile,
            centre,
            radius,
            tiles,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn directions() -> Vec<Vec3> {
        let mut s = 7u32;
        let mut rnd = || {
            s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (s >> 8) as f32 / (1u32 << 24) as f32
        };
        (0..2000)
            .map(|_| {
                let (z, a) = (rnd(), rnd() * std::f32::consts::TAU);
                let r = (1.0 - z * z).sqrt();
                Vec3::new(r * a.cos(), z, r * a.sin())
            })
            .collect()
    }

    #[test]
    fn encode_decode_round_trip() {
        for d in directions() {
            let back = hemi_oct_decode(hemi_oct_encode(d));
            assert!((back - d).length() < 1e-5, "{d} -> {back}");
            let e = hemi_oct_encode(d);
            assert!(e.abs().max_element() <= 1.0 + 1e-6, "{e}");
        }
        // The border is the horizon, the centre the zenith.
        assert!(hemi_oct_decode(Vec2::new(1.0, 0.3)).y.abs() < 1e-6);
        assert!((hemi_oct_decode(Vec2::ZERO) - Vec3::Y).length() < 1e-6);
        // Below the horizon folds onto it.
        assert!(
            hemi_oct_decode(hemi_oct_encode(Vec3::new(0.6, -0.8, 0.0)))
                .y
                .abs()
                < 1e-6
        );
    }

    #[test]
    fn weights_are_a_partition_of_unity_and_exact_on_grid_views() {
        for grid in [4, 5, 8, 16, 32] {
            for d in directions() {
                let w = view_weights(grid, d);
                let sum: f32 = w.iter().map(|x| x.1).sum();
                assert!((sum - 1.0).abs() < 1e-5, "{sum}");
                for ((i, j), x) in w {
                    assert!(x >= -1e-6 && i < grid && j < grid, "{i} {j} {x}");
                }
                // The blend of the views' grid points is d's grid point.
                let g = w.iter().fold(Vec2::ZERO, |a, ((i, j), x)| {
                    a + Vec2::new(*i as f32, *j as f32) * *x
                });
                let want = (hemi_oct_encode(d) + 1.0) * 0.5 * (grid - 1) as f32;
                assert!((g - want).length() < 1e-3, "{g} {want}");
            }
            for j in 0..grid {
                for i in 0..grid {
                    let w = view_weights(grid, grid_direction(grid, i, j));
                    let top = w.iter().find(|x| x.0 == (i, j)).map_or(0.0, |x| x.1);
                    assert!(top > 1.0 - 1e-4, "grid {grid} view ({i}, {j}): {w:?}");
                }
            }
        }
    }
}
