//! Seeded tree placement with blue-noise spacing.
//!
//! All density-driven species share ONE candidate pattern: a Poisson-disk set (Bridson 2007,
//! "Fast Poisson Disk Sampling in Arbitrary Dimensions") over the whole terrain, or a periodic
//! Poisson tile repeated over it (`tiled`, constant memory for huge terrains). Its radius comes
//! from the sum of the species' peak densities, so no two trees of any species are closer than
//! [`Placed::min_spacing_m`]. Each candidate draws one uniform number `u`: it is kept when
//! `u·ρ < D(x)` (ρ = the pattern's measured density, D = the summed local density), and the same
//! `u·ρ` picks the species by the cumulative local densities — density maps thus modulate both
//! acceptance and the species mix. Expected count is exactly ∫D over the terrain.
//!
//! Under `tiled` (and `wang`) placement every candidate draws its numbers from a hash of (seed,
//! tile copy, point index) rather than from one stream, so the trees of any rectangle can be
//! produced alone, in any order, and come out identical: [`SeededForest`] produces a world tile
//! by tile, on demand, in time and memory proportional to the rectangle, never to the world.
//!
//! `wang` placement is `tiled` with Poisson-disk Wang tiles (CSHD03) in place of the periodic
//! tile: 16 tiles of the same side and radius, laid out by a hashed non-periodic tiling, as
//! BN12 §4 asks ([`crate::WangSet`], `wang.rs`); everything else — thinning, hashing,
//! [`SeededForest`] — is shared. Its tiles' point counts differ slightly (±0.2 % at the
//! forest's tile size), so ρ is the 16 tiles' mean and the expected count is ∫D within that.
//!
//! Deviation: `tiled` repeats its tile without per-tile rotation, since rotating a periodic tile
//! would break the minimum spacing at tile borders; the random thinning hides the period (use
//! `wang` for no period at all).

use crate::rng::{Rng, hash2, mix};
use crate::terrain::bilinear;
use crate::types::{Terrain, TreeInstance};
use crate::wang::WangSet;
use glam::{Vec2, Vec3};
use std::fmt;

/// Most trees a scene may place when it is loaded (positions files and `poisson` placement);
/// `tiled` and `wang` placement produce their trees tile by tile and are limited by
/// [`MAX_WORLD_TREES`].
pub const MAX_TREES: usize = 2_000_000;
/// Most trees a `tiled` or `wang` world may hold in all (expected count); only the tiles in
/// range are ever produced.
pub const MAX_WORLD_TREES: f64 = 1e10;
/// Most candidate points a `poisson` pattern may generate (use `tiled` or `wang` beyond).
pub const MAX_PATTERN_POINTS: usize = 6_000_000;
/// Highest accepted density, trees per hectare (one tree per m²).
pub const MAX_DENSITY_PER_HA: f32 = 10_000.0;
/// Default `density_per_ha` (and the scale of a density map when none is given).
pub const DEFAULT_DENSITY_PER_HA: f32 = 400.0;

/// Bridson candidates per active point.
const BRIDSON_K: u32 = 18;
/// r² · (target peak density): the pattern has ≈ 0.88 / r² points, so thinning keeps ~85 % where
/// the density peaks.
const PACKING: f32 = 0.75;
/// Points per r² of the pattern (measured; used only for estimates and the tile size).
const PATTERN_DENSITY: f64 = 0.88;
/// Points per periodic tile in `tiled` placement.
const TILE_POINTS: f32 = 2500.0;

/// How candidate points are generated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlacementMethod {
    /// One Poisson-disk pattern over the whole terrain (best quality, memory ∝ trees).
    #[default]
    Poisson,
    /// A periodic Poisson tile repeated over the terrain (constant memory).
    Tiled,
    /// Poisson-disk Wang tiles laid out by a hashed, non-periodic tiling (CSHD03, as BN12 §4
    /// asks; [`crate::WangSet`]): constant memory like `Tiled`, without its period.
    Wang,
}

/// The `[placement]` table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Placement {
    /// Seed for candidates, thinning, heights and rotations.
    pub seed: u64,
    /// Candidate generator.
    pub method: PlacementMethod,
}

impl Default for Placement {
    fn default() -> Self {
        Self {
            seed: 1,
            method: PlacementMethod::Poisson,
        }
    }
}

/// A grayscale map stretched over the terrain (column 0 at X = 0, row 0 at Z = 0, samples on
/// the edges like a heightmap), values in [0, 1].
#[derive(Debug, Clone, PartialEq)]
pub struct DensityMap {
    /// Samples along X and Z, each ≥ 1.
    pub resolution: [u32; 2],
    /// Row-major values in [0, 1].
    pub values: Vec<f32>,
}

