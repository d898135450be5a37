//! Mesh import: glTF 2.0 (`.gltf`/`.glb`, via the `gltf` crate) and Wavefront OBJ + MTL (via
//! `tobj`), as made by tree modellers (GPSS07 and BN12 start from such meshes).
//!
//! Wood vs leaves is decided per material: alpha-masked or blended glTF materials, OBJ
//! materials with a dissolve map (`map_d`) or dissolve < 1, and any material or object whose
//! name says leaf/leaves/foliage/needle/frond/twig are leaves; the rest is wood. The first leaf
//! material's base-colour texture (PNG) becomes the leaf texture, else the procedural one. Wood
//! vertex colours are the wood material's colour times its texture sampled at the vertex.
//!
//! Units: glTF is metres (by specification); OBJ has no unit, so a unit scale is given by the
//! caller (`--unit-scale`). The result is moved so that the trunk base is at the origin. The
//! hierarchy comes from `cluster`; the instancing view is a single root object holding
//! everything (no repetition is detected in imported meshes).

pub mod cluster;
mod gltf_in;
mod obj_in;

use crate::hierarchy::Aabb;
use crate::{BaseObject, Instancing, LeafKind, LeafTexture, Mesh, Plant, PlantError};
use glam::Vec3;
use std::path::Path;

/// Most bytes read for one imported mesh: the file plus everything it names (glTF buffers and
/// textures, OBJ's MTL files and textures), checked while reading.
pub const MAX_IMPORT_BYTES: u64 = 512 << 20;
/// Most vertices accepted in an imported mesh (every node instance counted), checked before each
/// primitive is read; at ~48 bytes a vertex, twice over (plant + instancing view), this keeps
/// an import under ~0.5 GB.
pub const MAX_IMPORT_VERTICES: usize = 4_000_000;
/// Largest texture decoded (width × height), checked from the image header before decoding.
pub const MAX_TEXTURE_PIXELS: u64 = 4096 * 4096;

pub(crate) use gltf_in::{gltf_from_bytes, load_gltf};
pub(crate) use obj_in::{load_obj, obj_from_bytes};

/// True when a material or object name says leaves.
pub fn is_leaf_name(name: &str) -> bool {
    let n = name.to_ascii_lowercase();
    [
        "leaf", "leave", "foliage", "needle", "frond", "twig", "canopy", "blatt",
    ]
    .iter()
    .any(|k| n.contains(k))
}

/// A decoded texture, for sampling wood colours and as the leaf texture.
pub(crate) struct Tex {
    pub w: u32,
    pub h: u32,
    pub rgba: Vec<u8>,
}

impl Tex {
    /// Decodes an image file's bytes; `None` for an undecodable one or one over
    /// [`MAX_TEXTURE_PIXELS`] (checked from the header, before decoding).
    pub fn decode(bytes: &[u8]) -> Option<Tex> {
        let reader = || {
            image::ImageReader::new(std::io::Cursor::new(bytes))
                .with_guessed_format()
                .ok()
        };
        let (w, h) = reader()?.into_dimensions().ok()?;
        if u64::from(w) * u64::from(h) > MAX_TEXTURE_PIXELS {
            return None;
        }
        let img = reader()?.decode().ok()?.to_rgba8();
        let (w, h) = img.dimensions();
        (w > 0 && h > 0).then(|| Tex {
            w,
            h,
            rgba: img.into_raw(),
        })
    }

    /// Linear RGB at `uv` (repeat wrap, nearest).
    pub fn sample(&self, uv: [f32; 2]) -> [f32; 3] {
        let fx = uv[0] - uv[0].floor();
        let fy = uv[1] - uv[1].floor();
        let x = ((fx * self.w as f32) as u32).min(self.w - 1);
        let y = ((fy * self.h as f32) as u32).min(self.h - 1);
        let o = ((y * self.w + x) * 4) as usize;
        let lin = |b: u8| (b as f32 / 255.0).powf(2.2);
        [
            lin(self.rgba[o]),
            lin(self.rgba[o + 1]),
            lin(self.rgba[o + 2]),
        ]
    }

    pub fn into_leaf_texture(self) -> LeafTexture {
        LeafTexture {
            width: self.w,
            height: self.h,
            rgba: self.rgba,
        }
    }
}

/// Wood and leaves gathered from a file, before centring and clustering.
#[derive(Default)]
pub(crate) struct Gathered {
    pub wood: Mesh,
    pub leaves: Mesh,
    pub leaf_texture: Option<LeafTexture>,
}

