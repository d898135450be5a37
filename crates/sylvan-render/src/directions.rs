//! Sphere direction sets and the direction → 3-sample table of MNP01 §3.1 and §4.1, shared by the
//! texture baker and every technique that samples view or light directions (first `hbt`).
//!
//! **Samples (MNP01 §3.1).** "6, 18, 66, or 258 samples … evenly distributed on a sphere": these
//! are the vertex counts of an octahedron whose 8 triangles are split into 4 by their edge
//! midpoints 0, 1, 2 or 3 times (4^k·4 + 2). [`DirectionSet`] builds exactly that, pushing every
//! midpoint back onto the sphere (great-arc midpoint), and keeps the spherical triangles: the
//! "cells bounded by 3 samples" the lookup works in (MNP01 figure 3.1, left).
//!
//! **Lookup (MNP01 §4.1).** A direction `d` blends the 3 samples of the cell that contains it with
//! "the barycentric coordinates within the cell on the sphere". We use the planar barycentrics of
//! the point where the ray `t·d` meets the cell's plane (the gnomonic projection): they are 1 on
//! a sample, 0 on the opposite edge and continuous across edges (two cells sharing an edge project
//! it to the same chord), and `Σ wᵢ sᵢ` points exactly along `d`. [`DirectionSet::nearest3`]
//! finds the cell by descending the subdivision hierarchy (8 + 4·level cell tests).
//!
//! **Precomputed table (MNP01 §4.1, figure 3.1 right).** [`DirectionLut`] is an octahedral map
//! of `R × R` texels. Each cell of the set is a straight-edged triangle in that map (within one
//! octant the map is a central projection onto a plane, which sends great arcs to lines), so each
//! texel lists every cell overlapping it (at most 8, 16-bit ids); a lookup tests those few cells
//! and recomputes the barycentrics. [`DIRECTIONS_WGSL`] is the same lookup for shaders.
//!
//! Deviations from MNP01: the paper's table "directly provides the 3 sample directions" per texel
//! (and, implicitly, weights sampled at texel resolution); ours stores candidate cells and
//! recomputes exact weights, so the table's resolution never shows as blending error and the
//! table and [`DirectionSet::nearest3`] agree exactly. The blend samples are the enclosing cell's,
//! which are not always the 3 angularly nearest samples (see the tests for what holds).

use bytemuck::{Pod, Zeroable};
use glam::{DVec2, DVec3, Vec3};
use std::collections::HashMap;

/// Subdivision levels MNP01 §3.1 uses: 0..=3.
pub const MAX_LEVEL: u32 = 3;

/// Sample counts of levels 0..=3 (MNP01 §3.1): 4^k·4 + 2.
pub const SAMPLE_COUNTS: [usize; 4] = [6, 18, 66, 258];

/// Candidate cells a [`DirectionLut`] texel can hold.
pub const TEXEL_CANDIDATES: usize = 8;

/// Marks an unused candidate slot in a [`GpuDirTexel`].
pub const NO_FACE: u16 = u16::MAX;

/// Score of a cell the direction points away from; also the lookup's starting score. Must match
/// `DIR_NO_SCORE` in [`DIRECTIONS_WGSL`].
const NO_SCORE: f32 = -3.4e38;

/// Inputs whose largest component exceeds this are treated like NaN (the WGSL has no `isinf`).
const MAX_COMPONENT: f32 = 3.4e38;

/// Table texels are widened by this fraction of a texel when listing the cells they overlap, so
/// a lookup whose rounding lands in a neighbouring texel still finds its cell.
const TEXEL_MARGIN: f64 = 0.01;

/// Why a direction set or table could not be built. Display is one line with a fix.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum DirectionError {
    /// A subdivision level outside 0..=3.
    #[error("direction-set level {0} is not supported — use 0..=3 (6, 18, 66 or 258 samples)")]
    Level(u32),
    /// A sample count MNP01 does not use.
    #[error("a set of {0} directions is not supported — use 6, 18, 66 or 258 (MNP01 §3.1)")]
    Count(usize),
    /// A table resolution outside 1..=[`DirectionLut::MAX_RESOLUTION`].
    #[error("direction table resolution {0} is out of range — use 1..=1024 (64 is the default)")]
    Resolution(u32),
    /// A texel overlaps more cells than it can list.
    #[error(
        "direction table resolution {resolution} is too coarse for {samples} directions: a texel \
         overlaps {cells} cells and at most 8 fit — use a finer resolution"
    )]
    TooCoarse {
        /// The requested resolution.
        resolution: u32,
        /// The set's sample count.
        samples: usize,
        /// The most cells one texel overlaps.
        cells: usize,
    },
}

/// MNP01's evenly spread sphere samples: the vertices of a subdivided octahedron, unit length,
/// with the spherical triangles ("cells", [`faces`](Self::faces)) between them.
///
/// Samples 0..6 are ±X, ±Y, ±Z (in that order) at every level, and each level's samples start
/// with the previous level's. Cells wind counter-clockwise seen from outside.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionSet {
    level: u32,
    directions: Vec<Vec3>,
    /// Cells of levels 0..=level; cells `4f..4f + 4` of level `l + 1` split cell `f` of level `l`.
    cells: Vec<Vec<[u32; 3]>>,
}