/// How densely a species grows.
#[derive(Debug, Clone, PartialEq)]
pub enum Density {
    /// The same density everywhere, trees per hectare.
    PerHectare(f32),
    /// A map scaled so 1.0 (white) is `max_per_ha` trees per hectare.
    Map {
        /// The map.
        map: DensityMap,
        /// Trees per hectare where the map is white.
        max_per_ha: f32,
    },
}

impl Density {
    /// Trees per m² at `(x, z)` on a terrain of extent `size`.
    pub fn per_m2(&self, size: [f32; 2], x: f32, z: f32) -> f32 {
        match self {
            Density::PerHectare(d) => d * 1e-4,
            Density::Map { map, max_per_ha } => {
                let res = map.resolution.map(|n| n.max(2));
                let v = if map.resolution.contains(&1) {
                    map.values[0]
                } else {
                    bilinear(&map.values, res, size, x, z)
                };
                v * max_per_ha * 1e-4
            }
        }
    }

    /// The highest density anywhere, trees per hectare.
    pub fn peak_per_ha(&self) -> f32 {
        match self {
            Density::PerHectare(d) => *d,
            Density::Map { map, max_per_ha } => {
                map.values.iter().fold(0.0f32, |a, &v| a.max(v)) * max_per_ha
            }
        }
    }

    /// The mean density over the terrain, trees per hectare.
    pub fn mean_per_ha(&self) -> f32 {
        match self {
            Density::PerHectare(d) => *d,
            Density::Map { map, max_per_ha } => {
                let sum: f64 = map.values.iter().map(|&v| v as f64).sum();
                (sum / map.values.len().max(1) as f64) as f32 * max_per_ha
            }
        }
    }
}

/// One density-driven species to place.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeciesLayout {
    /// Index into `Scene::species`.
    pub species: u32,
    /// Height range, metres; each tree's height is uniform in it.
    pub height_m: [f32; 2],
    /// Where and how densely it grows.
    pub density: Density,
}

/// Placement would exceed a limit; checked before anything large is allocated.
#[derive(Debug, Clone, PartialEq)]
pub enum PlacementError {
    /// The expected tree count exceeds [`MAX_TREES`].
    TooManyTrees {
        /// Expected trees (density × area, plus fixed trees).
        estimated: f64,
        /// The limit exceeded ([`MAX_TREES`] placed at load, [`MAX_WORLD_TREES`] in a world).
        limit: f64,
    },
    /// A `poisson` pattern would exceed [`MAX_PATTERN_POINTS`].
    TooManyCandidates {
        /// Expected candidate points.
        estimated: f64,
    },
}

impl fmt::Display for PlacementError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlacementError::TooManyTrees { estimated, limit } => write!(
                f,
                "about {estimated:.0} trees, more than the limit of {limit:.0}"
            ),
            PlacementError::TooManyCandidates { estimated } => write!(
                f,
                "the Poisson pattern would need about {:.0} candidate points, more than the \
                 limit of {MAX_PATTERN_POINTS}",
                estimated
            ),
        }
    }
}

impl std::error::Error for PlacementError {}

/// Placed trees and the spacing they respect.
#[derive(Debug, Clone)]
pub struct Placed {
    /// Fixed trees first (as given), then the density-driven ones; each density-driven tree's
    /// `seed` is its index here.
    pub trees: Vec<TreeInstance>,
    /// Minimum distance between density-driven trees (and from them to fixed trees), metres;
    /// 0 when no species is density-driven.
    pub min_spacing_m: f32,
}

/// Expected number of density-driven trees on a terrain of extent `size`.
pub fn estimate_trees(size: [f32; 2], layouts: &[SpeciesLayout]) -> f64 {
    let area_ha = size[0] as f64 * size[1] as f64 * 1e-4;
    layouts
        .iter()
        .map(|l| l.density.mean_per_ha() as f64 * area_ha)
        .sum()
}

