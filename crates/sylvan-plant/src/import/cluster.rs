//! A hierarchy for imported meshes, so that the techniques written for L-system plants (LCV04
//! box trees, MNP01 levels) apply to artist trees too.
//!
//! Wood is split into connected pieces (vertices welded by position); each piece is a branch.
//! The piece holding the lowest vertex is the trunk (root); every other piece hangs from the
//! piece it comes closest to (its attachment point), and a breadth-first walk from the trunk
//! turns those links into a tree. Leaves are the leaf mesh's blades — triangles joined across
//! shared edges whose ends agree in position and texture coordinates (`blades`) — clustered
//! around the branch whose wood is nearest to their centre. When the wood is a single piece (merged
//! meshes) the leaves are clustered spatially instead: recursive median splits along the
//! longest axis, down to [`LEAVES_PER_CLUSTER`] leaves. Deviation: this is a heuristic, not a
//! reconstruction of the modelling tool's own hierarchy.
//!
//! Triangles are reordered so that each subtree's leaves and wood are contiguous ranges, as
//! for L-system plants.

use crate::hierarchy::{Aabb, BranchNode, Hierarchy};
use crate::mesh::Mesh;
use glam::Vec3;
use std::collections::HashMap;

/// Leaves per spatial cluster when the wood gives no branch structure.
pub const LEAVES_PER_CLUSTER: usize = 48;

/// Most wood surface samples used to attach leaves to branches.
pub const MAX_SAMPLES: usize = 4_000_000;

/// Welded vertex numbers: vertices within 10⁻⁵ of the mesh's diagonal of each other (and, with
/// `uv`, within 10⁻⁵ in texture coordinates) get one number. Returns them and their count.
fn weld(m: &Mesh, uv: bool) -> (Vec<u32>, usize) {
    let diag = {
        let mut b = Aabb::default();
        for p in &m.positions {
            b.add(Vec3::from(*p));
        }
        if b.is_empty() {
            1.0
        } else {
            (b.max - b.min).length().max(1e-6)
        }
    };
    let (q, quv) = (diag * 1e-5, 1e-5f32);
    let mut weld: HashMap<[i64; 5], u32> = HashMap::new();
    let ids = m
        .positions
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let t = if uv {
                m.uvs.get(i).copied().unwrap_or([0.0; 2])
            } else {
                [0.0; 2]
            };
            let k = [
                (p[0] / q).round() as i64,
                (p[1] / q).round() as i64,
                (p[2] / q).round() as i64,
                (t[0] / quv).round() as i64,
                (t[1] / quv).round() as i64,
            ];
            let n = weld.len() as u32;
            *weld.entry(k).or_insert(n)
        })
        .collect();
    (ids, weld.len())
}

/// Union-find root, with path halving.
fn find(p: &mut [u32], mut x: u32) -> u32 {
    while p[x as usize] != x {
        p[x as usize] = p[p[x as usize] as usize];
        x = p[x as usize];
    }
    x
}

/// Connected pieces of a mesh (vertices welded by position): per triangle, its piece; and the
/// piece count.
fn pieces(m: &Mesh) -> (Vec<u32>, usize) {
    let (ids, nv) = weld(m, false);
    let mut parent: Vec<u32> = (0..nv as u32).collect();
    for t in m.indices.chunks_exact(3) {
        let a = find(&mut parent, ids[t[0] as usize]);
        for &v in &t[1..] {
            let b = find(&mut parent, ids[v as usize]);
            if a != b {
                parent[b as usize] = a;
            }
        }
    }
    let mut label: HashMap<u32, u32> = HashMap::new();
    let tri_piece = m
        .indices
        .chunks_exact(3)
        .map(|t| {
            let r = find(&mut parent, ids[t[0] as usize]);
            let n = label.len() as u32;
            *label.entry(r).or_insert(n)
        })
        .collect();
    (tri_piece, label.len())
}