impl DirectionSet {
    /// The set of subdivision `level` (0..=3): 6, 18, 66 or 258 samples.
    pub fn new(level: u32) -> Result<Self, DirectionError> {
        if level > MAX_LEVEL {
            return Err(DirectionError::Level(level));
        }
        let mut points = vec![
            DVec3::X,
            -DVec3::X,
            DVec3::Y,
            -DVec3::Y,
            DVec3::Z,
            -DVec3::Z,
        ];
        let octants = (0..8u32).map(|octant| {
            let [x, y, z] = [octant & 1, (octant >> 1) & 1, (octant >> 2) & 1];
            // An even number of negative axes keeps (x, y, z) counter-clockwise from outside.
            if (x + y + z) % 2 == 0 {
                [x, 2 + y, 4 + z]
            } else {
                [x, 4 + z, 2 + y]
            }
        });
        let mut cells = vec![octants.collect::<Vec<_>>()];
        for _ in 0..level {
            let mut midpoints = HashMap::new();
            let parents = cells.last().expect("level 0 exists");
            let mut children = Vec::with_capacity(parents.len() * 4);
            for &[a, b, c] in parents {
                let ab = midpoint(&mut points, &mut midpoints, a, b);
                let bc = midpoint(&mut points, &mut midpoints, b, c);
                let ca = midpoint(&mut points, &mut midpoints, c, a);
                children.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
            }
            cells.push(children);
        }
        let directions = points.iter().map(|p| p.as_vec3()).collect();
        Ok(Self {
            level,
            directions,
            cells,
        })
    }

    /// The set with `count` samples: 6, 18, 66 or 258.
    pub fn with_count(count: usize) -> Result<Self, DirectionError> {
        let level = SAMPLE_COUNTS.iter().position(|&n| n == count);
        Self::new(level.ok_or(DirectionError::Count(count))? as u32)
    }

    /// Subdivision level, 0..=3.
    pub fn level(&self) -> u32 {
        self.level
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.directions.len()
    }

    /// Always false: every set has at least 6 samples.
    pub fn is_empty(&self) -> bool {
        self.directions.is_empty()
    }

    /// The unit sample directions.
    pub fn directions(&self) -> &[Vec3] {
        &self.directions
    }

    /// The cells: 3 sample indices each, counter-clockwise from outside; `8·4^level` of them,
    /// tiling the sphere.
    pub fn faces(&self) -> &[[u32; 3]] {
        self.cells.last().expect("level 0 exists")
    }

    /// A camera basis `(right, up, forward)` for baking sample `i`: the camera sits on the ray
    /// from the object's centre along sample `i` and looks back at it, so `forward = −sᵢ`.
    /// `up` is world +Y projected off `forward`, or +Z where `forward` is within ~2.6° of ±Y.
    /// Orthonormal and right-handed as a view basis: `right × up = −forward`.
    ///
    /// # Panics
    /// If `i >= self.len()`.
    pub fn frame(&self, i: usize) -> (Vec3, Vec3, Vec3) {
        let forward = -self.directions[i];
        let reference = if forward.y.abs() > 0.999 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        let right = forward.cross(reference).normalize();
        let up = right.cross(forward);
        (right, up, forward)
    }

    /// The 3 samples of the cell containing `dir` and their barycentric weights (MNP01 §4.1):
    /// non-negative, summing to 1, exactly `[1, 0, 0]`-like on a sample (to float rounding).
    /// `dir` need not be unit length. A zero, NaN or infinite `dir` gives cell 0's samples with
    /// weights `[1, 0, 0]`, i.e. sample 0 (+X) alone.
    pub fn nearest3(&self, dir: Vec3) -> ([u32; 3], [f32; 3]) {
        let Some(d) = unit(dir) else {
            return self.fallback();
        };
        let mut cell = best_cell(d, &self.directions, &self.cells[0], 0..8).map_or(0, |(f, _)| f);
        for level in &self.cells[1..] {
            let children = 4 * cell..4 * cell + 4;
            cell = best_cell(d, &self.directions, level, children).map_or(4 * cell, |(f, _)| f);
        }
        let face = self.faces()[cell as usize];
        (face, finish(cell_weights(d, &self.directions, face)))
    }

    /// Samples and weights for inputs with no direction.
    fn fallback(&self) -> ([u32; 3], [f32; 3]) {
        (self.faces()[0], [1.0, 0.0, 0.0])
    }

    /// The cells for a storage buffer: `xyz` = sample indices, `w` = 0.
    pub fn gpu_faces(&self) -> Vec<GpuDirFace> {
        let faces = self.faces().iter();
        faces
            .map(|&[a, b, c]| GpuDirFace {
                indices: [a, b, c, 0],
            })
            .collect()
    }

    /// The samples for a storage buffer: `xyz` = unit direction, `w` = 0.
    pub fn gpu_samples(&self) -> Vec<GpuDirSample> {
        let dirs = self.directions.iter();
        dirs.map(|d| GpuDirSample {
            direction: d.extend(0.0).to_array(),
        })
        .collect()
    }
}

/// The index of the great-arc midpoint of samples `a` and `b`, adding it on first use.
fn midpoint(points: &mut Vec<DVec3>, cache: &mut HashMap<(u32, u32), u32>, a: u32, b: u32) -> u32 {
    *cache.entry((a.min(b), a.max(b))).or_insert_with(|| {
        points.push((points[a as usize] + points[b as usize]).normalize());
        points.len() as u32 - 1
    })
}