/// The highest summed density of `layouts`, trees per hectare: exact when every map shares one
/// resolution (bilinear sums peak at grid points), else the sum of the peaks (an upper bound).
pub fn peak_per_ha(layouts: &[SpeciesLayout]) -> f32 {
    let mut uniform = 0.0;
    let mut maps = Vec::new();
    for l in layouts {
        match &l.density {
            Density::PerHectare(d) => uniform += d,
            Density::Map { map, max_per_ha } => maps.push((map, *max_per_ha)),
        }
    }
    let shared = maps
        .windows(2)
        .all(|w| w[0].0.resolution == w[1].0.resolution);
    let maps_peak = if shared && !maps.is_empty() {
        let n = maps[0].0.values.len();
        (0..n)
            .map(|i| maps.iter().map(|(m, s)| m.values[i] * s).sum::<f32>())
            .fold(0.0, f32::max)
    } else {
        layouts
            .iter()
            .filter(|l| matches!(l.density, Density::Map { .. }))
            .map(|l| l.density.peak_per_ha())
            .sum()
    };
    uniform + maps_peak
}

/// Place `layouts` on `terrain` around the `fixed` trees (e.g. from positions CSVs), which are
/// kept as given. Same inputs → identical output. Under `tiled` or `wang` placement this
/// produces the whole terrain at once (bounded by [`MAX_TREES`]); [`SeededForest`] produces it
/// tile by tile.
pub fn place_trees(
    terrain: &Terrain,
    layouts: &[SpeciesLayout],
    placement: &Placement,
    fixed: &[TreeInstance],
) -> Result<Placed, PlacementError> {
    place_trees_within(terrain, layouts, placement, fixed, MAX_TREES)
}

/// [`place_trees`] with a lower tree limit than [`MAX_TREES`] (the fuzz entry points use one,
/// so that a valid scene of a million trees is not mistaken for a hang under a sanitizer).
pub(crate) fn place_trees_within(
    terrain: &Terrain,
    layouts: &[SpeciesLayout],
    placement: &Placement,
    fixed: &[TreeInstance],
    limit: usize,
) -> Result<Placed, PlacementError> {
    let limit = limit.min(MAX_TREES);
    let size = terrain.size;
    let estimated = estimate_trees(size, layouts) + fixed.len() as f64;
    if estimated > limit as f64 {
        return Err(PlacementError::TooManyTrees {
            estimated,
            limit: limit as f64,
        });
    }
    let mut trees = Vec::with_capacity(fixed.len() + (estimated * 1.05) as usize + 16);
    trees.extend_from_slice(fixed);
    let min_spacing_m = match placement.method {
        PlacementMethod::Tiled | PlacementMethod::Wang => {
            let Some(forest) =
                SeededForest::with_method(size, layouts, placement.seed, placement.method, fixed)?
            else {
                return Ok(Placed {
                    trees,
                    min_spacing_m: 0.0,
                });
            };
            forest.produce(terrain, Vec2::ZERO, Vec2::from(size), &mut trees);
            forest.min_spacing_m()
        }
        PlacementMethod::Poisson => {
            let peak = peak_per_ha(layouts) * 1e-4;
            if peak <= 0.0 {
                return Ok(Placed {
                    trees,
                    min_spacing_m: 0.0,
                });
            }
            let radius = pattern_radius_m(peak);
            let area = size[0] as f64 * size[1] as f64;
            let estimated = PATTERN_DENSITY * area / (radius as f64 * radius as f64);
            if estimated > MAX_PATTERN_POINTS as f64 {
                return Err(PlacementError::TooManyCandidates { estimated });
            }
            let mut rng = Rng::new(placement.seed);
            let candidates = poisson_disk(size, radius, rng.next_u64());
            let blockers = SpatialHash::new(
                fixed.iter().map(|t| Vec2::new(t.position.x, t.position.z)),
                radius,
            );
            let thin = Thinning {
                layouts,
                size,
                rho: candidates.len() as f64 / area.max(1e-6),
                radius,
                blockers: &blockers,
                single: false,
            };
            let mut local = vec![0.0f32; layouts.len()];
            for &p in &candidates {
                if let Some(mut t) = thin.consider(terrain, p, &mut rng, &mut local) {
                    t.seed = trees.len() as u32;
                    trees.push(t);
                }
            }
            radius
        }
    };
    if trees.len() > limit {
        return Err(PlacementError::TooManyTrees {
            estimated: trees.len() as f64,
            limit: limit as f64,
        });
    }
    Ok(Placed {
        trees,
        min_spacing_m,
    })
}

/// Thinning a candidate pattern to the species' densities (shared by both methods).
#[derive(Debug, Clone)]
struct Thinning<'a> {
    layouts: &'a [SpeciesLayout],
    size: [f32; 2],
    /// The pattern's measured density (points per m²).
    rho: f64,
    radius: f32,
    /// Fixed trees: no density-driven tree within `radius` of one.
    blockers: &'a SpatialHash,
    /// Thin in f32 (`wang`: the arithmetic the GPU seed producer repeats, `world/seed.wgsl`)
    /// rather than f64 (`poisson`, `tiled`: kept so their forests stay as they were).
    single: bool,
}