/// Blades of a leaf mesh: per triangle, its blade; and the blade count. Two triangles are one
/// blade when they share an edge whose two ends agree in position and texture coordinates
/// (welded within 10⁻⁵ of the mesh's diagonal and 10⁻⁵ in uv), so that
/// - leaflets meeting at a point (a palmate leaf's petiole tip) are separate leaves, as the
///   L-system presets make them;
/// - a flat-shaded export (each triangle its own vertices, split normals) still joins;
/// - a blade never spans a texture seam, so each blade has one affine map from its texture to
///   its surface (what `billboard-cloud` fits per leaf).
fn blades(m: &Mesh) -> (Vec<u32>, usize) {
    let (ids, _) = weld(m, true);
    let nt = m.indices.len() / 3;
    let mut parent: Vec<u32> = (0..nt as u32).collect();
    let mut edges: HashMap<(u32, u32), u32> = HashMap::with_capacity(nt * 3 / 2);
    for (t, tri) in m.indices.chunks_exact(3).enumerate() {
        for e in 0..3 {
            let (a, b) = (ids[tri[e] as usize], ids[tri[(e + 1) % 3] as usize]);
            if a == b {
                continue;
            }
            let key = (a.min(b), a.max(b));
            match edges.entry(key) {
                std::collections::hash_map::Entry::Occupied(o) => {
                    let (x, y) = (find(&mut parent, *o.get()), find(&mut parent, t as u32));
                    if x != y {
                        parent[y as usize] = x;
                    }
                }
                std::collections::hash_map::Entry::Vacant(v) => {
                    v.insert(t as u32);
                }
            }
        }
    }
    let mut label: HashMap<u32, u32> = HashMap::new();
    let tri_blade = (0..nt as u32)
        .map(|t| {
            let r = find(&mut parent, t);
            let n = label.len() as u32;
            *label.entry(r).or_insert(n)
        })
        .collect();
    (tri_blade, label.len())
}

/// Lexicographic order of points (a tie-break independent of vertex order).
fn before(a: &[f32; 3], b: &[f32; 3]) -> bool {
    (a[0], a[1], a[2]) < (b[0], b[1], b[2])
}

/// A uniform grid of points for nearest-point queries.
struct Grid {
    cell: f32,
    map: HashMap<[i32; 3], Vec<u32>>,
}

impl Grid {
    fn new(points: &[[f32; 3]], cell: f32) -> Self {
        let mut map: HashMap<[i32; 3], Vec<u32>> = HashMap::new();
        for (i, p) in points.iter().enumerate() {
            map.entry(Self::key(p, cell)).or_default().push(i as u32);
        }
        Grid { cell, map }
    }
    fn key(p: &[f32; 3], cell: f32) -> [i32; 3] {
        [
            (p[0] / cell).floor() as i32,
            (p[1] / cell).floor() as i32,
            (p[2] / cell).floor() as i32,
        ]
    }
    /// Nearest point accepted by `ok` within `rings` cells.
    fn nearest(
        &self,
        points: &[[f32; 3]],
        q: Vec3,
        rings: i32,
        ok: impl Fn(u32) -> bool,
    ) -> Option<(u32, f32)> {
        let k = Self::key(&q.to_array(), self.cell);
        let mut best: Option<(u32, f32)> = None;
        for r in 0..=rings {
            for dx in -r..=r {
                for dy in -r..=r {
                    for dz in -r..=r {
                        if dx.abs().max(dy.abs()).max(dz.abs()) != r {
                            continue;
                        }
                        if let Some(list) = self.map.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) {
                            for &i in list {
                                if !ok(i) {
                                    continue;
                                }
                                let d = Vec3::from(points[i as usize]).distance_squared(q);
                                // Ties go to the lexicographically smaller point, so that the
                                // answer does not depend on the order of the points.
                                if best.is_none_or(|(b, bd)| {
                                    d < bd
                                        || (d == bd
                                            && before(&points[i as usize], &points[b as usize]))
                                }) {
                                    best = Some((i, d));
                                }
                            }
                        }
                    }
                }
            }
            // One more ring after a hit guarantees the true nearest within the searched cube.
            if let Some((_, d)) = best
                && d.sqrt() <= r as f32 * self.cell
            {
                break;
            }
        }
        best
    }
}