/// `dir` scaled to unit length, or `None` for zero, NaN and infinite input. Dividing by the
/// largest component first keeps huge and subnormal inputs exact.
fn unit(dir: Vec3) -> Option<Vec3> {
    let m = dir.abs().max_element();
    (m > 0.0 && m <= MAX_COMPONENT).then(|| (dir / m).normalize())
}

/// Planar (gnomonic) barycentrics of unit `d` in cell `face`, negative outside it; `NO_SCORE`
/// everywhere when `d` points away from the cell's plane.
fn cell_weights(d: Vec3, dirs: &[Vec3], face: [u32; 3]) -> [f32; 3] {
    let [a, b, c] = face.map(|i| dirs[i as usize]);
    let w = [d.dot(b.cross(c)), d.dot(c.cross(a)), d.dot(a.cross(b))];
    let sum = w[0] + w[1] + w[2];
    if sum > 0.0 {
        w.map(|x| x / sum)
    } else {
        [NO_SCORE; 3]
    }
}

/// Of `candidates` (indices into `faces`), the cell whose smallest weight is largest, i.e. the one
/// containing `d` (first wins ties), with its weights; `None` if `d` faces away from them all.
/// The same rule as `dir_lookup` in [`DIRECTIONS_WGSL`].
fn best_cell(
    d: Vec3,
    dirs: &[Vec3],
    faces: &[[u32; 3]],
    candidates: impl IntoIterator<Item = u32>,
) -> Option<(u32, [f32; 3])> {
    let mut best = None;
    let mut best_score = NO_SCORE;
    for f in candidates {
        let w = cell_weights(d, dirs, faces[f as usize]);
        let score = w[0].min(w[1]).min(w[2]);
        if score > best_score {
            (best, best_score) = (Some((f, w)), score);
        }
    }
    best
}

/// Clamps rounding-level negative weights to 0 and renormalises.
fn finish(w: [f32; 3]) -> [f32; 3] {
    let w = w.map(|x| x.max(0.0));
    let sum = w[0] + w[1] + w[2];
    if sum > 0.0 {
        w.map(|x| x / sum)
    } else {
        [1.0, 0.0, 0.0]
    }
}

/// Octahedral-map coordinates in [−1, 1]² of a unit direction: `+Z` at the centre, the upper
/// hemisphere inside the diamond `|u| + |v| ≤ 1`, the lower one folded into the corners.
/// Identical to `dir_octahedral_uv` in [`DIRECTIONS_WGSL`].
fn octahedral_uv(d: Vec3) -> [f32; 2] {
    let p = d / (d.x.abs() + d.y.abs() + d.z.abs());
    if p.z >= 0.0 {
        return [p.x, p.y];
    }
    let sign = |x: f32| if x >= 0.0 { 1.0 } else { -1.0 };
    [(1.0 - p.y.abs()) * sign(p.x), (1.0 - p.x.abs()) * sign(p.y)]
}

/// [`octahedral_uv`] of any direction `p` of the closed octant with signs `s` (each ±1), folded as
/// that octant is: exact on the octant's boundary where the plain map is ambiguous.
fn octant_uv(p: DVec3, s: DVec3) -> DVec2 {
    let p = p / (p.x.abs() + p.y.abs() + p.z.abs());
    if s.z > 0.0 {
        DVec2::new(p.x, p.y)
    } else {
        DVec2::new((1.0 - p.y.abs()) * s.x, (1.0 - p.x.abs()) * s.y)
    }
}

/// One table texel: the ids of up to 8 cells overlapping it, unused slots [`NO_FACE`]. 16 bytes:
/// one `vec4<u32>` of a storage buffer (slot `2k` in the low half of component `k`) or one
/// `Rgba32Uint` texel.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Pod, Zeroable)]
pub struct GpuDirTexel {
    /// Cell ids, used slots first.
    pub faces: [u16; TEXEL_CANDIDATES],
}

/// One cell for the GPU: `indices[..3]` are its samples, `indices[3]` is 0.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Pod, Zeroable)]
pub struct GpuDirFace {
    /// Sample indices and padding.
    pub indices: [u32; 4],
}

/// One sample for the GPU: `direction[..3]` is the unit direction, `direction[3]` is 0.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct GpuDirSample {
    /// Direction and padding.
    pub direction: [f32; 4],
}

/// MNP01 §4.1's precomputed table from a direction to its 3 samples: an octahedral map of
/// `resolution²` texels ([`GpuDirTexel`]), each listing the cells overlapping it (widened by 1% of
/// a texel). [`lookup`](Self::lookup) tests those cells and recomputes exact weights, so it
/// returns what [`DirectionSet::nearest3`] returns.
///
/// Texel `(i, j)` is at index `j·resolution + i` and covers
/// `u ∈ [−1 + 2i/R, −1 + 2(i+1)/R]`, `v` likewise with `j`.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionLut {
    set: DirectionSet,
    resolution: u32,
    texels: Vec<GpuDirTexel>,
}

impl DirectionLut {
    /// Default resolution: 64² texels, 64 KiB; enough for 258 samples.
    pub const DEFAULT_RESOLUTION: u32 = 64;

    /// Largest resolution accepted (16 MiB).
    pub const MAX_RESOLUTION: u32 = 1024;

