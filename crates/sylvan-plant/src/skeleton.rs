//! The turtle's output before meshing: chains of points joined by internodes (generalised
//! cylinders, ABOP §1.6 / §2.2) and leaf frames; and the meshing of both.
//!
//! A chain is a run of `F` along one branch; each point carries a ring of vertices, consecutive
//! rings are joined by quads, and the radius changes along the chain with `!` (tapering). Ring
//! frames are parallel-transported along the chain so that tubes do not twist when the turtle
//! rolls. Branch tips are left open (they are thinner than a pixel at any useful distance).

use crate::mesh::Mesh;
use glam::Vec3;

/// A point on a chain (generalised cylinder).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChainPoint {
    /// Position, metres.
    pub pos: Vec3,
    /// Unit tangent of the chain here.
    pub heading: Vec3,
    /// A unit vector across the chain (the turtle's left), used at chain starts.
    pub side: Vec3,
    /// Radius, metres.
    pub radius: f32,
    /// Colour index (`'`).
    pub color: u8,
    /// Ring vertex count (3..=8), fixed per chain.
    pub sides: u8,
    /// Distance along the chain, metres (texture v).
    pub v: f32,
    /// Previous point of the chain, or `u32::MAX` at a chain start.
    pub prev: u32,
}

/// A leaf: a quad from `pos` along `heading`, across `side`, facing `normal`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeafFrame {
    /// Base of the leaf (petiole end), metres.
    pub pos: Vec3,
    /// Along the midrib.
    pub heading: Vec3,
    /// Across the blade.
    pub side: Vec3,
    /// Front-face normal.
    pub normal: Vec3,
    /// Length of the quad, metres.
    pub size: f32,
    /// Colour index (`'`).
    pub color: u8,
}

/// Chains and leaves, in string order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Skeleton {
    /// Chain points.
    pub points: Vec<ChainPoint>,
    /// Internodes as (from, to) point indices, in string order.
    pub segments: Vec<[u32; 2]>,
    /// Leaves, in string order.
    pub leaves: Vec<LeafFrame>,
}

/// Width/length ratio of leaf quads (and of a single leaf's texture footprint) per leaf kind.
pub fn leaf_aspect(kind: crate::lsystem::LeafKind) -> f32 {
    match kind {
        // Leaf-cluster card: square.
        crate::lsystem::LeafKind::Broadleaf => 1.0,
        // Needle-shoot spray card: longer than wide.
        crate::lsystem::LeafKind::Needles => 0.7,
        // A single leaf: the width of its texture's footprint.
        kind => crate::blade::Outline::of(kind).map_or(1.0, |o| o.texture_width()),
    }
}

/// Linear-RGB bark colours by colour index (`'`).
pub const WOOD_PALETTE: [[f32; 3]; 6] = [
    [0.100, 0.066, 0.042], // 0 brown bark
    [0.062, 0.052, 0.044], // 1 dark grey-brown bark (prunus)
    [0.105, 0.074, 0.060], // 2 reddish grey-brown pine bark
    [0.120, 0.100, 0.048], // 3 young shoot
    [0.050, 0.036, 0.026], // 4 dark bark (bush)
    [0.180, 0.150, 0.110], // 5 pale bark
];

/// Linear-RGB leaf tints by colour index (they multiply the leaf texture). The same index
/// selects the bark colour above, so one `'` at the base of a plant picks both.
pub const LEAF_PALETTE: [[f32; 3]; 6] = [
    [1.00, 1.00, 1.00], // 0 as textured
    [1.00, 1.00, 1.00], // 1 as textured (prunus)
    [0.94, 1.00, 1.02], // 2 conifer, a little bluer (pine)
    [0.80, 0.92, 0.70], // 3 fresh, lighter
    [0.90, 0.96, 0.88], // 4 deep green (bush)
    [1.10, 0.95, 0.55], // 5 yellowing
];

fn palette(p: &[[f32; 3]], i: u8) -> [f32; 3] {
    p[i as usize % p.len()]
}

impl Skeleton {
    /// Triangles the wood mesh will have (checked against limits before meshing).
    pub fn wood_triangles(&self) -> usize {
        self.segments
            .iter()
            .map(|s| 2 * self.points[s[1] as usize].sides as usize)
            .sum()
    }

