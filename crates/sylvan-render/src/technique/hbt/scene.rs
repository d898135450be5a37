//! MNP01 §3.3 at the top level: each placed tree's visibility cube-maps of the rest of the
//! scene (the other trees, through their baked coverage, and the terrain), built once when the
//! scene is placed; per frame, the sun's direction is looked up in them (only when the sun
//! moves) and the sky transmittance is read from a table.

use super::visibility::{self, Coverage, Horizon, Occluder};
use glam::{Affine3A, Vec3};
use sylvan_scene::Terrain;

/// Occluders farther than this from a corner (bounding sphere to corner) are ignored, in units
/// of the largest tree's bounding radius.
const REACH_RADII: f32 = 5.0;
/// At most this many occluders per corner, nearest first.
const MAX_OCCLUDERS: usize = 48;

/// One placed tree as the visibility pass sees it.
#[derive(Debug, Clone, Copy)]
pub struct PlacedTree {
    /// Its species (index into the coverages).
    pub species: usize,
    /// Model → world (rotation about Y, uniform scale, translation).
    pub to_world: Affine3A,
}

impl PlacedTree {
    /// From a GPU instance record: trunk base and scale, cos/sin of the rotation about Y.
    pub fn from_record(species: usize, base_scale: [f32; 4], rot: [f32; 4]) -> Self {
        let (c, s, k) = (rot[0], rot[1], base_scale[3]);
        Self {
            species,
            to_world: Affine3A::from_cols(
                (Vec3::new(c, 0.0, -s) * k).into(),
                (Vec3::Y * k).into(),
                (Vec3::new(s, 0.0, c) * k).into(),
                Vec3::new(base_scale[0], base_scale[1], base_scale[2]).into(),
            ),
        }
    }
}

/// The top level of the visibility hierarchy for every placed tree.
pub struct SceneVisibility {
    res: usize,
    /// Per tree, 8 cube-maps of `6·res²` opacities.
    cubes: Vec<u8>,
    /// Per tree, per corner: sky transmittance (0–255).
    sky: Vec<[u8; 8]>,
    /// Per tree, per corner: sun transmittance for `sun` (0–255).
    sun_vis: Vec<[u8; 8]>,
    sun: Option<Vec3>,
    /// Per tree: model → world.
    trees: Vec<PlacedTree>,
    /// Per species: model bounding box.
    boxes: Vec<(Vec3, Vec3)>,
    /// Time taken to build, milliseconds.
    pub build_ms: f64,
}