/// Builds the hierarchy and reorders the index buffers of `wood` and `leaves` to match.
/// Returns the hierarchy and the number of leaves (blades, see `blades`).
pub fn build(wood: &mut Mesh, leaves: &mut Mesh) -> (Hierarchy, usize) {
    let (wood_piece, nw) = pieces(wood);
    let (leaf_piece, nl) = blades(leaves);
    // Leaf centres.
    let mut centre = vec![Vec3::ZERO; nl];
    let mut count = vec![0u32; nl];
    for (t, tri) in leaves.indices.chunks_exact(3).enumerate() {
        let p = leaf_piece[t] as usize;
        for &v in tri {
            centre[p] += Vec3::from(leaves.positions[v as usize]);
        }
        count[p] += 3;
    }
    for (c, n) in centre.iter_mut().zip(&count) {
        *c /= (*n).max(1) as f32;
    }
    let mut all = Aabb::default();
    for p in wood.positions.iter().chain(&leaves.positions) {
        all.add(Vec3::from(*p));
    }
    let diag = if all.is_empty() {
        1.0
    } else {
        (all.max - all.min).length().max(1e-3)
    };
    // Node of each wood piece / leaf, and the node tree.
    let mut parent: Vec<u32> = vec![u32::MAX];
    let mut wood_node = vec![0u32; nw];
    let mut leaf_node = vec![0u32; nl];
    if nw >= 2 {
        let mut vert_piece = vec![u32::MAX; wood.positions.len()];
        for (t, tri) in wood.indices.chunks_exact(3).enumerate() {
            for &v in tri {
                vert_piece[v as usize] = wood_piece[t];
            }
        }
        let root = wood
            .positions
            .iter()
            .enumerate()
            .filter(|(i, _)| vert_piece[*i] != u32::MAX)
            .min_by(|a, b| a.1[1].total_cmp(&b.1[1]))
            .map_or(0, |(i, _)| vert_piece[i]);
        let grid = Grid::new(&wood.positions, diag / 64.0);
        // Each piece's closest other piece.
        let mut link = vec![(u32::MAX, f32::INFINITY); nw];
        let mut link_point = vec![[f32::INFINITY; 3]; nw];
        for (v, p) in wood.positions.iter().enumerate() {
            let c = vert_piece[v];
            if c == u32::MAX {
                continue;
            }
            if let Some((o, d)) = grid.nearest(&wood.positions, Vec3::from(*p), 2, |i| {
                vert_piece[i as usize] != c && vert_piece[i as usize] != u32::MAX
            }) && (d < link[c as usize].1
                || (d == link[c as usize].1
                    && before(&wood.positions[o as usize], &link_point[c as usize])))
            {
                link[c as usize] = (vert_piece[o as usize], d);
                link_point[c as usize] = wood.positions[o as usize];
            }
        }
        let mut adj: Vec<Vec<u32>> = vec![Vec::new(); nw];
        for (c, &(o, _)) in link.iter().enumerate() {
            if o != u32::MAX {
                adj[c].push(o);
                adj[o as usize].push(c as u32);
            }
        }
        // Visit neighbours in an order given by the geometry (each piece's lexicographically
        // smallest vertex), not by vertex order, so that re-importing an exported plant gives
        // the same node numbering.
        let mut piece_key = vec![[f32::INFINITY; 3]; nw];
        for (v, p) in wood.positions.iter().enumerate() {
            let c = vert_piece[v];
            if c != u32::MAX && before(p, &piece_key[c as usize]) {
                piece_key[c as usize] = *p;
            }
        }
        for list in &mut adj {
            list.sort_by(|a, b| {
                let (ka, kb) = (piece_key[*a as usize], piece_key[*b as usize]);
                (ka[0], ka[1], ka[2])
                    .partial_cmp(&(kb[0], kb[1], kb[2]))
                    .unwrap_or(std::cmp::Ordering::Equal)
            });
            list.dedup();
        }
        // Breadth-first from the trunk: node per piece in visiting order.
        let mut node_of = vec![u32::MAX; nw];
        node_of[root as usize] = 0;
        let mut queue = std::collections::VecDeque::from([root]);
        while let Some(c) = queue.pop_front() {
            for &o in &adj[c as usize] {
                if node_of[o as usize] == u32::MAX {
                    node_of[o as usize] = parent.len() as u32;
                    parent.push(node_of[c as usize]);
                    queue.push_back(o);
                }
            }
        }
        for n in node_of.iter_mut() {
            if *n == u32::MAX {
                *n = parent.len() as u32;
                parent.push(0);
            }
        }
        wood_node = node_of.clone();
        // Leaves go to the piece with the nearest wood surface, sampled along triangle edges.
        let spacing = diag / 64.0;
        let mut samples: Vec<[f32; 3]> = Vec::new();
        let mut sample_piece: Vec<u32> = Vec::new();
        for (t, tri) in wood.indices.chunks_exact(3).enumerate() {
            for e in 0..3 {
                let a = Vec3::from(wood.positions[tri[e] as usize]);
                let b = Vec3::from(wood.positions[tri[(e + 1) % 3] as usize]);
                let n = ((a.distance(b) / spacing).ceil() as usize).clamp(1, 64);
                for k in 0..n {
                    if samples.len() >= MAX_SAMPLES {
                        break;
                    }
                    samples.push(a.lerp(b, k as f32 / n as f32).to_array());
                    sample_piece.push(wood_piece[t]);
                }
            }
        }
        let sgrid = Grid::new(&samples, spacing);
        for (l, c) in centre.iter().enumerate() {
            if let Some((v, _)) = sgrid.nearest(&samples, *c, 64, |_| true) {
                leaf_node[l] = node_of[sample_piece[v as usize] as usize];
            }
        }
    } else {
        // Spatial clusters of leaves: median splits along the longest axis.
        let mut stack: Vec<(u32, Vec<u32>, u32)> = vec![(0, (0..nl as u32).collect(), 0)];
        while let Some((node, mut ls, depth)) = stack.pop() {
            if ls.len() <= LEAVES_PER_CLUSTER || depth >= 16 {
                for l in ls {
                    leaf_node[l as usize] = node;
                }
                continue;
            }
            let mut b = Aabb::default();
            for &l in &ls {
                b.add(centre[l as usize]);
            }
            let axis = (b.max - b.min).max_position();
            ls.sort_by(|a, c| centre[*a as usize][axis].total_cmp(&centre[*c as usize][axis]));
            let right = ls.split_off(ls.len() / 2);
            for half in [ls, right] {
                let id = parent.len() as u32;
                parent.push(node);
                stack.push((id, half, depth + 1));
            }
        }
    }
    assemble(
        wood,
        leaves,
        &parent,
        &wood_piece,
        &wood_node,
        &leaf_piece,
        &leaf_node,
        nl,
    )
}

