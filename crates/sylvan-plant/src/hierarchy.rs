//! The plant hierarchy of LCV04 §3.1: one node per branch with the bounding box of its subtree,
//! built while the turtle interprets the string with the algorithm of LCV04 §3.2.1 — PUSH (`[`)
//! opens a new box (child of the current branch, one level deeper), drawn geometry (internodes,
//! leaves) grows the open boxes, POP (`]`) closes the last box. Growing only the innermost open
//! box and merging a closed box into its parent at POP gives the same boxes as updating all
//! open boxes, in O(1) per module.
//!
//! Deviation: LCV04 keeps a node per module; Sylvan keeps a node per *branch* (a bracketed
//! substring that draws at least one internode). Brackets that hold only leaves (petioles) are
//! merged into their branch, so a node is always a piece of wood with its leaves.
//!
//! Leaves are numbered in string order, so the leaves of a subtree are one contiguous range
//! ([`BranchNode::leaves`]); so are their triangles ([`BranchNode::leaf_indices`]) and the wood
//! triangles of the subtree ([`BranchNode::wood_indices`]). For imported meshes the nodes come
//! from spatial clustering (see `import::cluster`) with the same guarantees.

use std::ops::Range;

/// One branch: its subtree's bounding box, parent/children, and which leaves it holds.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BranchNode {
    /// Parent node, `None` for the root (the whole plant, node 0).
    pub parent: Option<u32>,
    /// Child branches, in string order.
    pub children: Vec<u32>,
    /// Depth: the root is 0, a branch on the trunk 1, and so on.
    pub level: u32,
    /// Bounding box of this branch and all its descendants (wood and leaves), metres.
    pub bbox_min: [f32; 3],
    /// Bounding box maximum, metres.
    pub bbox_max: [f32; 3],
    /// Leaf numbers of the subtree (this branch and descendants), contiguous.
    pub leaves: Range<u32>,
    /// Leaves attached directly to this branch (not to a child branch).
    pub own_leaves: u32,
    /// Internodes drawn directly by this branch.
    pub own_internodes: u32,
    /// Range into `Plant::leaves.indices` holding the subtree's leaf triangles.
    pub leaf_indices: Range<u32>,
    /// Range into `Plant::wood.indices` holding the subtree's wood triangles.
    pub wood_indices: Range<u32>,
}

/// The branch tree of a plant (LCV04 §3.1). `nodes[0]` is the root; parents come before
/// their children.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Hierarchy {
    /// All branches; `nodes[0]` is the root (the trunk and everything on it).
    pub nodes: Vec<BranchNode>,
    /// Leaf `i` owns `Plant::leaves.indices[leaf_first_index[i]..leaf_first_index[i + 1]]`
    /// (length: leaves + 1).
    pub leaf_first_index: Vec<u32>,
}

impl Hierarchy {
    /// Number of levels (the deepest node's level + 1; 0 when empty).
    pub fn levels(&self) -> u32 {
        self.nodes.iter().map(|n| n.level + 1).max().unwrap_or(0)
    }

    /// Number of leaves covered by the hierarchy.
    pub fn leaf_count(&self) -> usize {
        self.leaf_first_index.len().saturating_sub(1)
    }

    /// Nodes at a given level.
    pub fn at_level(&self, level: u32) -> impl Iterator<Item = (usize, &BranchNode)> {
        self.nodes
            .iter()
            .enumerate()
            .filter(move |(_, n)| n.level == level)
    }
}

/// An axis-aligned box being grown.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Aabb {
    pub min: glam::Vec3,
    pub max: glam::Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Aabb {
            min: glam::Vec3::splat(f32::INFINITY),
            max: glam::Vec3::splat(f32::NEG_INFINITY),
        }
    }
}

impl Aabb {
    pub fn add(&mut self, p: glam::Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
    pub fn add_sphere(&mut self, p: glam::Vec3, r: f32) {
        self.add(p - glam::Vec3::splat(r));
        self.add(p + glam::Vec3::splat(r));
    }
    pub fn merge(&mut self, o: &Aabb) {
        self.min = self.min.min(o.min);
        self.max = self.max.max(o.max);
    }
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x
    }
}

/// A node while the turtle runs (before merging leaf-only brackets).
#[derive(Debug, Clone, Default)]
pub(crate) struct RawNode {
    pub parent: u32,
    pub bbox: Aabb,
    pub leaves: Range<u32>,
    pub segments: Range<u32>,
    pub own_internodes: u32,
}

/// Keeps the nodes whose subtree draws wood; leaf-only brackets fold into their branch.
/// `seg_first` maps segment numbers to wood index offsets; every leaf has `leaf_indices`
/// indices (6 for a card quad, 12 or 24 for a single leaf's blade).
pub(crate) fn finish(
    raw: &[RawNode],
    seg_first: &[u32],
    leaf_count: u32,
    leaf_indices: u32,
) -> Hierarchy {
    let mut map = vec![u32::MAX; raw.len()];
    let mut nodes: Vec<BranchNode> = Vec::new();
    for (i, r) in raw.iter().enumerate() {
        let keep = i == 0 || r.segments.start < r.segments.end;
        if !keep {
            // Fold into the nearest kept ancestor (parents come first, so it is mapped).
            map[i] = map[r.parent as usize];
            continue;
        }
        let parent = (i != 0).then(|| map[r.parent as usize]);
        let level = parent.map_or(0, |p| nodes[p as usize].level + 1);
        let idx = nodes.len() as u32;
        map[i] = idx;
        if let Some(p) = parent {
            nodes[p as usize].children.push(idx);
        }
        let (bmin, bmax) = if r.bbox.is_empty() {
            ([0.0; 3], [0.0; 3])
        } else {
            (r.bbox.min.to_array(), r.bbox.max.to_array())
        };
        let wi = |s: u32| seg_first.get(s as usize).copied().unwrap_or(0);
        nodes.push(BranchNode {
            parent,
            children: Vec::new(),
            level,
            bbox_min: bmin,
            bbox_max: bmax,
            leaves: r.leaves.clone(),
            own_leaves: 0,
            own_internodes: 0,
            leaf_indices: r.leaves.start * leaf_indices..r.leaves.end * leaf_indices,
            wood_indices: wi(r.segments.start)..wi(r.segments.end),
        });
    }
    for (i, r) in raw.iter().enumerate() {
        let n = map[i] as usize;
        nodes[n].own_internodes += r.own_internodes;
    }
    // Own leaves = subtree leaves minus the children's subtree leaves.
    for i in 0..nodes.len() {
        let total = nodes[i].leaves.len() as u32;
        let in_children: u32 = nodes[i]
            .children
            .iter()
            .map(|&c| nodes[c as usize].leaves.len() as u32)
            .sum();
        nodes[i].own_leaves = total.saturating_sub(in_children);
    }
    Hierarchy {
        nodes,
        leaf_first_index: (0..=leaf_count).map(|i| i * leaf_indices).collect(),
    }
}
