//! MNP01 §3.1's sphere samples: [`DirectionSet`], the subdivided octahedron with its cells, and
//! the exact lookup [`DirectionSet::nearest3`] by descending the subdivision hierarchy; the
//! cell tests and weights the table ([`super::DirectionLut`]) shares.

use super::{DirectionError, MAX_COMPONENT, MAX_LEVEL, NO_SCORE, SAMPLE_COUNTS};
use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Vec3};
use std::collections::HashMap;

/// MNP01's evenly spread sphere samples: the vertices of a subdivided octahedron, unit length,
/// with the spherical triangles ("cells", [`faces`](Self::faces)) between them.
///
/// Samples 0..6 are ±X, ±Y, ±Z (in that order) at every level, and each level's samples start
/// with the previous level's. Cells wind counter-clockwise seen from outside.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionSet {
    level: u32,
    pub(super) directions: Vec<Vec3>,
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
    pub(super) fn fallback(&self) -> ([u32; 3], [f32; 3]) {
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
pub(super) fn unit(dir: Vec3) -> Option<Vec3> {
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
/// The same rule as `dir_lookup` in [`DIRECTIONS_WGSL`](super::DIRECTIONS_WGSL).
pub(super) fn best_cell(
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
pub(super) fn finish(w: [f32; 3]) -> [f32; 3] {
    let w = w.map(|x| x.max(0.0));
    let sum = w[0] + w[1] + w[2];
    if sum > 0.0 {
        w.map(|x| x / sum)
    } else {
        [1.0, 0.0, 0.0]
    }
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
