//! glTF 2.0 reader: walks the default scene's node tree (world transforms applied), reads
//! triangle primitives, sorts them into wood and leaves by material.
//!
//! Hostile files are refused before anything large is allocated: every byte read (the file, its
//! external buffers, its texture files) goes through `sylvan_io` under one budget of
//! [`super::MAX_IMPORT_BYTES`]; every accessor is checked against its buffer view (stride at least
//! the element size, all elements inside the view, the view inside its buffer) so the `gltf`
//! crate's reader cannot assert; node instances are counted while the node graph is expanded
//! ([`MAX_NODE_INSTANCES`]) and vertices are counted before each primitive is read.

use super::{
    Gathered, MAX_IMPORT_BYTES, MAX_IMPORT_VERTICES, Tex, append, check_indices, is_leaf_name,
};
use crate::PlantError;
use glam::{Mat4, Vec3};
use std::path::{Path, PathBuf};

/// Most node instances (a node reached through every path of the scene graph counts once per
/// path) expanded from one file. Checked while expanding, so a small file whose nodes fan out
/// exponentially is refused before its instances are gathered.
pub const MAX_NODE_INSTANCES: usize = 65_536;

/// Reads one buffer's bytes: the GLB blob, a `data:` URI (already bounded by the JSON's size), or
/// a file next to the glTF read through `sylvan_io` within `budget` bytes.
fn read_buffer(
    file: &str,
    buffer: &gltf::Buffer,
    base: &Path,
    blob: &mut Option<Vec<u8>>,
    budget: &mut u64,
) -> Result<Vec<u8>, PlantError> {
    let bad = |e: String| {
        PlantError::file(
            file,
            format!("malformed glTF: {e}"),
            "check the file with a glTF validator or re-export it",
        )
    };
    let mut data = match buffer.source() {
        gltf::buffer::Source::Bin => blob
            .take()
            .ok_or_else(|| bad("the GLB has no binary chunk".into()))?,
        gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
            gltf::buffer::Data::from_source(buffer.source(), None)
                .map_err(|e| bad(e.to_string()))?
                .0
        }
        gltf::buffer::Source::Uri(uri) => {
            let path = uri_path(base, uri)
                .ok_or_else(|| bad(format!("buffer uri '{uri}' is not a file path")))?;
            read_budget(&path, budget).map_err(|e| {
                PlantError::file(file, format!("buffer '{}': {e}", path.display()), e.fix())
            })?
        }
    };
    if data.len() < buffer.length() {
        return Err(bad(format!(
            "buffer {} holds {} bytes, the file says {}",
            buffer.index(),
            data.len(),
            buffer.length()
        )));
    }
    while data.len() % 4 != 0 {
        data.push(0);
    }
    Ok(data)
}

/// The file a relative or `file:` URI names, percent-decoded; `None` for other schemes.
fn uri_path(base: &Path, uri: &str) -> Option<PathBuf> {
    let rest = uri
        .strip_prefix("file://")
        .or_else(|| uri.strip_prefix("file:"));
    if rest.is_none() && uri.contains(':') {
        return None;
    }
    let raw = rest.unwrap_or(uri).as_bytes();
    let mut out = Vec::with_capacity(raw.len());
    let mut i = 0;
    while i < raw.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        match (
            raw[i],
            raw.get(i + 1).and_then(|&b| hex(b)),
            raw.get(i + 2).and_then(|&b| hex(b)),
        ) {
            (b'%', Some(h), Some(l)) => {
                out.push((h * 16 + l) as u8);
                i += 3;
            }
            (b, ..) => {
                out.push(b);
                i += 1;
            }
        }
    }
    Some(base.join(String::from_utf8_lossy(&out).as_ref()))
}

/// `sylvan_io::read` within what is left of the import budget, which it then lowers.
fn read_budget(path: &Path, budget: &mut u64) -> Result<Vec<u8>, sylvan_io::ReadError> {
    let bytes = sylvan_io::read(path, *budget)?;
    *budget -= bytes.len() as u64;
    Ok(bytes)
}

