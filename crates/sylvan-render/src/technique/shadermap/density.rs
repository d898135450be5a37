//! The field's tree density Λ_h(x) over the terrain (BN12 §4's density maps): a raster the
//! field samples per pixel, so the forest is where the scene's trees are — a clearing is bare
//! ground, a dense stand is dense — instead of one density for the whole terrain.
//!
//! Built from what the scene has: its density-driven species' maps (or constant densities),
//! evaluated at the texel centres and summed, and its placed trees binned per cell and
//! smoothed by a 3 × 3 tent (a cell holds a stand, not one tree: BN12's maps are densities, not
//! positions). Size is bounded by [`MAX_TEXELS`] per side whatever the terrain's extent or the
//! number of trees.
//!
//! **Species** (a deviation): BN12 keeps one density channel per species and tables per tree
//! model; Sylvan measures one table set for the scene's mix, so where the local mix differs
//! from the mix's shares (a clearing of bushes, a stand of tall pines) the tables' coverage
//! for the summed density is wrong. Each texel therefore also holds the trees' summed crown
//! areas seen from above (Σ Λⁱ aⁱ) and from the side (Σ Λⁱ sⁱ), and the field looks the
//! tables up at the *effective* density
//! `λ = (Σ Λⁱ aⁱ cos θ + Σ Λⁱ sⁱ sin θ) / (ā cos θ + s̄ sin θ)` (θ the view zenith in the
//! transformed space, the side areas scaled by its 2/h, ā and s̄ the mix's mean areas): the
//! density of the mix's trees that projects as much crown along the view as the local trees
//! do. Where the local mix is the mix, it is Λ_h. Crowns are the plants' bounding boxes: a
//! disk of the mean horizontal half-extent r on top, a 2r × height rectangle from the side.
//!
//! **Colour**: each texel also holds Σ Λⁱ aⁱ ρⁱ, the top crown areas weighted by each
//! species' albedo (its `zfield` bake's mean), so the field's trees take the local species'
//! colour — a stand of pale birches among dark pines stays pale to the horizon — instead of
//! the mix's mean ρ̄ everywhere ([`DensityRaster::mean_albedo`] is the terrain's mean, which
//! the field scales to ρ̄).
//!
//! **Per species** ([`DensityRaster::species`]): Λⁱ E(h²) per texel, so the field can weigh
//! each species' own handover by the crown area it shows (BN12 §4's 3-px rule ends a bush long
//! before a pine: `FieldEnd`).

use sylvan_plant::Plant;
use sylvan_scene::Scene;

/// Channels per texel of [`DensityRaster::texels`].
pub const CHANNELS: usize = 6;

/// Most texels per side of the raster.
pub const MAX_TEXELS: u32 = 512;

/// Smallest cell side for binning placed trees, metres (a cell holds a stand: at 150 trees/ha
/// about 9 trees, and the tent widens it to about 50 m).
pub const PLACED_CELL_M: f32 = 25.0;

/// A species' crown areas per square metre of tree height (top view: π r̂², side view: 2 r̂,
/// r̂ the plant's mean horizontal half-extent over its height).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrownShape {
    /// Top-view area / height².
    pub top: f32,
    /// Side-view area / height².
    pub side: f32,
}

impl CrownShape {
    /// From a plant's bounding box.
    pub fn of(plant: &Plant) -> Self {
        let (min, max) = (plant.bbox_min, plant.bbox_max);
        let h = max[1].max(1e-3);
        let r = ((max[0] - min[0]) + (max[2] - min[2])) * 0.25 / h;
        Self {
            top: std::f32::consts::PI * r * r,
            side: 2.0 * r * (max[1] - min[1].min(0.0)) / h,
        }
    }
}