impl SceneVisibility {
    /// Builds every tree's 8 cube-maps (`res²` per face) against the other trees (each through
    /// its species' coverage) and `terrain`.
    pub fn build(
        trees: &[PlacedTree],
        coverages: &[Coverage<'_>],
        terrain: Option<&Terrain>,
        res: usize,
    ) -> Self {
        let start = std::time::Instant::now();
        let occluders: Vec<Occluder> = trees
            .iter()
            .map(|t| Occluder::new(&coverages[t.species], t.to_world))
            .collect();
        let reach = occluders.iter().map(|o| o.radius).fold(1.0f32, f32::max) * REACH_RADII;
        let grid = Grid::new(&occluders, reach);
        let layout = visibility::CubeLayout::new(res);
        let dirs = &layout.dirs;
        let per = dirs.len() * visibility::CORNERS;
        let mut cubes = vec![0u8; trees.len() * per];
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        let chunk_trees = trees.len().div_ceil(threads).max(1);
        std::thread::scope(|scope| {
            for (c, part) in cubes.chunks_mut(chunk_trees * per).enumerate() {
                let (occluders, layout, grid) = (&occluders, &layout, &grid);
                let dirs = &layout.dirs;
                scope.spawn(move || {
                    let mut open = Vec::new();
                    let mut near: Vec<(f32, usize)> = Vec::new();
                    let mut list: Vec<&Occluder> = Vec::new();
                    for (k, maps) in part.chunks_mut(per).enumerate() {
                        let t = c * chunk_trees + k;
                        let cov = &coverages[trees[t].species];
                        for (corner, map) in maps.chunks_mut(dirs.len()).enumerate() {
                            let at = trees[t]
                                .to_world
                                .transform_point3(visibility::corner(cov.min, cov.max, corner));
                            near.clear();
                            grid.around(at, |q| {
                                if q == t {
                                    return;
                                }
                                let o = &occluders[q];
                                let gap = o.centre.distance(at) - o.radius;
                                if gap < reach {
                                    near.push((gap, q));
                                }
                            });
                            near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
                            near.truncate(MAX_OCCLUDERS);
                            list.clear();
                            list.extend(near.iter().map(|&(_, q)| &occluders[q]));
                            let horizon = terrain.map(|tr| Horizon::trace(tr, at));
                            visibility::render(at, &list, horizon.as_ref(), layout, &mut open, map);
                        }
                    }
                });
            }
        });
        let sky = cubes
            .chunks(per)
            .map(|maps| {
                let mut out = [0u8; 8];
                for (o, map) in out.iter_mut().zip(maps.chunks(dirs.len())) {
                    *o = (visibility::sky_transmittance(map, dirs) * 255.0).round() as u8;
                }
                out
            })
            .collect();
        Self {
            res,
            cubes,
            sky,
            sun_vis: vec![[255; 8]; trees.len()],
            sun: None,
            trees: trees.to_vec(),
            boxes: coverages.iter().map(|c| (c.min, c.max)).collect(),
            build_ms: start.elapsed().as_secs_f64() * 1e3,
        }
    }

    /// Looks `sun` (unit, towards the sun) up in every cube-map when it moved.
    pub fn set_sun(&mut self, sun: Vec3) {
        if self.sun.is_some_and(|s| s.abs_diff_eq(sun, 1e-6)) {
            return;
        }
        self.sun = Some(sun);
        let per = 6 * self.res * self.res;
        for (t, out) in self.sun_vis.iter_mut().enumerate() {
            for (k, o) in out.iter_mut().enumerate() {
                let map = &self.cubes[(t * 8 + k) * per..(t * 8 + k + 1) * per];
                let opacity = visibility::lookup(map, self.res, sun);
                *o = ((1.0 - opacity) * 255.0).round() as u8;
            }
        }
    }

    /// Tree `t`'s sun transmittance per corner (for the last [`Self::set_sun`]).
    pub fn sun(&self, t: usize) -> [u8; 8] {
        self.sun_vis.get(t).copied().unwrap_or([255; 8])
    }

    /// Tree `t`'s sky transmittance per corner.
    pub fn sky(&self, t: usize) -> [u8; 8] {
        self.sky.get(t).copied().unwrap_or([255; 8])
    }

    /// Tree `t`'s model → world transform and its species' model box.
    pub fn tree(&self, t: usize) -> Option<(&PlacedTree, (Vec3, Vec3))> {
        let tree = self.trees.get(t)?;
        Some((tree, *self.boxes.get(tree.species)?))
    }

    /// Trees covered.
    pub fn len(&self) -> usize {
        self.trees.len()
    }

    /// Whether no tree is covered.
    pub fn is_empty(&self) -> bool {
        self.trees.is_empty()
    }

    /// Bytes of the cube-maps and tables.
    pub fn bytes(&self) -> u64 {
        (self.cubes.len() + self.sky.len() * 8 + self.sun_vis.len() * 8) as u64
    }
}

/// Trilinear interpolation of 8 per-corner values (corner `k`: bit 0 x, bit 1 y, bit 2 z) at
/// `q` in [0, 1]³.
pub fn trilinear(v: [f32; 8], q: Vec3) -> f32 {
    let q = q.clamp(Vec3::ZERO, Vec3::ONE);
    let x = |a: f32, b: f32| a + (b - a) * q.x;
    let c00 = x(v[0], v[1]);
    let c10 = x(v[2], v[3]);
    let c01 = x(v[4], v[5]);
    let c11 = x(v[6], v[7]);
    let c0 = c00 + (c10 - c00) * q.y;
    let c1 = c01 + (c11 - c01) * q.y;
    c0 + (c1 - c0) * q.z
}

/// A uniform grid over x/z of the occluders' bounding spheres.
struct Grid {
    cell: f32,
    origin: (f32, f32),
    dims: (usize, usize),
    cells: Vec<Vec<usize>>,
    reach: f32,
}

impl Grid {
    fn new(occluders: &[Occluder], reach: f32) -> Self {
        let cell = reach.max(1.0);
        let (mut lo, mut hi) = ((f32::MAX, f32::MAX), (f32::MIN, f32::MIN));
        for o in occluders {
            lo = (lo.0.min(o.centre.x), lo.1.min(o.centre.z));
            hi = (hi.0.max(o.centre.x), hi.1.max(o.centre.z));
        }
        if occluders.is_empty() {
            (lo, hi) = ((0.0, 0.0), (0.0, 0.0));
        }
        let dims = (
            (((hi.0 - lo.0) / cell) as usize + 1).min(4096),
            (((hi.1 - lo.1) / cell) as usize + 1).min(4096),
        );
        let mut cells = vec![Vec::new(); dims.0 * dims.1];
        let mut g = Self {
            cell,
            origin: lo,
            dims,
            cells: Vec::new(),
            reach,
        };
        for (i, o) in occluders.iter().enumerate() {
            let (x, z) = g.index(o.centre);
            cells[z * dims.0 + x].push(i);
        }
        g.cells = cells;
        g
    }