impl Thinning<'_> {
    /// The tree grown at candidate `p`, if any; draws exactly three numbers from `rng` for a
    /// candidate on the terrain (so a stream stays aligned whatever is kept).
    fn consider(
        &self,
        terrain: &Terrain,
        p: Vec2,
        rng: &mut Rng,
        local: &mut [f32],
    ) -> Option<TreeInstance> {
        if !terrain.contains(p.x, p.y) {
            return None;
        }
        for (d, l) in local.iter_mut().zip(self.layouts) {
            *d = l.density.per_m2(self.size, p.x, p.y);
        }
        let local = &local[..self.layouts.len()];
        // `wang`: one 24-bit draw times ρ, sums in f32 (what the GPU can repeat); else f64.
        let chosen = if self.single {
            first_below(rng.f32() * self.rho as f32, local)
        } else {
            first_below(rng.f64() * self.rho, local)
        };
        let (hr, rot) = (rng.f32(), rng.f32());
        let i = chosen?;
        if self.blockers.any_within(p, self.radius) {
            return None;
        }
        let [h0, h1] = self.layouts[i].height_m;
        Some(TreeInstance {
            position: Vec3::new(p.x, terrain.height_at(p.x, p.y), p.y),
            height: h0 + (h1 - h0) * hr,
            rotation: rot * std::f32::consts::TAU,
            species: self.layouts[i].species,
            seed: 0,
        })
    }
}

/// The first species whose cumulative density (summed in `T`, in species order) exceeds `u`.
fn first_below<T>(u: T, densities: &[f32]) -> Option<usize>
where
    T: Copy + PartialOrd + std::ops::Add<Output = T> + From<f32>,
{
    let mut cum = T::from(0.0);
    densities.iter().position(|&d| {
        cum = cum + T::from(d);
        u < cum
    })
}

/// The density-driven trees of `tiled` or `wang` placement, produced for any rectangle of the
/// terrain alone: a periodic Poisson tile repeated over the terrain (`tiled`) or Poisson-disk
/// Wang tiles in a hashed tiling (`wang`), each candidate thinned with numbers hashed from
/// (seed, tile copy, point index). The trees of a rectangle are exactly those of the whole
/// terrain that fall in it, whatever else was produced before; memory is the pattern (≈ 2,500
/// points, 16 tiles of them for `wang`) plus the fixed trees it must keep clear of.
#[derive(Debug, Clone)]
pub struct SeededForest {
    size: [f32; 2],
    layouts: Vec<SpeciesLayout>,
    pattern: Pattern,
    tile: f32,
    rho: f64,
    radius: f32,
    seed: u64,
    blockers: SpatialHash,
}

/// The candidate pattern of a [`SeededForest`].
#[derive(Debug, Clone)]
enum Pattern {
    /// One periodic tile's points, sorted by z.
    Periodic(Vec<Vec2>),
    /// Wang tiles, each sorted by z.
    Wang(WangSet),
}

impl SeededForest {
    /// The `tiled` forest of `layouts` over a terrain of extent `size`, kept clear of `fixed`;
    /// `None` when no layout has any density.
    pub fn new(
        size: [f32; 2],
        layouts: &[SpeciesLayout],
        seed: u64,
        fixed: &[TreeInstance],
    ) -> Result<Option<Self>, PlacementError> {
        Self::with_method(size, layouts, seed, PlacementMethod::Tiled, fixed)
    }

