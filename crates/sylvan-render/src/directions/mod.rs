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
//!
//! **Hemisphere grid (BN12 §5).** [`HemiGrid`]: the hemi-octahedral diamond grid of
//! `2(n² + n) + 1` directions over the upper hemisphere (181 at `n = 9`, BN12's count) with an
//! analytic 3-view lookup ([`HEMI_GRID_WGSL`] for shaders), used by `zfield`.

mod hemi;
mod lut;
mod set;
#[cfg(test)]
mod tests;
mod wgsl;

pub use hemi::{HEMI_GRID_WGSL, HemiGrid};
pub use lut::{DirectionLut, GpuDirTexel};
pub use set::{DirectionSet, GpuDirFace, GpuDirSample};
pub use wgsl::DIRECTIONS_WGSL;

/// MNP01 §4.1: the 9 pair weights `view_w[i] · light_w[j]` (row-major, view major) of a view
/// and a light look-up, with those below `min_weight` dropped and the rest renormalised to sum
/// to 1. When every product is below the threshold, the largest alone is kept. The same rule
/// as `dir_pair_weights` in [`DIRECTIONS_WGSL`] (a test runs both on the GPU and the CPU).
pub fn pair_weights(view_w: [f32; 3], light_w: [f32; 3], min_weight: f32) -> [f32; 9] {
    let mut w = [0.0f32; 9];
    let mut best = 0;
    for (k, out) in w.iter_mut().enumerate() {
        *out = view_w[k / 3].max(0.0) * light_w[k % 3].max(0.0);
    }
    for k in 1..9 {
        if w[k] > w[best] {
            best = k;
        }
    }
    let mut sum = 0.0;
    for x in &mut w {
        if *x < min_weight {
            *x = 0.0;
        }
        sum += *x;
    }
    if sum <= 0.0 {
        w = [0.0; 9];
        w[best] = 1.0;
        return w;
    }
    w.map(|x| x / sum)
}

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