/// Appends a triangle list to `m`, filling missing attributes (normals computed per face).
pub(crate) fn append(
    m: &mut Mesh,
    pos: &[[f32; 3]],
    nrm: Option<&[[f32; 3]]>,
    uv: Option<&[[f32; 2]]>,
    col: &dyn Fn(usize) -> [f32; 3],
    idx: &[u32],
) {
    let base = m.positions.len() as u32;
    m.positions.extend_from_slice(pos);
    match nrm {
        Some(n) if n.len() == pos.len() => m.normals.extend(
            n.iter()
                .map(|v| Vec3::from(*v).normalize_or(Vec3::Y).to_array()),
        ),
        _ => {
            let mut acc = vec![Vec3::ZERO; pos.len()];
            for t in idx.chunks_exact(3) {
                let (a, b, c) = (
                    Vec3::from(pos[t[0] as usize]),
                    Vec3::from(pos[t[1] as usize]),
                    Vec3::from(pos[t[2] as usize]),
                );
                let f = (b - a).cross(c - a);
                for &v in t {
                    acc[v as usize] += f;
                }
            }
            m.normals
                .extend(acc.iter().map(|v| v.normalize_or(Vec3::Y).to_array()));
        }
    }
    match uv {
        Some(u) if u.len() == pos.len() => m.uvs.extend_from_slice(u),
        _ => m.uvs.extend(std::iter::repeat_n([0.0, 0.0], pos.len())),
    }
    m.colors.extend((0..pos.len()).map(col));
    m.indices.extend(idx.iter().map(|i| i + base));
}

/// Validates indices of one primitive against its vertex count.
pub(crate) fn check_indices(file: &str, idx: &[u32], n: usize) -> Result<(), PlantError> {
    if !idx.len().is_multiple_of(3) {
        return Err(PlantError::file(
            file,
            "triangle list length is not a multiple of 3",
            "re-export the mesh as triangles",
        ));
    }
    if let Some(bad) = idx.iter().find(|&&i| i as usize >= n) {
        return Err(PlantError::file(
            file,
            format!("index {bad} is out of range (only {n} vertices)"),
            "the file is corrupt; re-export it",
        ));
    }
    Ok(())
}

/// Loads a mesh file as a plant.
pub fn load_mesh(path: &Path, unit_scale: f32) -> Result<Plant, PlantError> {
    let file = path.display().to_string();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let g = match ext.as_str() {
        "obj" => load_obj(path)?,
        _ => load_gltf(path)?,
    };
    let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("plant");
    finish(&file, name, g, unit_scale)
}

/// Scales, centres the trunk base at the origin, clusters, and assembles the plant.
pub(crate) fn finish(
    file: &str,
    name: &str,
    mut g: Gathered,
    unit_scale: f32,
) -> Result<Plant, PlantError> {
    if g.wood.indices.is_empty() && g.leaves.indices.is_empty() {
        return Err(PlantError::file(
            file,
            "the file holds no triangles",
            "export the tree as a triangle mesh",
        ));
    }
    if g.wood.positions.len() + g.leaves.positions.len() > MAX_IMPORT_VERTICES {
        return Err(PlantError::file(
            file,
            format!("more than {MAX_IMPORT_VERTICES} vertices"),
            "decimate the mesh",
        ));
    }
    if g.wood
        .positions
        .iter()
        .chain(&g.leaves.positions)
        .flatten()
        .any(|v| !v.is_finite())
    {
        return Err(PlantError::file(
            file,
            "a vertex position is not a finite number",
            "the file is corrupt; re-export it",
        ));
    }
    // Trunk base: centre of the wood (or everything) near the lowest point.
    let src = if g.wood.positions.is_empty() {
        &g.leaves.positions
    } else {
        &g.wood.positions
    };
    let mut b = Aabb::default();
    for p in g.wood.positions.iter().chain(&g.leaves.positions) {
        b.add(Vec3::from(*p));
    }
    let ymin = src.iter().map(|p| p[1]).fold(f32::INFINITY, f32::min);
    let band = ymin + 0.02 * (b.max.y - b.min.y).max(1e-6);
    let (mut sum, mut n) = (Vec3::ZERO, 0u32);
    for p in src.iter().filter(|p| p[1] <= band) {
        sum += Vec3::from(*p);
        n += 1;
    }
    let base = if n > 0 { sum / n as f32 } else { Vec3::ZERO };
    let shift = Vec3::new(base.x, b.min.y, base.z);
    for m in [&mut g.wood, &mut g.leaves] {
        for p in &mut m.positions {
            *p = ((Vec3::from(*p) - shift) * unit_scale).to_array();
        }
    }
    let (hierarchy, leaf_count) = cluster::build(&mut g.wood, &mut g.leaves);
    let root = BaseObject {
        level: 1,
        wood: g.wood.clone(),
        leaves: g.leaves.clone(),
        instances: Vec::new(),
        uses: 1,
    };
    let mut p = Plant {
        name: name.to_string(),
        wood: g.wood,
        leaves: g.leaves,
        leaf_texture: g
            .leaf_texture
            .unwrap_or_else(|| crate::texture::leaf_texture(LeafKind::Broadleaf)),
        hierarchy,
        instancing: Instancing {
            objects: vec![BaseObject::default(), root],
            root: 1,
        },
        internodes: 0,
        leaf_count,
        ..Default::default()
    };
    p.update_bbox();
    Ok(p)
}