    /// [`SeededForest::new`] with the candidate pattern of `method`: `Wang` for Wang tiles of
    /// the same side and radius as `Tiled`'s periodic tile; `Tiled` (and `Poisson`, which has
    /// no per-rectangle form) for the periodic tile.
    pub fn with_method(
        size: [f32; 2],
        layouts: &[SpeciesLayout],
        seed: u64,
        method: PlacementMethod,
        fixed: &[TreeInstance],
    ) -> Result<Option<Self>, PlacementError> {
        let estimated = estimate_trees(size, layouts);
        if estimated > MAX_WORLD_TREES {
            return Err(PlacementError::TooManyTrees {
                estimated,
                limit: MAX_WORLD_TREES,
            });
        }
        let peak = peak_per_ha(layouts) * 1e-4;
        if peak <= 0.0 {
            return Ok(None);
        }
        let radius = pattern_radius_m(peak);
        let tile = (radius * (TILE_POINTS / PATTERN_DENSITY as f32).sqrt()).max(4.0 * radius);
        if !radius.is_finite() || radius > 1e12 {
            // A peak density so small (< 1e-24 / m², or a subnormal one whose radius is
            // infinite) that the tiles' squared distances would overflow f32 and the sampler
            // would never finish: under 1e-12 trees expected on the largest terrain, so none.
            return Ok(None);
        }
        let (pattern, rho) = if method == PlacementMethod::Wang {
            let set = WangSet::new(tile, radius, Rng::new(seed).next_u64());
            let rho = set.density();
            (Pattern::Wang(set), rho)
        } else {
            let mut pattern = poisson_tile(tile, radius, Rng::new(seed).next_u64());
            let rho = pattern.len() as f64 / (tile as f64 * tile as f64);
            pattern.sort_by(|a, b| a.y.total_cmp(&b.y).then(a.x.total_cmp(&b.x)));
            (Pattern::Periodic(pattern), rho)
        };
        Ok(Some(Self {
            size,
            layouts: layouts.to_vec(),
            pattern,
            tile,
            rho,
            radius,
            seed,
            blockers: SpatialHash::new(
                fixed.iter().map(|t| Vec2::new(t.position.x, t.position.z)),
                radius,
            ),
        }))
    }

    /// The candidate pattern's method: `Tiled` or `Wang`.
    pub fn method(&self) -> PlacementMethod {
        match self.pattern {
            Pattern::Periodic(_) => PlacementMethod::Tiled,
            Pattern::Wang(_) => PlacementMethod::Wang,
        }
    }

    /// The Wang tiles under `wang` placement (`None` under `tiled`).
    pub fn wang(&self) -> Option<&WangSet> {
        match &self.pattern {
            Pattern::Periodic(_) => None,
            Pattern::Wang(set) => Some(set),
        }
    }

    /// The density-driven species it places.
    pub fn layouts(&self) -> &[SpeciesLayout] {
        &self.layouts
    }

    /// Minimum distance between its trees (and from them to the fixed trees), metres.
    pub fn min_spacing_m(&self) -> f32 {
        self.radius
    }

    /// Expected number of trees over the whole terrain.
    pub fn estimated_trees(&self) -> f64 {
        estimate_trees(self.size, &self.layouts)
    }

    /// Expected number of trees in a rectangle of `area_m2` where the density peaks (an upper
    /// bound for sizing buffers).
    pub fn peak_trees(&self, area_m2: f64) -> f64 {
        peak_per_ha(&self.layouts) as f64 * 1e-4 * area_m2
    }

    /// The tallest tree any layout can grow, metres.
    pub fn tallest_m(&self) -> f32 {
        self.layouts
            .iter()
            .map(|l| l.height_m[1])
            .fold(0.0, f32::max)
    }

    /// Appends the trees in `[min, max)` (x, z) to `out`, in a fixed order (tile copies by row,
    /// then pattern points by z: [`SeededForest::candidate_runs`]'s order). Time ∝ the
    /// rectangle's area. Under `wang` candidate `j` of copy `(tx, ty)` showing tile `t` draws
    /// its numbers from `hash2(seed ^ mix(t·2¹⁶ + j + 1), tx, ty)` (under `tiled`, `t` = 0) and
    /// is thinned in f32 (the GPU seed producer repeats this arithmetic).
    pub fn produce(&self, terrain: &Terrain, min: Vec2, max: Vec2, out: &mut Vec<TreeInstance>) {
        let thin = Thinning {
            layouts: &self.layouts,
            size: self.size,
            rho: self.rho,
            radius: self.radius,
            blockers: &self.blockers,
            single: self.method() == PlacementMethod::Wang,
        };
        let mut local = vec![0.0f32; self.layouts.len()];
        let mut runs = Vec::new();
        let (min, max) = self.candidate_runs(min, max, &mut runs);
        for run in &runs {
            let pattern = self.tile_points(run.tile as usize);
            for j in run.first..run.end {
                let q = run.origin + pattern[j as usize];
                if q.x < min.x || q.x >= max.x {
                    continue;
                }
                let key = hash2(
                    self.seed ^ mix(((run.tile as u64) << 16) + j as u64 + 1),
                    run.tx,
                    run.ty,
                );
                let mut rng = Rng::new(key);
                if let Some(mut t) = thin.consider(terrain, q, &mut rng, &mut local) {
                    t.seed = (key >> 32) as u32;
                    out.push(t);
                }
            }
        }
    }