/// Per texel: trees per m², their summed crown areas per m² (top, side) and the top areas
/// weighted by albedo (linear RGB); texel centres at `(i + ½) size / n`, row-major from X = 0,
/// Z = 0.
#[derive(Debug, Clone, PartialEq)]
pub struct DensityRaster {
    /// Texels along X and Z, each 1 to [`MAX_TEXELS`].
    pub resolution: [u32; 2],
    /// The terrain's extent along X and Z, metres.
    pub size_m: [f32; 2],
    /// Per texel [Λ_h (trees per m²), Σ Λⁱ aⁱ, Σ Λⁱ sⁱ (m² of crown per m²), Σ Λⁱ aⁱ ρⁱ
    /// (red, green, blue)], row-major.
    pub texels: Vec<[f32; CHANNELS]>,
    /// Per species (as the plants), per texel: Λⁱ E(h²) (m² of tree height² per m²), the
    /// species' share of the crown areas (its top area is this × its [`CrownShape::top`]) —
    /// what the field weighs each species' own handover by (BN12 keeps a density channel per
    /// species).
    pub species: Vec<Vec<f32>>,
    /// Per species its trees' root-mean-square height (metres; 0 without trees): the height
    /// the field's per-species handover takes (`FieldEnd`'s pixel rule).
    pub heights: Vec<f32>,
    /// Per species its [`CrownShape`].
    pub shapes: Vec<CrownShape>,
}

impl DensityRaster {
    /// The density of `scene`'s forest (one plant per species): its seeded species' densities
    /// plus its placed trees; `albedo` per species (linear RGB; a species past its end counts
    /// as white).
    pub fn of_scene(scene: &Scene, plants: &[Plant], albedo: &[[f32; 3]]) -> Self {
        let rho = |s: u32| albedo.get(s as usize).copied().unwrap_or([1.0; 3]);
        let shapes: Vec<CrownShape> = plants.iter().map(CrownShape::of).collect();
        let shape = |s: u32| {
            shapes.get(s as usize).copied().unwrap_or(CrownShape {
                top: 0.0,
                side: 0.0,
            })
        };
        let size = scene.terrain.size.map(|v| v.max(1e-3));
        let layouts = scene.seeded.as_ref().map_or(&[][..], |s| s.layouts());
        let resolution = if !scene.trees.is_empty() {
            let cell = PLACED_CELL_M.max(size[0].max(size[1]) / MAX_TEXELS as f32);
            size.map(|s| ((s / cell).ceil() as u32).clamp(1, MAX_TEXELS))
        } else {
            // The finest map's resolution (1 × 1 for constant densities).
            layouts
                .iter()
                .filter_map(|l| match &l.density {
                    sylvan_scene::Density::Map { map, .. } => Some(map.resolution),
                    sylvan_scene::Density::PerHectare(_) => None,
                })
                .fold([1, 1], |a, r| [a[0].max(r[0]), a[1].max(r[1])])
                .map(|n| n.clamp(1, MAX_TEXELS))
        };
        let [nx, nz] = resolution.map(|n| n as usize);
        let mut texels = vec![[0.0f32; CHANNELS]; nx * nz];
        let mut species = vec![vec![0.0f32; nx * nz]; plants.len()];
        // Per species: trees and Σ h² over the terrain (for the rms height).
        let mut totals = vec![[0.0f64; 2]; plants.len()];
        if !scene.trees.is_empty() {
            let cell_m2 = (size[0] / nx as f32) * (size[1] / nz as f32);
            for t in &scene.trees {
                let cx = ((t.position.x / size[0] * nx as f32).max(0.0) as usize).min(nx - 1);
                let cz = ((t.position.z / size[1] * nz as f32).max(0.0) as usize).min(nz - 1);
                let (c, h2) = (shape(t.species), t.height * t.height);
                if let Some(q) = species.get_mut(t.species as usize) {
                    q[cz * nx + cx] += h2 / cell_m2;
                    totals[t.species as usize][0] += 1.0;
                    totals[t.species as usize][1] += h2 as f64;
                }
                let v = &mut texels[cz * nx + cx];
                v[0] += 1.0 / cell_m2;
                v[1] += c.top * h2 / cell_m2;
                v[2] += c.side * h2 / cell_m2;
                for (k, a) in rho(t.species).into_iter().enumerate() {
                    v[3 + k] += a * c.top * h2 / cell_m2;
                }
            }
            texels = tent(&texels, nx, nz);
            for q in &mut species {
                let one: Vec<[f32; 1]> = q.iter().map(|&v| [v]).collect();
                *q = tent(&one, nx, nz).into_iter().map(|[v]| v).collect();
            }
        }
        let texel_m2 = (size[0] / nx as f32) as f64 * (size[1] / nz as f32) as f64;
        for (i, v) in texels.iter_mut().enumerate() {
            let x = ((i % nx) as f32 + 0.5) / nx as f32 * size[0];
            let z = ((i / nx) as f32 + 0.5) / nz as f32 * size[1];
            for l in layouts {
                let d = l.density.per_m2(size, x, z);
                let [h0, h1] = l.height_m;
                // E[h²] over the layout's uniform heights.
                let h2 = (h0 * h0 + h0 * h1 + h1 * h1) / 3.0;
                let c = shape(l.species);
                if let Some(q) = species.get_mut(l.species as usize) {
                    q[i] += d * h2;
                    totals[l.species as usize][0] += d as f64 * texel_m2;
                    totals[l.species as usize][1] += (d * h2) as f64 * texel_m2;
                }
                v[0] += d;
                v[1] += d * c.top * h2;
                v[2] += d * c.side * h2;
                for (k, a) in rho(l.species).into_iter().enumerate() {
                    v[3 + k] += a * d * c.top * h2;
                }
            }
        }
        let heights = totals
            .iter()
            .map(|&[n, h2]| if n > 0.0 { (h2 / n).sqrt() as f32 } else { 0.0 })
            .collect();
        Self {
            resolution,
            size_m: size,
            texels,
            species,
            heights,
            shapes,
        }
    }

