//! Triangle meshes and the [`Plant`] that the renderer consumes.

/// An indexed triangle mesh. All per-vertex arrays have the same length.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Positions in metres.
    pub positions: Vec<[f32; 3]>,
    /// Unit normals. For leaves: the normal of the front face (leaves are drawn two-sided).
    pub normals: Vec<[f32; 3]>,
    /// Texture coordinates; for leaves they index [`Plant::leaf_texture`].
    pub uvs: Vec<[f32; 2]>,
    /// Linear RGB base colour per vertex (multiplies the texture for leaves).
    pub colors: Vec<[f32; 3]>,
    /// Triangle list, counter-clockwise front faces.
    pub indices: Vec<u32>,
}

impl Mesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }
}

/// An RGBA8 leaf texture: sRGB colour, straight (not premultiplied) alpha used as a cut-out mask.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LeafTexture {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height * 4` bytes, rows top to bottom.
    pub rgba: Vec<u8>,
}

/// A plant ready to draw: wood and leaf meshes in metres, Y up, trunk base at the origin.
///
/// Besides the meshes it carries the branch hierarchy with bounding boxes (LCV04 §3, read by
/// the box-tree technique) and the instancing view (MNP01 §3.2, read by hierarchical
/// billboards). Construct with [`crate::preset`], [`crate::load`] or
/// [`crate::from_lsystem`]; `..Default::default()` fills the optional parts in tests.
#[derive(Debug, Clone, Default)]
pub struct Plant {
    /// Human-readable name (preset name or file stem).
    pub name: String,
    /// Branches and trunk (opaque).
    pub wood: Mesh,
    /// Leaves or needles (alpha-tested with `leaf_texture`, two-sided).
    pub leaves: Mesh,
    /// The leaf cut-out texture (front side; its alpha is the cut-out mask of both sides).
    pub leaf_texture: LeafTexture,
    /// The back side of the leaves (same size and alpha as `leaf_texture`), drawn where a
    /// two-sided leaf is seen from behind; empty: the front image on both sides.
    pub leaf_back: LeafTexture,
    /// Tangent-space normal map of the leaves (RGB = normal · 0.5 + 0.5, x along +u, y along
    /// +v, z out of the front face; linear, not sRGB); empty: flat.
    pub leaf_normal: LeafTexture,
    /// Bounding box of wood and leaves, metres.
    pub bbox_min: [f32; 3],
    /// Bounding box of wood and leaves, metres.
    pub bbox_max: [f32; 3],
    /// Branch tree with a bounding box per branch (LCV04 §3.1, §3.2.1); node 0 is the root.
    pub hierarchy: crate::Hierarchy,
    /// Base objects and instances (MNP01 §3.2): the plant stored once per distinct part.
    pub instancing: crate::Instancing,
    /// Drawn internodes (`F` segments); 0 for imported meshes.
    pub internodes: usize,
    /// Number of leaves (leaf quads / needle tufts, or the blades of an imported mesh).
    pub leaf_count: usize,
}