    /// The candidates of `[min, max)` (x, z; clipped to the terrain, the clipped rectangle is
    /// returned): per tile copy overlapping it, by row, the run of its tile's points (sorted by
    /// z) whose z lies in the rectangle — each point `j` of a run is a candidate when its x
    /// lies in the rectangle too. The runs are cleared first.
    pub fn candidate_runs(
        &self,
        min: Vec2,
        max: Vec2,
        out: &mut Vec<CandidateRun>,
    ) -> (Vec2, Vec2) {
        out.clear();
        let min = min.max(Vec2::ZERO);
        let max = max.min(Vec2::from(self.size));
        if min.x >= max.x || min.y >= max.y {
            return (min, max);
        }
        let copies = |lo: f32, hi: f32| {
            (lo / self.tile).floor() as i64..=((hi / self.tile).ceil() as i64 - 1)
        };
        for ty in copies(min.y, max.y) {
            let oz = ty as f32 * self.tile;
            for tx in copies(min.x, max.x) {
                let ox = tx as f32 * self.tile;
                let tile = match &self.pattern {
                    Pattern::Periodic(_) => 0,
                    Pattern::Wang(set) => set.tile_of(tx, ty),
                };
                let pattern = self.tile_points(tile);
                let first = pattern.partition_point(|p| oz + p.y < min.y);
                let end = first + pattern[first..].partition_point(|p| oz + p.y < max.y);
                if end > first {
                    out.push(CandidateRun {
                        tile: tile as u32,
                        tx,
                        ty,
                        origin: Vec2::new(ox, oz),
                        first: first as u32,
                        end: end as u32,
                    });
                }
            }
        }
        (min, max)
    }

    /// The points of pattern tile `tile` (sorted by z, then x): one tile under `tiled`, the
    /// 16 Wang tiles under `wang`.
    pub fn tile_points(&self, tile: usize) -> &[Vec2] {
        match &self.pattern {
            Pattern::Periodic(p) => p,
            Pattern::Wang(set) => set.points(tile),
        }
    }

    /// The placement seed the candidates' numbers are hashed from.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The candidate pattern's density, points per m² (the thinning's ρ).
    pub fn pattern_density(&self) -> f64 {
        self.rho
    }

    /// The terrain extent it covers, metres.
    pub fn size(&self) -> [f32; 2] {
        self.size
    }

    /// Whether a fixed tree lies within the pattern radius of `[min, max)` (x, z): the trees
    /// there must keep clear of it.
    pub fn blocked_near(&self, min: Vec2, max: Vec2) -> bool {
        self.blockers.any_near_rect(min, max, self.radius)
    }
}

/// A run of candidates of a [`SeededForest`]: points `first..end` of pattern tile `tile`
/// (index into [`SeededForest::tile_points`]), shown by tile copy `(tx, ty)` whose corner is
/// `origin` (`(tx, ty) × side`, rounded as the CPU rounds it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CandidateRun {
    /// Pattern tile.
    pub tile: u32,
    /// Copy column.
    pub tx: i64,
    /// Copy row.
    pub ty: i64,
    /// The copy's corner (x, z), metres.
    pub origin: Vec2,
    /// First point of the run.
    pub first: u32,
    /// One past the last point.
    pub end: u32,
}

/// The Poisson pattern radius (minimum spacing) for a forest whose densest part has
/// `peak_per_m2` trees per m²: the candidates then number about 1.17 × the peak density.
pub fn pattern_radius_m(peak_per_m2: f32) -> f32 {
    (PACKING / peak_per_m2).sqrt()
}

/// Bridson's Poisson-disk sampling over `[0, size[0]] × [0, size[1]]`: no two points closer than
/// `radius`, and (nearly) no gap that could hold another. Deterministic for a seed.
pub fn poisson_disk(size: [f32; 2], radius: f32, seed: u64) -> Vec<Vec2> {
    bridson(size, radius, seed, false)
}

/// A periodic Poisson-disk tile of side `tile`: the spacing holds across the wrap-around, so
/// copies placed edge to edge keep it too.
pub fn poisson_tile(tile: f32, radius: f32, seed: u64) -> Vec<Vec2> {
    bridson([tile, tile], radius, seed, true)
}

fn bridson(size: [f32; 2], radius: f32, seed: u64, periodic: bool) -> Vec<Vec2> {
    bridson_in(size, radius, &mut Rng::new(seed), periodic, &[], |_| true)
}