#[allow(clippy::too_many_arguments)]
fn assemble(
    wood: &mut Mesh,
    leaves: &mut Mesh,
    parent: &[u32],
    wood_piece: &[u32],
    wood_node: &[u32],
    leaf_piece: &[u32],
    leaf_node: &[u32],
    nl: usize,
) -> (Hierarchy, usize) {
    let n = parent.len();
    let mut children: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (i, &p) in parent.iter().enumerate().skip(1) {
        children[p as usize].push(i as u32);
    }
    // Pre-order.
    let mut order = Vec::with_capacity(n);
    let mut stack = vec![0u32];
    while let Some(x) = stack.pop() {
        order.push(x);
        for &c in children[x as usize].iter().rev() {
            stack.push(c);
        }
    }
    let mut rank = vec![0u32; n];
    for (r, &x) in order.iter().enumerate() {
        rank[x as usize] = r as u32;
    }
    // Leaves sorted by node rank, then piece; triangles grouped by leaf.
    let mut leaf_order: Vec<u32> = (0..nl as u32).collect();
    leaf_order.sort_by_key(|&l| (rank[leaf_node[l as usize] as usize], l));
    let mut leaf_new = vec![0u32; nl];
    for (k, &l) in leaf_order.iter().enumerate() {
        leaf_new[l as usize] = k as u32;
    }
    let mut tris: Vec<(u32, [u32; 3])> = leaves
        .indices
        .chunks_exact(3)
        .enumerate()
        .map(|(t, c)| (leaf_new[leaf_piece[t] as usize], [c[0], c[1], c[2]]))
        .collect();
    tris.sort_by_key(|t| t.0);
    let mut leaf_first_index = vec![0u32; nl + 1];
    for t in &tris {
        leaf_first_index[t.0 as usize + 1] += 3;
    }
    for i in 0..nl {
        leaf_first_index[i + 1] += leaf_first_index[i];
    }
    leaves.indices = tris.iter().flat_map(|t| t.1).collect();
    let mut wtris: Vec<(u32, [u32; 3])> = wood
        .indices
        .chunks_exact(3)
        .enumerate()
        .map(|(t, c)| {
            (
                rank[wood_node.get(wood_piece[t] as usize).copied().unwrap_or(0) as usize],
                [c[0], c[1], c[2]],
            )
        })
        .collect();
    wtris.sort_by_key(|t| t.0);
    wood.indices = wtris.iter().flat_map(|t| t.1).collect();
    // Per node (in rank order): own leaf range, own wood range, bbox.
    let mut nodes: Vec<BranchNode> = (0..n).map(|_| BranchNode::default()).collect();
    let mut boxes = vec![Aabb::default(); n];
    let mut own_leaves = vec![0u32; n];
    for &l in &leaf_order {
        own_leaves[rank[leaf_node[l as usize] as usize] as usize] += 1;
    }
    let mut wood_count = vec![0u32; n];
    for t in &wtris {
        wood_count[t.0 as usize] += 3;
        for &v in &t.1 {
            boxes[t.0 as usize].add(Vec3::from(wood.positions[v as usize]));
        }
    }
    for t in &tris {
        let r = rank[leaf_node[leaf_order[t.0 as usize] as usize] as usize] as usize;
        for &v in &t.1 {
            boxes[r].add(Vec3::from(leaves.positions[v as usize]));
        }
    }
    let (mut lstart, mut wstart) = (0u32, 0u32);
    for r in 0..n {
        let x = order[r] as usize;
        nodes[r].parent = (x != 0).then(|| rank[parent[x] as usize]);
        nodes[r].children = children[x].iter().map(|&c| rank[c as usize]).collect();
        nodes[r].level = nodes[r].parent.map_or(0, |p| nodes[p as usize].level + 1);
        nodes[r].own_leaves = own_leaves[r];
        nodes[r].leaves = lstart..lstart + own_leaves[r];
        nodes[r].wood_indices = wstart..wstart + wood_count[r];
        lstart += own_leaves[r];
        wstart += wood_count[r];
    }
    // Subtree ranges and boxes, children after parents in rank order: walk backwards.
    for r in (0..n).rev() {
        let kids = nodes[r].children.clone();
        for c in kids {
            let (cl, cw) = (
                nodes[c as usize].leaves.end,
                nodes[c as usize].wood_indices.end,
            );
            nodes[r].leaves.end = nodes[r].leaves.end.max(cl);
            nodes[r].wood_indices.end = nodes[r].wood_indices.end.max(cw);
            let b = boxes[c as usize];
            boxes[r].merge(&b);
        }
        let b = boxes[r];
        if !b.is_empty() {
            nodes[r].bbox_min = b.min.to_array();
            nodes[r].bbox_max = b.max.to_array();
        }
        nodes[r].leaf_indices = leaf_first_index[nodes[r].leaves.start as usize]
            ..leaf_first_index[nodes[r].leaves.end as usize];
    }
    (
        Hierarchy {
            nodes,
            leaf_first_index,
        },
        nl,
    )
}
