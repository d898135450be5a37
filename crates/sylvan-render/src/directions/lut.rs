//! MNP01 §4.1's precomputed table (figure 3.1 right): [`DirectionLut`], an octahedral map whose
//! texels list the cells overlapping them, and its lookup.

use super::set::{best_cell, finish, unit};
use super::{DirectionError, DirectionSet, GpuDirFace, GpuDirSample, NO_FACE, TEXEL_CANDIDATES};
use bytemuck::{Pod, Zeroable};
use glam::{DVec2, DVec3, Vec3};

/// Table texels are widened by this fraction of a texel when listing the cells they overlap, so
/// a lookup whose rounding lands in a neighbouring texel still finds its cell.
const TEXEL_MARGIN: f64 = 0.01;

/// Octahedral-map coordinates in [−1, 1]² of a unit direction: `+Z` at the centre, the upper
/// hemisphere inside the diamond `|u| + |v| ≤ 1`, the lower one folded into the corners.
/// Identical to `dir_octahedral_uv` in [`DIRECTIONS_WGSL`](super::DIRECTIONS_WGSL).
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

    /// WGSL declarations of the three storage buffers [`DIRECTIONS_WGSL`](super::DIRECTIONS_WGSL) reads, at bindings
    /// `first_binding..first_binding + 3` of `group`: `dir_texels` ([`as_bytes`](Self::as_bytes)),
    /// `dir_faces` ([`DirectionSet::gpu_faces`]), `dir_samples` ([`DirectionSet::gpu_samples`]).
    /// with the accessors it calls and `fn dir_lookup(d: vec3<f32>) -> DirLookup` over this one
    /// table.
    pub fn bindings_wgsl(group: u32, first_binding: u32) -> String {
        let names = [
            ("dir_texels", "u32"),
            ("dir_faces", "u32"),
            ("dir_samples", "f32"),
        ];
        let lines: String = names
            .iter()
            .zip(first_binding..)
            .map(|((name, scalar), binding)| {
                format!(
                    "@group({group}) @binding({binding}) \
                 var<storage, read> {name}: array<vec4<{scalar}>>;\n"
                )
            })
            .collect();
        lines
            + "fn dir_texel(row: u32) -> vec4<u32> { return dir_texels[row]; }\n\
               fn dir_face(row: u32) -> vec4<u32> { return dir_faces[row]; }\n\
               fn dir_sample(row: u32) -> vec4<f32> { return dir_samples[row]; }\n\
               fn dir_lookup(d: vec3<f32>) -> DirLookup {\n\
               \x20   let r = u32(round(sqrt(f32(arrayLength(&dir_texels)))));\n\
               \x20   return dir_lookup_in(d, DirTable(0u, r, 0u, 0u));\n\
               }\n"
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