/// Bridson's sampling over `[0, size[0]] × [0, size[1]]` (wrapping around when `periodic`),
/// conditioned on `fixed` points and restricted to a sub-domain: returns only the NEW points,
/// each inside `inside` and ≥ `radius` from every other point and every fixed point. The
/// fixed points must lie in the box and keep the radius among themselves; they seed the
/// growth (all start active), and when there are none a first point is drawn uniformly in
/// the domain (up to 64 tries). With no fixed points and `inside` always true this is exactly
/// [`poisson_disk`] / [`poisson_tile`] (same numbers drawn in the same order).
pub(crate) fn bridson_in(
    size: [f32; 2],
    radius: f32,
    rng: &mut Rng,
    periodic: bool,
    fixed: &[Vec2],
    inside: impl Fn(Vec2) -> bool,
) -> Vec<Vec2> {
    let cell_max = radius / std::f32::consts::SQRT_2;
    let n = size.map(|s| ((s / cell_max).ceil() as usize).max(1));
    let cell = [size[0] / n[0] as f32, size[1] / n[1] as f32];
    let reach = [
        (radius / cell[0]).ceil() as i64,
        (radius / cell[1]).ceil() as i64,
    ];
    let mut grid = vec![u32::MAX; n[0] * n[1]];
    let mut points: Vec<Vec2> = Vec::with_capacity(fixed.len());
    let mut active: Vec<u32> = Vec::new();
    let r2 = radius * radius;
    let cell_of = |p: Vec2| {
        let c = ((p.x / cell[0]) as usize).min(n[0] - 1);
        let r = ((p.y / cell[1]) as usize).min(n[1] - 1);
        (c, r)
    };
    let fits = |p: Vec2, grid: &[u32], points: &[Vec2]| {
        let (c, r) = cell_of(p);
        for dr in -reach[1]..=reach[1] {
            for dc in -reach[0]..=reach[0] {
                // Skip cells whose nearest point is already ≥ r away (the 5×5 block's corners).
                let gap = |d: i64, c: f32| (d.abs() - 1).max(0) as f32 * c;
                if gap(dc, cell[0]).powi(2) + gap(dr, cell[1]).powi(2) >= r2 {
                    continue;
                }
                let (mut cc, mut rr) = (c as i64 + dc, r as i64 + dr);
                let mut shift = Vec2::ZERO;
                if periodic {
                    let (w, h) = (n[0] as i64, n[1] as i64);
                    shift.x = cc.div_euclid(w) as f32 * size[0];
                    shift.y = rr.div_euclid(h) as f32 * size[1];
                    cc = cc.rem_euclid(w);
                    rr = rr.rem_euclid(h);
                } else if cc < 0 || rr < 0 || cc >= n[0] as i64 || rr >= n[1] as i64 {
                    continue;
                }
                let idx = grid[rr as usize * n[0] + cc as usize];
                if idx != u32::MAX && (points[idx as usize] + shift).distance_squared(p) < r2 {
                    return false;
                }
            }
        }
        true
    };
    let insert = |p: Vec2, grid: &mut [u32], points: &mut Vec<Vec2>, active: &mut Vec<u32>| {
        let (c, r) = cell_of(p);
        grid[r * n[0] + c] = points.len() as u32;
        active.push(points.len() as u32);
        points.push(p);
    };
    for &p in fixed {
        insert(p, &mut grid, &mut points, &mut active);
    }
    if fixed.is_empty() {
        let first = (0..64)
            .map(|_| Vec2::new(rng.f32() * size[0], rng.f32() * size[1]))
            .find(|&p| inside(p));
        let Some(first) = first else {
            return Vec::new();
        };
        insert(first, &mut grid, &mut points, &mut active);
    }
    // Roberts' variant of Bridson: K candidates evenly spaced on the circle of radius r (+ε)
    // from a random start angle — denser packing, and no trigonometry per candidate.
    let ring: Vec<Vec2> = (0..BRIDSON_K)
        .map(|j| Vec2::from_angle(j as f32 * std::f32::consts::TAU / BRIDSON_K as f32))
        .collect();
    let step = radius * 1.0001;
    while !active.is_empty() {
        let slot = rng.below(active.len());
        let centre = points[active[slot] as usize];
        let start = Vec2::from_angle(rng.f32() * std::f32::consts::TAU) * step;
        let mut found = false;
        for dir in &ring {
            let mut p = centre + dir.rotate(start);
            if periodic {
                p = Vec2::new(p.x.rem_euclid(size[0]), p.y.rem_euclid(size[1]));
                // rem_euclid can round up to exactly `size`.
                p = p.min(Vec2::new(size[0], size[1]) * (1.0 - f32::EPSILON));
            } else if !(0.0..size[0]).contains(&p.x) || !(0.0..size[1]).contains(&p.y) {
                continue;
            }
            if inside(p) && fits(p, &grid, &points) {
                insert(p, &mut grid, &mut points, &mut active);
                found = true;
                break;
            }
        }
        if !found {
            active.swap_remove(slot);
        }
    }
    points.split_off(fixed.len())
}

