//! Plants as plain data: L-systems, the turtle, the plant hierarchy with instancing, the
//! bounding-box tree (LCV04 §3), meshes, and glTF/OBJ import/export. No GPU.
//!
//! CONTRACT used by `sylvan-render` (fields may be added, not removed or renamed):
//! [`Plant`] with `wood` and `leaves` [`Mesh`]es (metres, Y up, trunk base at the origin),
//! `leaf_texture` (RGBA8, sRGB colour, straight alpha; leaf UVs index it), `bbox_min/max`;
//! [`preset`] and [`load`] build one. Added: [`Plant::hierarchy`] (LCV04 §3.1 branch boxes),
//! [`Plant::instancing`] (MNP01 §3.2 base objects + instances), counts, [`Plant::stats`].
//!
//! Pipeline for `.lsys` sources: [`LSystem::parse`] → [`LSystem::derive`] →
//! [`turtle::interpret`] → [`from_lsystem`] (meshes, hierarchy, instancing, leaf texture).
//!
//! Limits (consts, checked before allocating): [`lsystem::MAX_SOURCE_BYTES`],
//! [`lsystem::MAX_ITERATIONS`], [`lsystem::MAX_LIMIT`], [`lsystem::MAX_WORK`],
//! [`turtle::MAX_INTERNODES`], [`turtle::MAX_LEAVES`], [`MAX_TRIANGLES`].

#![warn(missing_docs)]

pub mod blade;
mod error;
pub mod export;
pub mod hierarchy;
pub mod import;
pub mod instancing;
pub mod lsystem;
mod mesh;
mod presets;
pub mod rng;
pub mod skeleton;
pub mod texture;
pub mod turtle;

pub use error::{PlantError, Pos};
pub use hierarchy::{BranchNode, Hierarchy};
pub use instancing::{BaseObject, Instance, Instancing};
pub use lsystem::{Blade, LSystem, LeafKind, Word};
pub use mesh::{LeafTexture, Mesh, Plant};
pub use presets::{PRESETS, preset_source};

use std::path::Path;

/// Most triangles (wood + leaves) a plant may have; checked before meshing.
pub const MAX_TRIANGLES: usize = 8_000_000;

/// A built-in plant by name (`pine`, `prunus`, `bush`), from `assets/plants/NAME.lsys`.
pub fn preset(name: &str) -> Result<Plant, PlantError> {
    let src = preset_source(name).ok_or_else(|| PlantError::UnknownPreset(name.to_string()))?;
    let ls = LSystem::parse(src, &format!("assets/plants/{name}.lsys"))?;
    from_lsystem(&ls, name)
}

/// Loads a plant from a `.lsys`, `.glb`, `.gltf` or `.obj` file (OBJ in metres).
pub fn load(path: &Path) -> Result<Plant, PlantError> {
    load_with(path, 1.0)
}

/// Like [`load`], with a unit scale for meshes (e.g. 0.01 for an OBJ in centimetres; glTF is
/// metres by specification and the scale multiplies it too).
pub fn load_with(path: &Path, unit_scale: f32) -> Result<Plant, PlantError> {
    let file = path.display().to_string();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if !(unit_scale.is_finite() && unit_scale > 0.0) {
        return Err(PlantError::file(
            &file,
            "unit scale must be a positive number",
            "use e.g. 0.01 for centimetres",
        ));
    }
    match ext.as_str() {
        "lsys" => {
            let src = sylvan_io::read_to_string(path, lsystem::MAX_SOURCE_BYTES as u64)
                .map_err(|e| io_error(&file, e))?;
            let ls = LSystem::parse(&src, &file)?;
            let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("plant");
            let mut p = from_lsystem(&ls, name)?;
            if unit_scale != 1.0 {
                p.scale(unit_scale);
            }
            Ok(p)
        }
        "glb" | "gltf" | "obj" => import::load_mesh(path, unit_scale),
        _ => Err(PlantError::file(
            &file,
            format!("unsupported file type '.{ext}'"),
            "use a .lsys, .glb, .gltf or .obj file",
        )),
    }
}

pub(crate) fn io_error(file: &str, e: sylvan_io::ReadError) -> PlantError {
    PlantError::file(file, e.to_string(), e.fix())
}