    fn index(&self, p: Vec3) -> (usize, usize) {
        let x = ((p.x - self.origin.0) / self.cell).floor().max(0.0) as usize;
        let z = ((p.z - self.origin.1) / self.cell).floor().max(0.0) as usize;
        (x.min(self.dims.0 - 1), z.min(self.dims.1 - 1))
    }

    /// Calls `f` with every occluder whose centre is within about `reach` plus one cell of `p`
    /// (candidates; the caller tests the distance).
    fn around(&self, p: Vec3, mut f: impl FnMut(usize)) {
        let span = (self.reach / self.cell).ceil() as i64 + 1;
        let (cx, cz) = self.index(p);
        for z in (cz as i64 - span).max(0)..=(cz as i64 + span).min(self.dims.1 as i64 - 1) {
            for x in (cx as i64 - span).max(0)..=(cx as i64 + span).min(self.dims.0 as i64 - 1) {
                for &i in &self.cells[z as usize * self.dims.0 + x as usize] {
                    f(i);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trilinear_hits_the_corners_and_the_middle() {
        let v = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0];
        for (k, &want) in v.iter().enumerate() {
            let q = visibility::corner(Vec3::ZERO, Vec3::ONE, k);
            assert_eq!(trilinear(v, q), want);
        }
        assert!((trilinear(v, Vec3::splat(0.5)) - 3.5).abs() < 1e-6);
    }

    #[test]
    fn record_transform_matches_the_instance_shader() {
        let (angle, k) = (0.7f32, 2.0);
        let t =
            PlacedTree::from_record(0, [1.0, 2.0, 3.0, k], [angle.cos(), angle.sin(), 0.0, 1.0]);
        let p = Vec3::new(0.3, 1.0, -0.5);
        let (c, s) = (angle.cos(), angle.sin());
        let q = p * k;
        let want = Vec3::new(c * q.x + s * q.z, q.y, -s * q.x + c * q.z) + Vec3::new(1.0, 2.0, 3.0);
        assert!(t.to_world.transform_point3(p).abs_diff_eq(want, 1e-5));
    }
}