    /// The table of `set` at `resolution²` texels. Fails when the resolution is out of range or
    /// too coarse for the set (a texel overlapping more than 8 cells: 16 is too coarse for 258
    /// samples, 32 is enough).
    pub fn new(set: &DirectionSet, resolution: u32) -> Result<Self, DirectionError> {
        if resolution == 0 || resolution > Self::MAX_RESOLUTION {
            return Err(DirectionError::Resolution(resolution));
        }
        let r = resolution as usize;
        let mut lists: Vec<Vec<u16>> = vec![Vec::new(); r * r];
        let points: Vec<DVec3> = set.directions.iter().map(|d| d.as_dvec3()).collect();
        for (f, face) in set.faces().iter().enumerate() {
            let corners = face.map(|i| points[i as usize]);
            let signs = (corners[0] + corners[1] + corners[2]).signum();
            let tri = corners.map(|p| (octant_uv(p, signs) * 0.5 + 0.5) * f64::from(resolution));
            let lo = tri[0].min(tri[1]).min(tri[2]) - TEXEL_MARGIN;
            let hi = tri[0].max(tri[1]).max(tri[2]) + TEXEL_MARGIN;
            let first = lo.floor().max(DVec2::ZERO).as_uvec2();
            let last = hi.floor().min(DVec2::splat(r as f64 - 1.0)).as_uvec2();
            for j in first.y..=last.y {
                for i in first.x..=last.x {
                    let centre = DVec2::new(f64::from(i), f64::from(j)) + 0.5;
                    if triangle_overlaps_square(tri, centre, 0.5 + TEXEL_MARGIN) {
                        lists[j as usize * r + i as usize].push(f as u16);
                    }
                }
            }
        }
        let cells = lists.iter().map(Vec::len).max().unwrap_or(0);
        if cells > TEXEL_CANDIDATES {
            return Err(DirectionError::TooCoarse {
                resolution,
                samples: set.len(),
                cells,
            });
        }
        let texels = lists.iter().map(|list| {
            let mut faces = [NO_FACE; TEXEL_CANDIDATES];
            faces[..list.len()].copy_from_slice(list);
            GpuDirTexel { faces }
        });
        Ok(Self {
            set: set.clone(),
            resolution,
            texels: texels.collect(),
        })
    }

    /// The direction set the table indexes.
    pub fn set(&self) -> &DirectionSet {
        &self.set
    }

    /// Texels per side.
    pub fn resolution(&self) -> u32 {
        self.resolution
    }

    /// The texels, row-major.
    pub fn texels(&self) -> &[GpuDirTexel] {
        &self.texels
    }

    /// The texels as bytes, for the `dir_texels` storage buffer (or an `Rgba32Uint` texture).
    pub fn as_bytes(&self) -> &[u8] {
        bytemuck::cast_slice(&self.texels)
    }

    /// GPU bytes of the three buffers `dir_texels`, `dir_faces`, `dir_samples`.
    pub fn bytes(&self) -> usize {
        self.texels.len() * size_of::<GpuDirTexel>()
            + self.set.faces().len() * size_of::<GpuDirFace>()
            + self.set.len() * size_of::<GpuDirSample>()
    }

    /// The most cells any texel lists (1..=8).
    pub fn max_candidates(&self) -> usize {
        let used = |t: &GpuDirTexel| t.faces.iter().take_while(|&&f| f != NO_FACE).count();
        self.texels.iter().map(used).max().unwrap_or(0)
    }

    /// [`DirectionSet::nearest3`] through the table: the texel under `dir`, the best of its cells,
    /// weights recomputed from that cell. Same fallback for zero, NaN and infinite `dir`.
    pub fn lookup(&self, dir: Vec3) -> ([u32; 3], [f32; 3]) {
        let Some(d) = unit(dir) else {
            return self.set.fallback();
        };
        let [u, v] = octahedral_uv(d);
        let texel = |x: f32| {
            let t = ((x * 0.5 + 0.5) * self.resolution as f32).floor();
            t.clamp(0.0, (self.resolution - 1) as f32) as usize
        };
        let listed = self.texels[texel(v) * self.resolution as usize + texel(u)].faces;
        let candidates = listed
            .into_iter()
            .take_while(|&f| f != NO_FACE)
            .map(u32::from);
        match best_cell(d, &self.set.directions, self.set.faces(), candidates) {
            Some((f, w)) => (self.set.faces()[f as usize], finish(w)),
            None => self.set.fallback(),
        }
    }

    /// WGSL declarations of the three storage buffers [`DIRECTIONS_WGSL`] reads, at bindings
    /// `first_binding..first_binding + 3` of `group`: `dir_texels` ([`as_bytes`](Self::as_bytes)),
    /// `dir_faces` ([`DirectionSet::gpu_faces`]), `dir_samples` ([`DirectionSet::gpu_samples`]).
    /// Put it before [`DIRECTIONS_WGSL`].
    pub fn bindings_wgsl(group: u32, first_binding: u32) -> String {
        let names = [
            ("dir_texels", "u32"),
            ("dir_faces", "u32"),
            ("dir_samples", "f32"),
        ];
        let lines = names
            .iter()
            .zip(first_binding..)
            .map(|((name, scalar), binding)| {
                format!(
                    "@group({group}) @binding({binding}) \
                 var<storage, read> {name}: array<vec4<{scalar}>>;\n"
                )
            });
        lines.collect()
    }
}