/// Checks that every primitive's POSITION attribute names an existing accessor (before
/// `gltf`'s validation, which indexes with it unchecked).
fn check_position_indices(json: &gltf::json::Root) -> Result<(), String> {
    let positions = gltf::json::validation::Checked::Valid(gltf::Semantic::Positions);
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            if let Some(i) = prim.attributes.get(&positions)
                && i.value() >= json.accessors.len()
            {
                return Err(format!(
                    "mesh {m} primitive {p}: POSITION names accessor {}, the file has {}",
                    i.value(),
                    json.accessors.len()
                ));
            }
        }
    }
    Ok(())
}

/// Checks that the accessors a triangle primitive is read through have the types glTF 2.0
/// requires for their semantic (the `gltf` reader hits `unreachable!` on, e.g., float indices).
fn check_primitive_types(prim: &gltf::Primitive) -> Result<(), String> {
    use gltf::Semantic;
    use gltf::accessor::{DataType as D, Dimensions as N};
    let check = |what: &str, a: &gltf::Accessor, dims: &[N], types: &[D]| {
        if dims.contains(&a.dimensions()) && types.contains(&a.data_type()) {
            Ok(())
        } else {
            Err(format!(
                "{what} accessor {} is {:?} of {:?}, which glTF does not allow there",
                a.index(),
                a.dimensions(),
                a.data_type()
            ))
        }
    };
    for (semantic, a) in prim.attributes() {
        match semantic {
            Semantic::Positions => check("POSITION", &a, &[N::Vec3], &[D::F32])?,
            Semantic::Normals => check("NORMAL", &a, &[N::Vec3], &[D::F32])?,
            Semantic::TexCoords(_) => check("TEXCOORD", &a, &[N::Vec2], &[D::F32, D::U8, D::U16])?,
            Semantic::Colors(_) => {
                check("COLOR", &a, &[N::Vec3, N::Vec4], &[D::F32, D::U8, D::U16])?
            }
            _ => {}
        }
    }
    if let Some(a) = prim.indices() {
        check("indices", &a, &[N::Scalar], &[D::U8, D::U16, D::U32])?;
    }
    Ok(())
}

/// Checks every accessor against its buffer view and buffer so that reading it cannot go out of
/// bounds (the `gltf` crate asserts on a stride smaller than the element).
fn check_accessors(doc: &gltf::Document, buffers: &[Vec<u8>]) -> Result<(), String> {
    let view_in_buffer = |v: &gltf::buffer::View| -> Result<(), String> {
        let len = buffers.get(v.buffer().index()).map_or(0, Vec::len);
        match v.offset().checked_add(v.length()) {
            Some(end) if end <= len => Ok(()),
            _ => Err(format!(
                "buffer view {} ends past its buffer ({len} bytes)",
                v.index()
            )),
        }
    };
    for a in doc.accessors() {
        let (n, elem) = (a.count(), a.size());
        if n > MAX_IMPORT_VERTICES * 3 {
            return Err(format!("accessor {} has {n} elements", a.index()));
        }
        if let Some(v) = a.view() {
            view_in_buffer(&v)?;
            let stride = v.stride().unwrap_or(elem);
            if stride < elem {
                return Err(format!(
                    "accessor {}: byte stride {stride} is smaller than its element ({elem} bytes)",
                    a.index()
                ));
            }
            let end = n
                .checked_sub(1)
                .map(|last| {
                    last.checked_mul(stride)
                        .and_then(|o| o.checked_add(a.offset() + elem))
                })
                .unwrap_or(Some(0));
            if end.is_none_or(|e| e > v.length()) {
                return Err(format!(
                    "accessor {} reads past the end of buffer view {}",
                    a.index(),
                    v.index()
                ));
            }
        }
        if let Some(s) = a.sparse() {
            let k = s.count();
            let (iv, vv) = (s.indices().view(), s.values().view());
            view_in_buffer(&iv)?;
            view_in_buffer(&vv)?;
            let isize = s.indices().index_type().size();
            let fits = |off: usize, each: usize, len: usize| {
                k.checked_mul(each)
                    .and_then(|b| b.checked_add(off))
                    .is_some_and(|e| e <= len)
            };
            if k > n
                || !fits(s.indices().offset(), isize, iv.length())
                || !fits(s.values().offset(), elem, vv.length())
            {
                return Err(format!("accessor {}: sparse data out of bounds", a.index()));
            }
        }
    }
    Ok(())
}