    /// The highest of channel `c` (0: Λ_h, 1: top areas, 2: side areas, 3–5: top areas ×
    /// albedo).
    pub fn max(&self, c: usize) -> f32 {
        self.texels.iter().fold(0.0, |a, v| a.max(v[c]))
    }

    /// The mix's mean crown areas per tree (top, side), m²: the totals over the terrain over
    /// its trees (0 without trees).
    pub fn mean_areas(&self) -> [f32; 2] {
        let sum = |c: usize| self.texels.iter().map(|v| v[c] as f64).sum::<f64>();
        let n = sum(0);
        if n <= 0.0 {
            return [0.0; 2];
        }
        [(sum(1) / n) as f32, (sum(2) / n) as f32]
    }

    /// The trees' mean albedo over the terrain, weighted by top crown area (white without
    /// trees).
    pub fn mean_albedo(&self) -> [f32; 3] {
        let sum = |c: usize| self.texels.iter().map(|v| v[c] as f64).sum::<f64>();
        let top = sum(1);
        if top <= 0.0 {
            return [1.0; 3];
        }
        [3, 4, 5].map(|c| (sum(c) / top) as f32)
    }

    /// The highest effective density at any view angle: what the tables must reach.
    pub fn peak_effective(&self) -> f32 {
        let [a, s] = self.mean_areas();
        let ratio = |v: f32, m: f32| if m > 0.0 { v / m } else { 0.0 };
        self.texels
            .iter()
            .map(|v| v[0].max(ratio(v[1], a)).max(ratio(v[2], s)))
            .fold(0.0, f32::max)
    }

    /// Channel `c` at `(x, z)`, bilinear between texel centres, clamped at the edges (as the
    /// field samples it).
    pub fn at(&self, c: usize, x: f32, z: f32) -> f32 {
        let [nx, nz] = self.resolution.map(|n| n as usize);
        let coord = |p: f32, size: f32, n: usize| {
            let u = (p / size * n as f32 - 0.5).clamp(0.0, (n - 1) as f32);
            let i = (u as usize).min(n.saturating_sub(2));
            (i, (u - i as f32).min(1.0), (i + 1).min(n - 1))
        };
        let (x0, fx, x1) = coord(x, self.size_m[0], nx);
        let (z0, fz, z1) = coord(z, self.size_m[1], nz);
        let v = |i: usize, j: usize| self.texels[j * nx + i][c];
        let a = v(x0, z0) + (v(x1, z0) - v(x0, z0)) * fx;
        let b = v(x0, z1) + (v(x1, z1) - v(x0, z1)) * fx;
        a + (b - a) * fz
    }
}