/// Builds a plant from a parsed L-system: derive, interpret, mesh, hierarchy, instancing.
pub fn from_lsystem(ls: &LSystem, name: &str) -> Result<Plant, PlantError> {
    let word = ls.derive()?;
    let interp = turtle::interpret(ls, &word)?;
    let sk = &interp.skeleton;
    let shape = blade::LeafShape::new(ls.leaf_kind, ls.blade);
    let tris = sk.wood_triangles() + shape.triangles() * sk.leaves.len();
    if tris > MAX_TRIANGLES {
        return Err(PlantError::file(
            &ls.file,
            format!("the plant would have {tris} triangles, more than {MAX_TRIANGLES}"),
            "lower `iterations:`",
        ));
    }
    let finite = |v: glam::Vec3| v.is_finite();
    if !sk.points.iter().all(|p| finite(p.pos))
        || !sk
            .leaves
            .iter()
            .all(|l| finite(l.pos) && l.size.is_finite())
    {
        return Err(PlantError::file(
            &ls.file,
            "the geometry overflows (a length or width is too large)",
            "use lengths and widths in metres",
        ));
    }
    let (wood, seg_first) = sk.mesh_wood();
    let leaves = skeleton::mesh_leaves(&sk.leaves, &shape, ls.seed);
    let hierarchy = hierarchy::finish(
        &interp.nodes,
        &seg_first,
        sk.leaves.len() as u32,
        shape.indices.len() as u32,
    );
    let instancing = build_instancing(&interp, &shape);
    let maps = texture_for(ls.leaf_kind);
    let mut p = Plant {
        name: name.to_string(),
        wood,
        leaves,
        leaf_texture: maps.front,
        leaf_back: maps.back,
        leaf_normal: maps.normal,
        internodes: interp.internodes,
        leaf_count: sk.leaves.len(),
        hierarchy,
        instancing,
        ..Default::default()
    };
    p.update_bbox();
    Ok(p)
}

/// A leaf kind's images, generated once per process.
fn texture_for(kind: LeafKind) -> texture::LeafMaps {
    use std::sync::OnceLock;
    static MAPS: [OnceLock<texture::LeafMaps>; 4] = [const { OnceLock::new() }; 4];
    let slot = match kind {
        LeafKind::Broadleaf => 0,
        LeafKind::Needles => 1,
        LeafKind::Chestnut => 2,
        LeafKind::Beech => 3,
    };
    MAPS[slot].get_or_init(|| texture::leaf_maps(kind)).clone()
}

fn build_instancing(interp: &turtle::Interpretation, shape: &blade::LeafShape) -> Instancing {
    let objects = interp
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| {
            if i == 0 {
                BaseObject {
                    level: 0,
                    wood: Mesh::default(),
                    leaves: skeleton::mesh_leaves(&o.skeleton.leaves, shape, 0),
                    instances: Vec::new(),
                    uses: o.uses,
                }
            } else {
                BaseObject {
                    level: o.level,
                    wood: o.skeleton.mesh_wood().0,
                    leaves: Mesh::default(),
                    instances: o.instances.clone(),
                    uses: o.uses,
                }
            }
        })
        .collect();
    Instancing { objects, root: 1 }
}

/// Numbers that describe a plant (`sylvan plant --stats`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PlantStats {
    /// Drawn internodes (`F` segments); 0 for imported meshes.
    pub internodes: usize,
    /// Leaves (quads, or the blades of an imported mesh).
    pub leaves: usize,
    /// Triangles, wood + leaves.
    pub triangles: usize,
    /// Wood triangles.
    pub wood_triangles: usize,
    /// Leaf triangles.
    pub leaf_triangles: usize,
    /// Levels of the branch hierarchy (LCV04).
    pub levels: u32,
    /// Branch nodes in the hierarchy.
    pub nodes: usize,
    /// Instance records in the instancing view (MNP01).
    pub instances: usize,
    /// Base objects in the instancing view (the leaf quad included).
    pub base_objects: usize,
    /// Levels of the instancing scene graph (leaf = level 0 … tree).
    pub instance_levels: u32,
    /// Bytes of the instanced representation (base meshes + 52 B per instance).
    pub instanced_bytes: usize,
    /// Bytes of the flattened meshes (44 B per vertex + 4 B per index).
    pub flattened_bytes: usize,
    /// Bytes of the flattened leaf mesh alone (as `flattened_bytes`).
    pub leaf_mesh_bytes: usize,
    /// Bounding box minimum, metres.
    pub bbox_min: [f32; 3],
    /// Bounding box maximum, metres.
    pub bbox_max: [f32; 3],
}

