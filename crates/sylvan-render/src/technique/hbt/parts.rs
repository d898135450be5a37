//! The plant's own meshes split by the placements of the level below the tree, so that an
//! opened tree can draw each main branch (and its rest) either as its BTF or as its polygons
//! (MNP01 §4: "the objects in the opened levels of the hierarchy, either polygonal meshes or
//! BTF").
//!
//! The baked placements draw *representatives* (scaled and turned); the meshes must be each
//! branch's own. Each root instance of the plant's instancing is expanded in place, and every
//! triangle of the plant's own meshes goes to the instance that has a triangle with the same
//! centroid (within rounding); the others are the rest, which comes last as the rest object
//! does in the baked placements. The plant's own meshes are used, not the expansion, whose leaf
//! tints are not the plant's (per-leaf variation is not instanced). The plant hierarchy's
//! index ranges do not serve: a bracket holding only leaves is an instance but no hierarchy
//! node (its leaves are merged into the branch that bears it).

use super::bake;
use glam::Vec3;
use std::collections::HashMap;
use std::ops::Range;
use sylvan_plant::{Mesh, Plant};

/// The plant's meshes with their indices grouped by placement.
pub struct PlacementMeshes {
    /// The plant's wood and leaves: same vertices, indices reordered so that each
    /// placement's triangles are contiguous, in placement order.
    pub wood: Mesh,
    /// See `wood`.
    pub leaves: Mesh,
    /// Per baked placement (same order): its range of `wood.indices` and of `leaves.indices`.
    pub parts: Vec<[Range<u32>; 2]>,
}

/// Splits `plant`'s meshes by the placements [`bake::branch_level`] makes of it (`placements`
/// of them, the rest last). `Err` says why they could not be matched (the caller then opens
/// the tree into its meshes as a whole).
pub fn placement_meshes(plant: &Plant, placements: usize) -> Result<PlacementMeshes, String> {
    if placements == 0 {
        return Err("no level below the tree".into());
    }
    let (children, rest) = bake::split_root(plant);
    let has_rest = !rest.wood.indices.is_empty() || !rest.leaves.indices.is_empty();
    if children.len() + has_rest as usize != placements {
        return Err(format!(
            "{} branch instances and {} rest for {placements} baked placements",
            children.len(),
            has_rest as usize
        ));
    }
    let diag = (Vec3::from(plant.bbox_max) - Vec3::from(plant.bbox_min)).length();
    let tolerance = 1e-4 * diag.max(1e-3);
    let mut expanded: Vec<(u32, Plant)> = Vec::new();
    let mut grids = [Grid::new(tolerance), Grid::new(tolerance)];
    let mut expected = vec![[0usize; 2]; children.len()];
    for (c, (object, t)) in children.iter().enumerate() {
        let sub = match expanded.iter().position(|e| e.0 == *object) {
            Some(i) => &expanded[i].1,
            None => {
                expanded.push((*object, bake::object_plant(plant, *object)));
                &expanded[expanded.len() - 1].1
            }
        };
        for (kind, mesh) in [&sub.wood, &sub.leaves].into_iter().enumerate() {
            for tri in mesh.indices.chunks_exact(3) {
                grids[kind].insert(t.transform_point3(centroid(mesh, tri)), c as u32);
            }
            expected[c][kind] = mesh.indices.len() / 3;
        }
    }
    let mut found = vec![[0usize; 2]; children.len()];
    let mut split = |kind: usize, mesh: &Mesh| {
        let mut by_part: Vec<Vec<u32>> = vec![Vec::new(); children.len() + 1];
        for tri in mesh.indices.chunks_exact(3) {
            let part = grids[kind]
                .nearest(centroid(mesh, tri))
                .map_or(children.len(), |c| c as usize);
            if part < children.len() {
                found[part][kind] += 1;
            }
            by_part[part].extend_from_slice(tri);
        }
        if !has_rest && !by_part[children.len()].is_empty() {
            // Triangles that no branch claims but no rest to hold them: keep them drawn.
            let stray = std::mem::take(&mut by_part[children.len()]);
            if let Some(last) = by_part[..children.len()].last_mut() {
                last.extend(stray);
            }
        }
        let mut indices = Vec::with_capacity(mesh.indices.len());
        let mut parts = Vec::with_capacity(placements);
        for p in by_part.iter().take(placements) {
            let start = indices.len() as u32;
            indices.extend_from_slice(p);
            parts.push(start..indices.len() as u32);
        }
        (
            Mesh {
                indices,
                ..mesh.clone()
            },
            parts,
        )
    };
    let (wood, wood_parts) = split(0, &plant.wood);
    let (leaves, leaf_parts) = split(1, &plant.leaves);
    if let Some(c) = (0..children.len()).find(|&c| found[c] != expected[c]) {
        return Err(format!(
            "branch instance {c} (object {}) expands to {:?} wood/leaf triangles but {:?} of the \
             plant's match them",
            children[c].0, expected[c], found[c]
        ));
    }
    Ok(PlacementMeshes {
        wood,
        leaves,
        parts: wood_parts
            .into_iter()
            .zip(leaf_parts)
            .map(|(w, l)| [w, l])
            .collect(),
    })
}

/// Centroid of triangle `tri` of `mesh` (0 for indices out of range).
fn centroid(mesh: &Mesh, tri: &[u32]) -> Vec3 {
    tri.iter()
        .map(|&i| {
            mesh.positions
                .get(i as usize)
                .map_or(Vec3::ZERO, |p| Vec3::from(*p))
        })
        .sum::<Vec3>()
        / 3.0
}

/// Points tagged with a part, hashed by cells of the matching tolerance.
struct Grid {
    cell: f32,
    map: HashMap<[i32; 3], Vec<(Vec3, u32)>>,
}

impl Grid {
    fn new(tolerance: f32) -> Self {
        Grid {
            cell: tolerance,
            map: HashMap::new(),
        }
    }

    fn key(&self, p: Vec3) -> [i32; 3] {
        (p / self.cell).floor().as_ivec3().to_array()
    }

    fn insert(&mut self, p: Vec3, part: u32) {
        let k = self.key(p);
        self.map.entry(k).or_default().push((p, part));
    }

    /// The part of the nearest point within one cell of `p`.
    fn nearest(&self, p: Vec3) -> Option<u32> {
        let k = self.key(p);
        let mut best: Option<(f32, u32)> = None;
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let Some(v) = self.map.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) else {
                        continue;
                    };
                    for &(q, part) in v {
                        let d = q.distance_squared(p);
                        if d <= self.cell * self.cell && best.is_none_or(|b| d < b.0) {
                            best = Some((d, part));
                        }
                    }
                }
            }
        }
        best.map(|b| b.1)
    }
}