/// `values` (nx × nz) smoothed by the tent [1 2 1]² / 16, edges clamped (mass-preserving in
/// the interior).
fn tent<const N: usize>(values: &[[f32; N]], nx: usize, nz: usize) -> Vec<[f32; N]> {
    let pass = |src: &[[f32; N]], dx: isize, dz: isize| -> Vec<[f32; N]> {
        let at = |i: isize, j: isize| {
            let i = i.clamp(0, nx as isize - 1) as usize;
            let j = j.clamp(0, nz as isize - 1) as usize;
            src[j * nx + i]
        };
        let mut out = vec![[0.0f32; N]; src.len()];
        for z in 0..nz as isize {
            for x in 0..nx as isize {
                let (a, b, c) = (at(x - dx, z - dz), at(x, z), at(x + dx, z + dz));
                out[z as usize * nx + x as usize] =
                    std::array::from_fn(|k| 0.25 * a[k] + 0.5 * b[k] + 0.25 * c[k]);
            }
        }
        out
    };
    let h = pass(values, 1, 0);
    pass(&h, 0, 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use sylvan_scene::{Scene, TreeInstance};

    fn scene_with(trees: Vec<TreeInstance>, size: f32) -> Scene {
        let mut s = Scene::builtin_grove();
        s.terrain = sylvan_scene::Terrain::procedural(1, [size, size], 0.0);
        s.trees = trees;
        s.seeded = None;
        s
    }

    /// A 10 m box plant 6 m wide: r̂ = 0.3.
    fn box_plant(height: f32, width: f32) -> Plant {
        Plant {
            bbox_min: [-width / 2.0, 0.0, -width / 2.0],
            bbox_max: [width / 2.0, height, width / 2.0],
            ..Default::default()
        }
    }

    fn plants() -> Vec<Plant> {
        vec![box_plant(10.0, 6.0), box_plant(2.0, 4.0)]
    }

    fn tree(x: f32, z: f32) -> TreeInstance {
        TreeInstance {
            position: Vec3::new(x, 0.0, z),
            species: 0,
            seed: 0,
            height: 10.0,
            rotation: 0.0,
        }
    }

    #[test]
    fn each_texel_holds_its_own_species_albedo() {
        // Species 0 (10 m, albedo red) on the west half, species 1 (the 2 m plant, blue) on the
        // east: a texel's weighted albedo over its top area is its species' albedo, and the
        // terrain's mean weighs them by top crown area.
        let mut trees = Vec::new();
        for i in 0..160 {
            for j in 0..160 {
                let mut t = tree(2.5 + 5.0 * i as f32, 2.5 + 5.0 * j as f32);
                if t.position.x >= 400.0 {
                    t.species = 1;
                    t.height = 2.0;
                }
                trees.push(t);
            }
        }
        let albedo = [[0.5, 0.1, 0.1], [0.1, 0.1, 0.5]];
        let r = DensityRaster::of_scene(&scene_with(trees, 800.0), &plants(), &albedo);
        let [nx, nz] = r.resolution.map(|n| n as usize);
        for (x, want) in [(nx / 8, albedo[0]), (nx - 1 - nx / 8, albedo[1])] {
            let v = r.texels[(nz / 2) * nx + x];
            for c in 0..3 {
                assert!(
                    (v[3 + c] / v[1] - want[c]).abs() < 1e-4,
                    "{v:?} vs {want:?}"
                );
            }
        }
        let areas = [0, 1].map(|s| {
            let c = CrownShape::of(&plants()[s]);
            c.top * [100.0f32, 4.0][s]
        });
        let mean = r.mean_albedo();
        for c in 0..3 {
            let want = (areas[0] * albedo[0][c] + areas[1] * albedo[1][c]) / (areas[0] + areas[1]);
            assert!((mean[c] - want).abs() < 1e-3 * want.max(0.1), "{mean:?}");
        }
    }

    #[test]
    fn placed_trees_give_their_density_where_they_are_and_none_elsewhere() {
        // A 5 m grid (400 trees/ha) over the east half of 800 m (25 m cells: 25 trees each).
        let mut trees = Vec::new();
        for i in 0..80 {
            for j in 0..160 {
                trees.push(tree(402.5 + 5.0 * i as f32, 2.5 + 5.0 * j as f32));
            }
        }
        let r = DensityRaster::of_scene(&scene_with(trees, 800.0), &plants(), &[]);
        assert_eq!(r.resolution, [32, 32]);
        let inside = r.at(0, 600.0, 400.0);
        assert!((inside - 0.04).abs() < 1e-5, "{inside}");
        assert_eq!(r.at(0, 200.0, 400.0), 0.0);
        // The edge is blurred over about two cells.
        let edge = r.at(0, 400.0, 400.0);
        assert!(edge > 0.2 * 0.04 && edge < 0.8 * 0.04, "{edge}");
        // The total is kept.
        let total: f32 = r.texels.iter().map(|v| v[0]).sum::<f32>() * 625.0;
        assert!((total - 12_800.0).abs() < 1.0, "{total}");
        // Crown areas: the 10 m tree's r = 3 m, top π 9 m², side 60 m².
        let [a, side] = r.mean_areas();
        assert!((a - std::f32::consts::PI * 9.0).abs() < 1e-3, "{a}");
        assert!((side - 60.0).abs() < 1e-3, "{side}");
    }

    #[test]
    fn the_raster_is_bounded_whatever_the_terrain() {
        let r =
            DensityRaster::of_scene(&scene_with(vec![tree(5.0, 5.0)], 100_000.0), &plants(), &[]);
        assert_eq!(r.resolution, [MAX_TEXELS, MAX_TEXELS]);
        let r = DensityRaster::of_scene(&scene_with(vec![tree(5.0, 5.0)], 10.0), &plants(), &[]);
        assert_eq!(r.resolution, [1, 1]);
        assert!((r.at(0, 0.0, 0.0) - 0.01).abs() < 1e-6);
    }

    #[test]
    fn density_maps_are_summed_over_species() {
        use sylvan_scene::{Density, DensityMap, SeededForest, SpeciesLayout};
        // Species 0 from a 3 × 2 map (white on the east column), species 1 constant.
        let map = DensityMap {
            resolution: [3, 2],
            values: vec![0.0, 0.5, 1.0, 0.0, 0.5, 1.0],
        };
        let layouts = [
            SpeciesLayout {
                species: 0,
                height_m: [10.0, 12.0],
                density: Density::Map {
                    map,
                    max_per_ha: 400.0,
                },
            },
            SpeciesLayout {
                species: 1,
                height_m: [4.0, 5.0],
                density: Density::PerHectare(100.0),
            },
        ];
        let mut s = scene_with(Vec::new(), 300.0);
        s.seeded = SeededForest::new([300.0; 2], &layouts, 1, &[])
            .unwrap()
            .map(std::sync::Arc::new);
        let r = DensityRaster::of_scene(&s, &plants(), &[]);
        assert_eq!(r.resolution, [3, 2]);
        // Texel centres at 50, 150, 250 m: the map (edge-sampled) is 1/6, 1/2, 5/6 there.
        // Crown areas per tree: species 0 (r̂ 0.3, E[h²] = 364/3) top 0.2827 × 121.3, side
        // 0.6 × 121.3; species 1 (r̂ 1, E[h²] = 61/3) top π × 20.3, side 2 × 20.3.
        let (h0, h1) = (364.0 / 3.0, 61.0 / 3.0);
        let pi = std::f32::consts::PI;
        for (i, want) in [1.0 / 6.0, 0.5, 5.0 / 6.0].into_iter().enumerate() {
            let [d, top, side, ..] = r.texels[i];
            let (d0, d1) = (want * 0.04, 0.01);
            assert!((d - (d0 + d1)).abs() < 1e-5, "{i}: {d}");
            let top_want = d0 * 0.09 * pi * h0 + d1 * pi * h1;
            assert!(
                (top - top_want).abs() < 1e-4 * top_want,
                "{i}: {top} vs {top_want}"
            );
            let side_want = d0 * 0.6 * h0 + d1 * 2.0 * h1;
            assert!((side - side_want).abs() < 1e-4 * side_want, "{i}: {side}");
        }
    }

    #[test]
    fn placed_trees_average_to_the_scene_s_density() {
        let s = Scene::builtin_grove();
        // The built-in scene's trees are placed from its maps: the binned density averages
        // to the trees over the area.
        let r = DensityRaster::of_scene(&s, &plants(), &[]);
        let area = s.terrain.size[0] * s.terrain.size[1];
        let cells = (r.resolution[0] * r.resolution[1]) as f32;
        let mean = r.texels.iter().map(|v| v[0]).sum::<f32>() / cells;
        let want = s.trees.len() as f32 / area;
        assert!((mean - want).abs() < 0.03 * want, "{mean} vs {want}");
        assert!(
            r.max(0) > 1.3 * want,
            "the groves are denser than the mean: {} vs {want}",
            r.max(0)
        );
    }
}