impl Plant {
    /// Summary numbers.
    pub fn stats(&self) -> PlantStats {
        PlantStats {
            internodes: self.internodes,
            leaves: self.leaf_count,
            triangles: self.wood.triangle_count() + self.leaves.triangle_count(),
            wood_triangles: self.wood.triangle_count(),
            leaf_triangles: self.leaves.triangle_count(),
            levels: self.hierarchy.levels(),
            nodes: self.hierarchy.nodes.len(),
            instances: self.instancing.instance_count(),
            base_objects: self.instancing.objects.len(),
            instance_levels: self.instancing.levels(),
            instanced_bytes: self.instancing.bytes(),
            flattened_bytes: self.wood.bytes() + self.leaves.bytes(),
            leaf_mesh_bytes: self.leaves.bytes(),
            bbox_min: self.bbox_min,
            bbox_max: self.bbox_max,
        }
    }

    /// Recomputes `bbox_min/max` from the meshes (zero box when empty).
    pub fn update_bbox(&mut self) {
        let mut b = hierarchy::Aabb::default();
        for p in self.wood.positions.iter().chain(&self.leaves.positions) {
            b.add(glam::Vec3::from(*p));
        }
        if b.is_empty() {
            self.bbox_min = [0.0; 3];
            self.bbox_max = [0.0; 3];
        } else {
            self.bbox_min = b.min.to_array();
            self.bbox_max = b.max.to_array();
        }
    }

    /// Scales everything (meshes, boxes, instance translations) uniformly by `s`.
    pub fn scale(&mut self, s: f32) {
        for m in [&mut self.wood, &mut self.leaves] {
            for p in &mut m.positions {
                *p = [p[0] * s, p[1] * s, p[2] * s];
            }
        }
        for n in &mut self.hierarchy.nodes {
            n.bbox_min = n.bbox_min.map(|v| v * s);
            n.bbox_max = n.bbox_max.map(|v| v * s);
        }
        for o in &mut self.instancing.objects {
            for m in [&mut o.wood, &mut o.leaves] {
                for p in &mut m.positions {
                    *p = [p[0] * s, p[1] * s, p[2] * s];
                }
            }
            for inst in &mut o.instances {
                inst.transform.w_axis.x *= s;
                inst.transform.w_axis.y *= s;
                inst.transform.w_axis.z *= s;
            }
        }
        self.update_bbox();
    }
}

/// Entry points for the fuzz targets (`fuzz/`): each reads untrusted bytes the way
/// [`load`] does and must return an error or a plant, never panic or allocate without bound.
/// Files an input names (glTF buffers and textures, OBJ's MTL files) resolve against a folder
/// that does not exist, so the importers' own parsing is what gets fuzzed.
#[doc(hidden)]
pub mod fuzzing {
    use std::cell::Cell;
    use std::path::Path;

    const NOWHERE: &str = "/nonexistent-sylvan-fuzz";

    /// `.lsys` source, derived and meshed with its limits lowered to keep each input fast
    /// (the limits themselves are exercised by the tests). Checks the derived word's length.
    pub fn lsystem(src: &str) {
        let Ok(mut ls) = crate::LSystem::parse(src, "fuzz.lsys") else {
            return;
        };
        ls.limit = ls.limit.min(20_000);
        ls.iterations = ls.iterations.min(12);
        if let Ok(word) = ls.derive() {
            assert!(word.len() <= ls.limit, "derived word over its limit");
            let _ = crate::from_lsystem(&ls, "fuzz");
        }
    }

    /// A `.gltf` (JSON) or `.glb` file's bytes, imported as a plant.
    pub fn gltf(bytes: &[u8]) {
        let file = "fuzz.glb";
        let budget = crate::import::MAX_IMPORT_BYTES;
        if let Ok(g) = crate::import::gltf_from_bytes(file, bytes, Path::new(NOWHERE), budget) {
            let _ = crate::import::finish(file, "fuzz", g, 1.0);
        }
    }

    /// An `.obj` file's bytes, imported as a plant.
    pub fn obj(bytes: &[u8]) {
        let file = "fuzz.obj";
        let budget = Cell::new(crate::import::MAX_IMPORT_BYTES);
        if let Ok(g) = crate::import::obj_from_bytes(file, bytes, Path::new(NOWHERE), budget) {
            let _ = crate::import::finish(file, "fuzz", g, 1.0);
        }
    }
}