    /// Meshes the chains: a ring per point, quads between consecutive rings. Returns the mesh
    /// and, per segment, the offset of its first index (so callers can map segment ranges to
    /// index ranges).
    pub fn mesh_wood(&self) -> (Mesh, Vec<u32>) {
        let mut m = Mesh::default();
        let nverts: usize = self.points.iter().map(|p| p.sides as usize + 1).sum();
        m.positions.reserve(nverts);
        m.normals.reserve(nverts);
        m.uvs.reserve(nverts);
        m.colors.reserve(nverts);
        m.indices.reserve(self.wood_triangles() * 3);
        // Ring frame per point, parallel-transported from the chain start.
        let mut first = vec![0u32; self.points.len()];
        let mut axis = vec![Vec3::X; self.points.len()];
        for (i, p) in self.points.iter().enumerate() {
            let x = if p.prev == u32::MAX {
                p.side
            } else {
                axis[p.prev as usize]
            };
            let mut x = (x - p.heading * x.dot(p.heading)).normalize_or_zero();
            if x == Vec3::ZERO {
                x = p.heading.any_orthonormal_vector();
            }
            axis[i] = x;
            let y = p.heading.cross(x);
            first[i] = m.positions.len() as u32;
            let col = palette(&WOOD_PALETTE, p.color);
            let n = p.sides as usize;
            for k in 0..=n {
                let a = k as f32 / n as f32 * std::f32::consts::TAU;
                let dir = x * a.cos() + y * a.sin();
                m.positions.push((p.pos + dir * p.radius).to_array());
                m.normals.push(dir.to_array());
                m.uvs.push([k as f32 / n as f32, p.v]);
                m.colors.push(col);
            }
        }
        let mut seg_first = Vec::with_capacity(self.segments.len() + 1);
        for s in &self.segments {
            seg_first.push(m.indices.len() as u32);
            let (a, b) = (first[s[0] as usize], first[s[1] as usize]);
            let n = self.points[s[1] as usize].sides as u32;
            for k in 0..n {
                // Counter-clockwise seen from outside: the ring runs x → y = heading × x.
                let (a0, a1, b0, b1) = (a + k, a + k + 1, b + k, b + k + 1);
                m.indices.extend_from_slice(&[a0, a1, b1, a0, b1, b0]);
            }
        }
        seg_first.push(m.indices.len() as u32);
        (m, seg_first)
    }
}

/// Meshes leaves, each a copy of `shape` (the card quad, or a single leaf's blade) placed in
/// its frame and scaled by its size, in leaf order: leaf `i` owns vertices `i·V..(i+1)·V` and
/// indices `i·I..(i+1)·I` (V, I: the shape's vertex and index counts). UV v runs from 1 at the
/// base to 0 at the tip. Each triangle's front face (counter-clockwise) faces the leaf normal.
pub fn mesh_leaves(leaves: &[LeafFrame], shape: &crate::blade::LeafShape, tint_seed: u64) -> Mesh {
    let mut m = Mesh::default();
    let (nv, ni) = (shape.positions.len(), shape.indices.len());
    m.positions.reserve(leaves.len() * nv);
    m.normals.reserve(leaves.len() * nv);
    m.uvs.reserve(leaves.len() * nv);
    m.colors.reserve(leaves.len() * nv);
    m.indices.reserve(leaves.len() * ni);
    for (i, l) in leaves.iter().enumerate() {
        let base = m.positions.len() as u32;
        let t = palette(&LEAF_PALETTE, l.color);
        // Per-leaf variation: brightness ±12 %, and a slight shift towards yellow or blue.
        let h = |salt: u64| {
            crate::rng::hash01(tint_seed ^ (i as u64).wrapping_mul(0x9e37_79b9) ^ salt) as f32
        };
        let k = 0.88 + 0.24 * h(0);
        let hue = h(0x5bd1_e995) - 0.5;
        let col = [
            t[0] * k * (1.0 + 0.16 * hue),
            t[1] * k,
            t[2] * k * (1.0 - 0.2 * hue),
        ];
        let place =
            |p: [f32; 3]| l.pos + (l.side * p[0] + l.heading * p[1] + l.normal * p[2]) * l.size;
        let turn = |n: [f32; 3]| {
            (l.side * n[0] + l.heading * n[1] + l.normal * n[2]).normalize_or(l.normal)
        };
        for ((p, n), uv) in shape.positions.iter().zip(&shape.normals).zip(&shape.uvs) {
            m.positions.push(place(*p).to_array());
            m.normals.push(turn(*n).to_array());
            m.uvs.push(*uv);
            m.colors.push(col);
        }
        for t in shape.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|j| base + j);
            let p = |j: u32| Vec3::from(m.positions[j as usize]);
            let nsum = Vec3::from(m.normals[a as usize])
                + Vec3::from(m.normals[b as usize])
                + Vec3::from(m.normals[c as usize]);
            let ccw = (p(b) - p(a)).cross(p(c) - p(a)).dot(nsum) >= 0.0;
            if ccw {
                m.indices.extend_from_slice(&[a, b, c]);
            } else {
                m.indices.extend_from_slice(&[a, c, b]);
            }
        }
    }
    m
}