/// Reads a `.gltf` or `.glb` file into wood and leaves (file units, not yet centred).
pub(crate) fn load_gltf(path: &Path) -> Result<Gathered, PlantError> {
    let file = path.display().to_string();
    let mut budget = MAX_IMPORT_BYTES;
    let bytes = read_budget(path, &mut budget).map_err(|e| crate::io_error(&file, e))?;
    let base = path.parent().unwrap_or(Path::new("."));
    gltf_from_bytes(&file, &bytes, base, budget)
}

/// Reads a `.gltf` or `.glb` file's `bytes` (named `file` in errors); external buffers and
/// textures resolve against `base` and are read within `budget` bytes.
pub(crate) fn gltf_from_bytes(
    file: &str,
    bytes: &[u8],
    base: &Path,
    mut budget: u64,
) -> Result<Gathered, PlantError> {
    let bad = |e: String| {
        PlantError::file(
            file,
            format!("malformed glTF: {e}"),
            "check the file with a glTF validator or re-export it",
        )
    };
    // gltf-json 1.4's validation indexes `accessors` with each POSITION attribute unchecked (a
    // panic on a file naming a missing accessor): parse, check those indices, then validate.
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| bad(e.to_string()))?;
    let json = document.into_json();
    check_position_indices(&json).map_err(bad)?;
    let document = gltf::Document::from_json(json).map_err(|e| bad(e.to_string()))?;
    let mut blob = blob;
    let buffers = document
        .buffers()
        .map(|b| read_buffer(file, &b, base, &mut blob, &mut budget))
        .collect::<Result<Vec<_>, _>>()?;
    check_accessors(&document, &buffers).map_err(bad)?;
    let mut image_bytes = |img: gltf::Image| -> Option<Vec<u8>> {
        match img.source() {
            gltf::image::Source::View { view, .. } => {
                let b = buffers.get(view.buffer().index())?;
                b.get(view.offset()..view.offset().checked_add(view.length())?)
                    .map(<[u8]>::to_vec)
            }
            gltf::image::Source::Uri { uri, .. } => {
                // A missing or oversized texture falls back to the procedural one.
                read_budget(&uri_path(base, uri)?, &mut budget).ok()
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
    let (mut instances, mut vertices) = (0usize, 0usize);
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > 64 {
            return Err(bad("node tree deeper than 64".into()));
        }
        instances += 1;
        if instances > MAX_NODE_INSTANCES {
            return Err(PlantError::file(
                file,
                format!("the node graph expands to more than {MAX_NODE_INSTANCES} node instances"),
                "flatten the scene graph or export fewer instances",
            ));
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
            check_primitive_types(&prim).map_err(bad)?;
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d[..]));
            let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
                continue;
            };
            vertices += pos_acc.count();
            if vertices > MAX_IMPORT_VERTICES {
                return Err(PlantError::file(
                    file,
                    format!("more than {MAX_IMPORT_VERTICES} vertices (counting every instance)"),
                    "decimate the mesh",
                ));
            }
            let Some(pos) = reader.read_positions() else {
                continue;
            };
            let pos: Vec<[f32; 3]> = pos
                .map(|p| m.transform_point3(Vec3::from(p)).to_array())
                .collect();
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
            check_indices(file, &idx, pos.len())?;
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
