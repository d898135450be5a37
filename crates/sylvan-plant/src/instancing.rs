//! The instancing view of a plant (MNP01 §3.2, §6, §7): a scene graph of *base objects*, each
//! stored once in its own frame, placed by *instances* (a transform). MNP01's pine has three
//! levels — small branch with needles, main branch made of small-branch instances, tree made of
//! main branches — and 30,000 needles; here level 0 is the leaf (or needle tuft) quad, and each
//! higher object is a branch made of its own wood plus instances of lower objects.
//!
//! Identical sub-structures are found on the derived string: a bracketed branch `[...]` is a
//! base object when the same content (modules and parameters, so the same module, parameters
//! and derivation depth) occurs at least twice *and* the turtle enters it with the same width
//! and colour. Content is compared through a 64-bit hash (collisions are not checked).
//! Branches that use `$` (which depends on the absolute frame) are never shared, and with
//! tropism (which depends on the absolute direction) nothing is shared.
//!
//! Frames: an object's local frame is the turtle frame at its `[`: local +Y is the heading,
//! −X the turtle's left, +Z its up, the origin the branch base. Instance transforms map an
//! object's local frame into its parent object's frame (rigid, plus uniform scale for leaves).

use crate::mesh::Mesh;
use glam::{Mat4, Vec3};

/// Bytes one instance costs in [`Instancing::bytes`]: a 3×4 `f32` matrix and an object id.
pub const INSTANCE_BYTES: usize = 52;

/// A placement of a base object inside another.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Instance {
    /// Index into [`Instancing::objects`].
    pub object: u32,
    /// Maps the object's frame into the containing object's frame.
    pub transform: Mat4,
}

/// A base object: its own geometry in its own frame, plus instances of other objects.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BaseObject {
    /// 0 for the leaf (needle tuft) quad; otherwise 1 + the highest level it instances.
    pub level: u32,
    /// Own wood (not including instances), in the object's frame.
    pub wood: Mesh,
    /// Own leaf geometry (only the level-0 leaf object has any), in the object's frame.
    pub leaves: Mesh,
    /// Sub-objects placed in this object's frame.
    pub instances: Vec<Instance>,
    /// How many times the object appears in the whole plant.
    pub uses: u32,
}

/// Base objects and the instances that assemble the plant (MNP01 §3.2).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Instancing {
    /// Base objects; `objects[0]` is the unit leaf quad (size 1 m), `objects[root]` the plant.
    pub objects: Vec<BaseObject>,
    /// The object that is the whole plant (placed once, at the identity).
    pub root: u32,
}

impl Mesh {
    /// Bytes of the mesh as stored for drawing: 44 per vertex (position, normal, uv, colour as
    /// `f32`) and 4 per index.
    pub fn bytes(&self) -> usize {
        self.positions.len() * 44 + self.indices.len() * 4
    }

    /// Appends `other` transformed by `m` (normals by its rotation part, renormalised).
    pub fn append_transformed(&mut self, other: &Mesh, m: &Mat4) {
        let base = self.positions.len() as u32;
        self.positions.extend(
            other
                .positions
                .iter()
                .map(|p| m.transform_point3(Vec3::from(*p)).to_array()),
        );
        self.normals.extend(other.normals.iter().map(|n| {
            m.transform_vector3(Vec3::from(*n))
                .normalize_or_zero()
                .to_array()
        }));
        self.uvs.extend_from_slice(&other.uvs);
        self.colors.extend_from_slice(&other.colors);
        self.indices.extend(other.indices.iter().map(|i| i + base));
    }
}

impl Instancing {
    /// Total instance records (the `instances` statistic).
    pub fn instance_count(&self) -> usize {
        self.objects.iter().map(|o| o.instances.len()).sum()
    }

    /// Levels of the scene graph (the root's level + 1).
    pub fn levels(&self) -> u32 {
        self.objects
            .get(self.root as usize)
            .map_or(0, |o| o.level + 1)
    }

    /// Bytes of the instanced representation: every base object's own meshes once, plus
    /// [`INSTANCE_BYTES`] per instance.
    pub fn bytes(&self) -> usize {
        self.objects
            .iter()
            .map(|o| o.wood.bytes() + o.leaves.bytes() + o.instances.len() * INSTANCE_BYTES)
            .sum()
    }

    /// Expands every instance: the flattened (wood, leaves) meshes. Positions equal those of
    /// `Plant::wood`/`Plant::leaves` up to rounding (leaf tints differ: per-leaf variation is
    /// not instanced).
    pub fn flatten(&self) -> (Mesh, Mesh) {
        let mut wood = Mesh::default();
        let mut leaves = Mesh::default();
        if (self.root as usize) < self.objects.len() {
            self.expand(self.root, &Mat4::IDENTITY, &mut wood, &mut leaves, 0);
        }
        (wood, leaves)
    }

    fn expand(&self, o: u32, m: &Mat4, wood: &mut Mesh, leaves: &mut Mesh, depth: u32) {
        if depth > 256 {
            return;
        }
        let obj = &self.objects[o as usize];
        wood.append_transformed(&obj.wood, m);
        leaves.append_transformed(&obj.leaves, m);
        for inst in &obj.instances {
            self.expand(inst.object, &(*m * inst.transform), wood, leaves, depth + 1);
        }
    }
}
