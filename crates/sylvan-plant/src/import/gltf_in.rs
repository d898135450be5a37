//! glTF 2.0 reader: walks the default scene's node tree (world transforms applied), reads
//! triangle primitives, sorts them into wood and leaves by material.

use super::{Gathered, Tex, append, check_indices, is_leaf_name};
use crate::PlantError;
use glam::{Mat4, Vec3};
use std::path::Path;

/// Reads a `.gltf` or `.glb` file into wood and leaves (file units, not yet centred).
pub(crate) fn load_gltf(path: &Path) -> Result<Gathered, PlantError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| crate::io_error(&file, e))?;
    let bad = |e: String| {
        PlantError::file(
            &file,
            format!("malformed glTF: {e}"),
            "check the file with a glTF validator or re-export it",
        )
    };
    // gltf-json 1.4 can panic while validating some malformed indices: contain it.
    let parsed = std::panic::catch_unwind(|| gltf::Gltf::from_slice(&bytes))
        .map_err(|_| bad("invalid index in the JSON".into()))?;
    let gltf::Gltf { document, blob } = parsed.map_err(|e| bad(e.to_string()))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers =
        gltf::import_buffers(&document, Some(base), blob).map_err(|e| bad(e.to_string()))?;
    let image_bytes = |img: gltf::Image| -> Option<Vec<u8>> {
        match img.source() {
            gltf::image::Source::View { view, .. } => {
                let b = buffers.get(view.buffer().index())?;
                b.get(view.offset()..view.offset().checked_add(view.length())?)
                    .map(<[u8]>::to_vec)
            }
            gltf::image::Source::Uri { uri, .. } => {
                if uri.starts_with("data:") {
                    None
                } else {
                    std::fs::read(base.join(uri)).ok()
                }
            }
        }
    };
    let mut g = Gathered::default();
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next());
    let mut stack: Vec<(gltf::Node, Mat4, u32)> = match &scene {
        Some(s) => s.nodes().map(|n| (n, Mat4::IDENTITY, 0)).collect(),
        None => document.nodes().map(|n| (n, Mat4::IDENTITY, 0)).collect(),
    };
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > 64 {
            return Err(bad("node tree deeper than 64".into()));
        }
        let m = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        for c in node.children() {
            stack.push((c, m, depth + 1));
        }
        let Some(mesh) = node.mesh() else { continue };
        for prim in mesh.primitives() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                continue;
            }
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
            let Some(pos) = reader.read_positions() else {
                continue;
            };
            let pos: Vec<[f32; 3]> = pos
                .map(|p| m.transform_point3(Vec3::from(p)).to_array())
                .collect();
            if pos.len() > super::MAX_IMPORT_VERTICES {
                return Err(bad("too many vertices".into()));
            }
            let nrm: Option<Vec<[f32; 3]>> = reader.read_normals().map(|it| {
                it.map(|n| m.transform_vector3(Vec3::from(n)).to_array())
                    .collect()
            });
            let uv: Option<Vec<[f32; 2]>> =
                reader.read_tex_coords(0).map(|t| t.into_f32().collect());
            let vcol: Option<Vec<[f32; 4]>> =
                reader.read_colors(0).map(|c| c.into_rgba_f32().collect());
            let idx: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..pos.len() as u32).collect(),
            };
            check_indices(&file, &idx, pos.len())?;
            let mat = prim.material();
            let name = format!("{} {}", mat.name().unwrap_or(""), mesh.name().unwrap_or(""));
            let leaf = mat.alpha_mode() != gltf::material::AlphaMode::Opaque || is_leaf_name(&name);
            let pbr = mat.pbr_metallic_roughness();
            let f = pbr.base_color_factor();
            let tex = pbr
                .base_color_texture()
                .and_then(|t| image_bytes(t.texture().source()))
                .and_then(|b| Tex::decode(&b));
            let vc = |i: usize| {
                vcol.as_ref()
                    .and_then(|c| c.get(i))
                    .map_or([1.0; 3], |c| [c[0], c[1], c[2]])
            };
            if leaf {
                append(
                    &mut g.leaves,
                    &pos,
                    nrm.as_deref(),
                    uv.as_deref(),
                    &|i| {
                        let c = vc(i);
                        [f[0] * c[0], f[1] * c[1], f[2] * c[2]]
                    },
                    &idx,
                );
                if g.leaf_texture.is_none() {
                    g.leaf_texture = tex.map(Tex::into_leaf_texture);
                }
            } else {
                let uvs = uv.clone();
                append(
                    &mut g.wood,
                    &pos,
                    nrm.as_deref(),
                    uv.as_deref(),
                    &|i| {
                        let c = vc(i);
                        let t = match (&tex, &uvs) {
                            (Some(t), Some(u)) => u.get(i).map_or([1.0; 3], |u| t.sample(*u)),
                            _ => [1.0; 3],
                        };
                        [f[0] * c[0] * t[0], f[1] * c[1] * t[1], f[2] * c[2] * t[2]]
                    },
                    &idx,
                );
            }
        }
    }
    Ok(g)
}