/// Whether the 2-D triangle `tri` overlaps the axis-aligned square at `centre` with half-size
/// `half` (separating axes: the square's two and the triangle's three edge normals).
fn triangle_overlaps_square(tri: [DVec2; 3], centre: DVec2, half: f64) -> bool {
    let tri = tri.map(|p| p - centre);
    let lo = tri[0].min(tri[1]).min(tri[2]);
    let hi = tri[0].max(tri[1]).max(tri[2]);
    if lo.x > half || lo.y > half || hi.x < -half || hi.y < -half {
        return false;
    }
    (0..3).all(|k| {
        let edge = tri[(k + 1) % 3] - tri[k];
        let n = DVec2::new(-edge.y, edge.x);
        let proj = tri.map(|p| p.dot(n));
        let reach = half * (n.x.abs() + n.y.abs());
        proj.iter().copied().fold(f64::INFINITY, f64::min) <= reach
            && proj.iter().copied().fold(f64::NEG_INFINITY, f64::max) >= -reach
    })
}

/// WGSL of [`DirectionLut::lookup`]: `fn dir_lookup(d: vec3<f32>) -> DirLookup` returns the 3
/// sample indices and weights for direction `d` (any length). Put
/// [`DirectionLut::bindings_wgsl`] (or equivalent declarations of `dir_texels`, `dir_faces`,
/// `dir_samples`) before it; the table's resolution comes from `arrayLength(&dir_texels)`.
/// Zero, NaN and infinite `d` give cell 0 with weights (1, 0, 0) where the driver keeps NaN
/// comparisons IEEE. One shader can hold one table (names are fixed).
pub const DIRECTIONS_WGSL: &str = r#"
// MNP01 §4.1 direction table lookup (sylvan_render::directions).
const DIR_NO_FACE: u32 = 0xffffu;
const DIR_NO_SCORE: f32 = -3.4e38;
const DIR_MAX_COMPONENT: f32 = 3.4e38;

struct DirLookup {
    indices: vec3<u32>,
    weights: vec3<f32>,
}

fn dir_octahedral_uv(d: vec3<f32>) -> vec2<f32> {
    let p = d / (abs(d.x) + abs(d.y) + abs(d.z));
    if p.z >= 0.0 {
        return p.xy;
    }
    let s = select(vec2<f32>(-1.0), vec2<f32>(1.0), p.xy >= vec2<f32>(0.0));
    return (vec2<f32>(1.0) - abs(p.yx)) * s;
}

fn dir_cell_weights(d: vec3<f32>, face: vec3<u32>) -> vec3<f32> {
    let a = dir_samples[face.x].xyz;
    let b = dir_samples[face.y].xyz;
    let c = dir_samples[face.z].xyz;
    let w = vec3<f32>(dot(d, cross(b, c)), dot(d, cross(c, a)), dot(d, cross(a, b)));
    let sum = w.x + w.y + w.z;
    if sum > 0.0 {
        return w / sum;
    }
    return vec3<f32>(DIR_NO_SCORE);
}