/// A uniform grid over points for "anything within r?" queries.
#[derive(Debug, Clone)]
struct SpatialHash {
    cell: f32,
    cells: std::collections::HashMap<(i64, i64), Vec<Vec2>>,
}

impl SpatialHash {
    fn new(points: impl Iterator<Item = Vec2>, cell: f32) -> Self {
        let mut cells: std::collections::HashMap<(i64, i64), Vec<Vec2>> = Default::default();
        for p in points {
            cells.entry(Self::key(p, cell)).or_default().push(p);
        }
        Self { cell, cells }
    }

    fn key(p: Vec2, cell: f32) -> (i64, i64) {
        ((p.x / cell).floor() as i64, (p.y / cell).floor() as i64)
    }

    /// Whether a point lies within `r` of the rectangle `[min, max]`.
    fn any_near_rect(&self, min: Vec2, max: Vec2, r: f32) -> bool {
        if self.cells.is_empty() {
            return false;
        }
        let lo = Self::key(min - Vec2::splat(r), self.cell);
        let hi = Self::key(max + Vec2::splat(r), self.cell);
        if (hi.0 - lo.0 + 1).saturating_mul(hi.1 - lo.1 + 1) > self.cells.len() as i64 {
            return self
                .cells
                .values()
                .flatten()
                .any(|q| (q.clamp(min, max) - *q).length_squared() < r * r);
        }
        (lo.1..=hi.1).any(|y| {
            (lo.0..=hi.0).any(|x| {
                self.cells.get(&(x, y)).is_some_and(|v| {
                    v.iter()
                        .any(|q| (q.clamp(min, max) - *q).length_squared() < r * r)
                })
            })
        })
    }

    fn any_within(&self, p: Vec2, r: f32) -> bool {
        if self.cells.is_empty() {
            return false;
        }
        let (c, rr) = Self::key(p, self.cell);
        let reach = (r / self.cell).ceil() as i64;
        (-reach..=reach).any(|dy| {
            (-reach..=reach).any(|dx| {
                self.cells
                    .get(&(c + dx, rr + dy))
                    .is_some_and(|v| v.iter().any(|q| q.distance_squared(p) < r * r))
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn min_distance(points: &[Vec2]) -> f32 {
        let mut best = f32::INFINITY;
        let mut sorted: Vec<Vec2> = points.to_vec();
        sorted.sort_by(|a, b| a.x.total_cmp(&b.x));
        for i in 0..sorted.len() {
            for j in i + 1..sorted.len() {
                if sorted[j].x - sorted[i].x >= best {
                    break;
                }
                best = best.min(sorted[i].distance(sorted[j]));
            }
        }
        best
    }

    #[test]
    fn bridson_respects_radius_and_fills() {
        let pts = poisson_disk([100.0, 60.0], 3.0, 9);
        assert!(min_distance(&pts) >= 3.0);
        let density = pts.len() as f64 * 9.0 / 6000.0;
        assert!((density - PATTERN_DENSITY).abs() < 0.05, "{density}");
        assert_eq!(pts, poisson_disk([100.0, 60.0], 3.0, 9));
    }

    #[test]
    fn periodic_tile_respects_radius_across_copies() {
        let tile = poisson_tile(30.0, 2.5, 4);
        let mut all = Vec::new();
        for ty in 0..2 {
            for tx in 0..2 {
                all.extend(
                    tile.iter()
                        .map(|&p| p + Vec2::new(tx as f32, ty as f32) * 30.0),
                );
            }
        }
        assert!(min_distance(&all) >= 2.5 * 0.9999);
    }

    #[test]
    fn fixed_trees_block_neighbours() {
        let t = Terrain::flat([50.0, 50.0], 0.0);
        let fixed = TreeInstance {
            position: Vec3::new(25.0, 0.0, 25.0),
            height: 5.0,
            rotation: 0.0,
            species: 1,
            seed: 0,
        };
        let layout = SpeciesLayout {
            species: 0,
            height_m: [3.0, 4.0],
            density: Density::PerHectare(2000.0),
        };
        let placed = place_trees(&t, &[layout], &Placement::default(), &[fixed]).unwrap();
        assert_eq!(placed.trees[0], fixed);
        let r = placed.min_spacing_m;
        assert!(
            placed.trees[1..]
                .iter()
                .all(|p| p.position.distance(fixed.position) >= r)
        );
    }
}