fn dir_lookup(d_in: vec3<f32>) -> DirLookup {
    var out = DirLookup(dir_faces[0].xyz, vec3<f32>(1.0, 0.0, 0.0));
    let m = max(max(abs(d_in.x), abs(d_in.y)), abs(d_in.z));
    if !(m > 0.0 && m <= DIR_MAX_COMPONENT) {
        return out;
    }
    let d = normalize(d_in / m);
    let r = u32(round(sqrt(f32(arrayLength(&dir_texels)))));
    let t = floor((dir_octahedral_uv(d) * 0.5 + 0.5) * f32(r));
    let texel_xy = vec2<u32>(clamp(t, vec2<f32>(0.0), vec2<f32>(f32(r - 1u))));
    let texel = dir_texels[texel_xy.y * r + texel_xy.x];
    var best = DIR_NO_SCORE;
    for (var k = 0u; k < 8u; k++) {
        let id = (texel[k >> 1u] >> ((k & 1u) * 16u)) & 0xffffu;
        if id == DIR_NO_FACE {
            break;
        }
        let face = dir_faces[id].xyz;
        let w = dir_cell_weights(d, face);
        let score = min(w.x, min(w.y, w.z));
        if score > best {
            best = score;
            out = DirLookup(face, w);
        }
    }
    let w = max(out.weights, vec3<f32>(0.0));
    let sum = w.x + w.y + w.z;
    out.weights = select(vec3<f32>(1.0, 0.0, 0.0), w / sum, sum > 0.0);
    return out;
}
"#;

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// xorshift64*: a seeded stream of uniform unit directions (no RNG dependency).
    struct Rng(u64);

    impl Rng {
        fn f32(&mut self) -> f32 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 40) as f32 / (1u64 << 24) as f32
        }

        fn direction(&mut self) -> Vec3 {
            let z = 2.0 * self.f32() - 1.0;
            let phi = std::f32::consts::TAU * self.f32();
            let r = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        }
    }

    fn sets() -> Vec<DirectionSet> {
        (0..=MAX_LEVEL)
            .map(|l| DirectionSet::new(l).unwrap())
            .collect()
    }

    fn angle(a: Vec3, b: Vec3) -> f64 {
        a.as_dvec3().angle_between(b.as_dvec3())
    }

    /// Samples sorted by angle from `d`.
    fn by_angle(set: &DirectionSet, d: Vec3) -> Vec<u32> {
        let mut order: Vec<u32> = (0..set.len() as u32).collect();
        let key = |i: &u32| angle(d, set.directions()[*i as usize]);
        order.sort_by(|a, b| key(a).total_cmp(&key(b)));
        order
    }

    /// `(indices, weights)` as a map from index to total weight, dropping zeros.
    fn weight_map((ids, w): ([u32; 3], [f32; 3])) -> HashMap<u32, f32> {
        let mut map = HashMap::new();
        for (i, w) in ids.into_iter().zip(w).filter(|(_, w)| *w > 0.0) {
            *map.entry(i).or_insert(0.0) += w;
        }
        map
    }

    fn map_distance(a: &HashMap<u32, f32>, b: &HashMap<u32, f32>) -> f32 {
        let keys: std::collections::HashSet<_> = a.keys().chain(b.keys()).collect();
        keys.iter()
            .map(|k| (a.get(k).unwrap_or(&0.0) - b.get(k).unwrap_or(&0.0)).abs())
            .sum()
    }

    #[test]
    fn counts_are_mnp01s() {
        for (level, set) in sets().iter().enumerate() {
            assert_eq!(set.len(), SAMPLE_COUNTS[level]);
            assert_eq!(set.len(), 4usize.pow(level as u32) * 4 + 2);
            assert_eq!(set.faces().len(), 8 * 4usize.pow(level as u32));
            assert_eq!(DirectionSet::with_count(set.len()).unwrap(), *set);
            assert_eq!(set.directions()[..6], sets()[0].directions()[..]);
        }
        assert_eq!(DirectionSet::new(4), Err(DirectionError::Level(4)));
        assert_eq!(DirectionSet::with_count(64), Err(DirectionError::Count(64)));
        assert!(
            DirectionError::Count(64)
                .to_string()
                .contains("6, 18, 66 or 258")
        );
    }

    #[test]
    fn samples_are_unit_distinct_and_antipodal() {
        for set in sets() {
            for (i, d) in set.directions().iter().enumerate() {
                assert!(
                    (d.length() - 1.0).abs() < 1e-6,
                    "sample {i} has length {}",
                    d.length()
                );
                let opposite = set.directions().iter().any(|e| (*d + *e).length() < 1e-6);
                assert!(opposite, "sample {i}'s antipode is missing");
            }
        }
    }

    /// Spread: the closest pair of samples vs the loneliest sample's nearest neighbour. Measured
    /// for 6/18/66/258 samples: 1, 1, 0.922 (22.5° vs 24.4°), 0.728 (11.25° vs 15.5°).
    /// Re-normalised midpoints crowd the 6 octahedron corners (degree 4) and stretch cells near
    /// octant centres; the bounds keep that within 1/0.7 ≈ 1.4× and catch a wrong subdivision
    /// (an unnormalised or misplaced midpoint halves the ratio).
    #[test]
    fn samples_are_evenly_spread() {
        let bounds = [0.999, 0.999, 0.9, 0.7];
        for (set, bound) in sets().iter().zip(bounds) {
            let dirs = set.directions();
            let nn: Vec<f64> = (0..dirs.len())
                .map(|i| {
                    let others = (0..dirs.len()).filter(|&j| j != i);
                    others
                        .map(|j| angle(dirs[i], dirs[j]))
                        .fold(f64::INFINITY, f64::min)
                })
                .collect();
            let min = nn.iter().copied().fold(f64::INFINITY, f64::min);
            let max = nn.iter().copied().fold(0.0, f64::max);
            eprintln!(
                "{} samples: min pair {:.2}°, max nearest-neighbour {:.2}°, ratio {:.3}",
                dirs.len(),
                min.to_degrees(),
                max.to_degrees(),
                min / max
            );
            assert!(
                min / max >= bound,
                "{} samples: spread ratio {}",
                dirs.len(),
                min / max
            );
        }
    }

    #[test]
    fn cells_tile_the_sphere() {
        for set in sets() {
            let dirs: Vec<DVec3> = set.directions().iter().map(|d| d.as_dvec3()).collect();
            let mut area = 0.0;
            let mut edges = std::collections::HashSet::new();
            for &[a, b, c] in set.faces() {
                let [a3, b3, c3] = [a, b, c].map(|i| dirs[i as usize]);
                let det = a3.dot(b3.cross(c3));
                assert!(det > 0.0, "cell {a} {b} {c} winds clockwise");
                // Van Oosterom–Strackee: tan(E/2) = det / (1 + a·b + b·c + c·a).
                area += 2.0 * det.atan2(1.0 + a3.dot(b3) + b3.dot(c3) + c3.dot(a3));
                for edge in [(a, b), (b, c), (c, a)] {
                    assert!(edges.insert(edge), "edge {edge:?} used twice the same way");
                }
            }
            assert!(
                (area - 4.0 * PI).abs() < 1e-4,
                "{} samples: area {area}",
                set.len()
            );
            assert!(
                edges.iter().all(|&(a, b)| edges.contains(&(b, a))),
                "the mesh has a hole"
            );
            assert_eq!(edges.len() / 2, set.len() + set.faces().len() - 2, "Euler");
        }
    }

    /// For 10,000 random directions per set: weights are a partition of unity, blend the samples
    /// back onto the input (gnomonic barycentrics: `Σ wᵢ sᵢ ∥ d`), the angularly nearest sample
    /// is always one of the 3, and the largest weight is always on one of the 3 nearest.
    /// Measured for 6/18/66/258 samples: the largest weight is on the nearest sample for
    /// 100/92.7/92.8/92.6% of directions; the 3 are exactly the 3 nearest for 100/69.5/66.8/70.7%
    /// (near an edge's middle, the neighbouring cell's far corner can be as near as our own).
    #[test]
    fn nearest3_blends_the_enclosing_cell() {
        for set in sets() {
            let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
            let (mut top_is_nearest, mut same_three) = (0, 0);
            for _ in 0..10_000 {
                let d = rng.direction();
                let (ids, w) = set.nearest3(d);
                assert!(w.iter().all(|&x| x >= 0.0), "{d}: negative weight {w:?}");
                assert!(
                    (w.iter().sum::<f32>() - 1.0).abs() < 1e-5,
                    "{d}: weights {w:?}"
                );
                let blend: Vec3 = (0..3)
                    .map(|k| w[k] * set.directions()[ids[k] as usize])
                    .sum();
                assert!(blend.normalize().dot(d) > 1.0 - 1e-6, "{d}: blend {blend}");

                let order = by_angle(&set, d);
                assert!(
                    ids.contains(&order[0]),
                    "{d}: nearest {} not in {ids:?}",
                    order[0]
                );
                let top = ids[(0..3).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap()];
                assert!(
                    order[..3].contains(&top),
                    "{d}: top {top} not among 3 nearest"
                );
                top_is_nearest += usize::from(top == order[0]);
                same_three += usize::from(ids.iter().all(|i| order[..3].contains(i)));
            }
            eprintln!(
                "{} samples: top weight on nearest {:.1}%, same 3 as nearest {:.1}%",
                set.len(),
                top_is_nearest as f64 / 100.0,
                same_three as f64 / 100.0
            );
            assert!(top_is_nearest >= 9_000 && same_three >= 6_000);
        }
    }

    #[test]
    fn nearest3_is_exact_on_samples_and_edges() {
        for set in sets() {
            for (i, &s) in set.directions().iter().enumerate() {
                let map = weight_map(set.nearest3(s));
                let w = map.get(&(i as u32)).copied().unwrap_or(0.0);
                assert!(w > 1.0 - 1e-6, "sample {i}: own weight {w}");
            }
            for &[a, b, _] in set.faces() {
                let [sa, sb] = [a, b].map(|i| set.directions()[i as usize]);
                let map = weight_map(set.nearest3(sa + sb));
                for i in [a, b] {
                    let w = map.get(&i).copied().unwrap_or(0.0);
                    assert!(
                        (w - 0.5).abs() < 1e-5,
                        "edge {a}-{b} midpoint: weights {map:?}"
                    );
                }
            }
        }
    }

    /// Weights move continuously: across every edge, and for random small steps, the weights
    /// (L1 over samples) change by at most 30× the angle moved (measured up to 14.5× for 258
    /// samples over 200,000 steps: about twice the inverse cell height; a jump to a wrong cell
    /// changes them by O(1), i.e. ~10⁴× a 10⁻⁴ step).
    #[test]
    fn nearest3_is_continuous() {
        let set = DirectionSet::new(MAX_LEVEL).unwrap();
        let step = 1e-4;
        for &[a, b, _] in set.faces() {
            let [sa, sb] = [a, b].map(|i| set.directions()[i as usize]);
            let across = sa.cross(sb).normalize() * step;
            for t in [0.1, 0.5, 0.9] {
                let on = sa.lerp(sb, t);
                let (left, right) = (set.nearest3(on + across), set.nearest3(on - across));
                let jump = map_distance(&weight_map(left), &weight_map(right));
                assert!(
                    jump < 30.0 * 2.0 * step,
                    "edge {a}-{b} at {t}: weights jump by {jump}"
                );
            }
        }
        let mut rng = Rng(7);
        for _ in 0..10_000 {
            let d = rng.direction();
            let e = (d + rng.direction() * step).normalize();
            let jump = map_distance(&weight_map(set.nearest3(d)), &weight_map(set.nearest3(e)));
            assert!(
                jump < 30.0 * angle(d, e) as f32 + 1e-6,
                "{d} → {e}: weights jump by {jump}"
            );
        }
    }

    #[test]
    fn degenerate_directions_do_not_panic() {
        for set in sets() {
            let lut = DirectionLut::new(&set, DirectionLut::DEFAULT_RESOLUTION).unwrap();
            let fallback = (set.faces()[0], [1.0, 0.0, 0.0]);
            assert_eq!(set.faces()[0][0], 0);
            for bad in [Vec3::ZERO, Vec3::NAN, Vec3::new(f32::INFINITY, 0.0, 1.0)] {
                assert_eq!(set.nearest3(bad), fallback, "{bad}");
                assert_eq!(lut.lookup(bad), fallback, "{bad}");
            }
            // Power-of-two scales keep the direction exact, down to subnormals and up to overflow.
            let d = Vec3::new(3.0, -5.0, 8.0);
            for scaled in [d * 2f32.powi(-145), d * 2f32.powi(-60), d * 2f32.powi(124)] {
                assert_eq!(set.nearest3(scaled), set.nearest3(d), "{scaled}");
                assert_eq!(lut.lookup(scaled), lut.lookup(d), "{scaled}");
            }
        }
    }

    /// The table gives `nearest3`'s answer: the same 3 samples and weights for 10,000 random
    /// directions, and the same blend on samples, edges and the octant boundaries where the
    /// octahedral map folds (there a tie between two cells may pick either, with weight 0 on
    /// the differing sample).
    #[test]
    fn lut_matches_nearest3() {
        for set in sets() {
            for resolution in [32, DirectionLut::DEFAULT_RESOLUTION, 128] {
                let lut = DirectionLut::new(&set, resolution).unwrap();
                let mut rng = Rng(0xDEAD_BEEF);
                for _ in 0..10_000 {
                    let d = rng.direction();
                    let ((ids, w), (lut_ids, lut_w)) = (set.nearest3(d), lut.lookup(d));
                    let mut sorted = [ids, lut_ids];
                    sorted.iter_mut().for_each(|s| s.sort());
                    assert_eq!(sorted[0], sorted[1], "{d}: {ids:?} vs table {lut_ids:?}");
                    let map = weight_map((lut_ids, lut_w));
                    for (i, w) in ids.iter().zip(w) {
                        let diff = (map.get(i).copied().unwrap_or(0.0) - w).abs();
                        assert!(diff <= 1e-5, "{d}: sample {i} weight differs by {diff}");
                    }
                }
                let mut special: Vec<Vec3> = set.directions().to_vec();
                for &[a, b, _] in set.faces() {
                    let [sa, sb] = [a, b].map(|i| set.directions()[i as usize]);
                    special.extend([sa + sb, sa.lerp(sb, 0.3)]);
                }
                for k in 0..200 {
                    let (c, s) = (k as f32 * 0.0314).sin_cos();
                    special.extend([Vec3::new(c, 0.0, s), Vec3::new(0.0, c, s)]);
                    special.extend([Vec3::new(c, s, 0.0), Vec3::new(c, -0.0, -s.abs())]);
                }
                for d in special {
                    let (a, b) = (weight_map(set.nearest3(d)), weight_map(lut.lookup(d)));
                    assert!(map_distance(&a, &b) < 1e-5, "{d}: {a:?} vs table {b:?}");
                }
            }
        }
    }

    #[test]
    fn lut_size_and_limits() {
        let set = DirectionSet::new(MAX_LEVEL).unwrap();
        let lut = DirectionLut::new(&set, DirectionLut::DEFAULT_RESOLUTION).unwrap();
        assert_eq!(size_of::<GpuDirTexel>(), 16);
        assert_eq!(lut.as_bytes().len(), 64 * 64 * 16);
        assert_eq!(lut.bytes(), 64 * 64 * 16 + 512 * 16 + 258 * 16);
        for r in [16, 32, 64, 128] {
            match DirectionLut::new(&set, r) {
                Ok(lut) => eprintln!("resolution {r}: ≤ {} cells per texel", lut.max_candidates()),
                Err(e) => eprintln!("resolution {r}: {e}"),
            }
        }
        assert!(matches!(
            DirectionLut::new(&set, 8),
            Err(DirectionError::TooCoarse { .. })
        ));
        assert_eq!(
            DirectionLut::new(&set, 0),
            Err(DirectionError::Resolution(0))
        );
        assert_eq!(
            DirectionLut::new(&set, 4096),
            Err(DirectionError::Resolution(4096))
        );
        assert!(
            DirectionLut::new(&sets()[0], 1).is_ok(),
            "8 cells fit one texel"
        );
        let faces = set.gpu_faces();
        assert_eq!(faces[5].indices[..3], set.faces()[5]);
        assert_eq!(
            set.gpu_samples()[7].direction[..3],
            set.directions()[7].to_array()
        );
    }

    #[test]
    fn frames_are_right_handed_cameras() {
        let set = DirectionSet::new(MAX_LEVEL).unwrap();
        for (i, &s) in set.directions().iter().enumerate() {
            let (right, up, forward) = set.frame(i);
            assert!(
                forward.abs_diff_eq(-s, 1e-6),
                "sample {i}: forward {forward}"
            );
            for (v, name) in [(right, "right"), (up, "up")] {
                assert!(
                    (v.length() - 1.0).abs() < 1e-5,
                    "sample {i}: |{name}| = {}",
                    v.length()
                );
            }
            assert!(right.dot(up).abs() < 1e-5 && right.dot(forward).abs() < 1e-5);
            assert!(up.dot(forward).abs() < 1e-5);
            assert!(
                right.cross(up).abs_diff_eq(-forward, 1e-5),
                "sample {i}: left-handed"
            );
            if s.y.abs() < 0.999 {
                assert!(
                    up.y > 0.0 && right.y.abs() < 1e-6,
                    "sample {i}: camera rolled"
                );
            }
        }
    }

    #[test]
    fn wgsl_validates() {
        let source = format!(
            "{}{DIRECTIONS_WGSL}\n\
             @group(0) @binding(3) var<storage, read_write> out: array<vec4<f32>>;\n\
             @compute @workgroup_size(64)\n\
             fn main(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
                 let l = dir_lookup(out[id.x].xyz);\n\
                 out[id.x] = vec4<f32>(l.weights, f32(l.indices.x + l.indices.y + l.indices.z));\n\
             }}\n",
            DirectionLut::bindings_wgsl(0, 0)
        );
        let module = naga::front::wgsl::parse_str(&source)
            .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&source)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&source)));
    }
}
