//! Wavefront OBJ + MTL reader (via `tobj`): triangulated, one index per vertex; materials
//! decide wood vs leaves. Texture paths are resolved next to the MTL file, and absolute paths
//! from another machine (`G:\...\bark.png`) fall back to their file name there.

use super::{Gathered, MAX_IMPORT_BYTES, Tex, append, check_indices, is_leaf_name};
use crate::PlantError;
use std::cell::Cell;
use std::path::Path;

/// `sylvan_io::read` within what is left of the import budget, which it then lowers.
fn read_budget(path: &Path, budget: &Cell<u64>) -> Result<Vec<u8>, sylvan_io::ReadError> {
    let bytes = sylvan_io::read(path, budget.get())?;
    budget.set(budget.get() - bytes.len() as u64);
    Ok(bytes)
}

fn find_texture(dir: &Path, name: &str, budget: &Cell<u64>) -> Option<Tex> {
    let name = name.trim();
    let direct = dir.join(name);
    let bytes = read_budget(&direct, budget).ok().or_else(|| {
        let base = name.rsplit(['/', '\\']).next()?;
        read_budget(&dir.join(base), budget).ok()
    })?;
    Tex::decode(&bytes)
}

/// Reads an `.obj` (and its `.mtl`) into wood and leaves (file units, not yet centred).
pub(crate) fn load_obj(path: &Path) -> Result<Gathered, PlantError> {
    let file = path.display().to_string();
    let budget = Cell::new(MAX_IMPORT_BYTES);
    let dir = path.parent().unwrap_or(Path::new("."));
    let obj = read_budget(path, &budget).map_err(|e| crate::io_error(&file, e))?;
    obj_from_bytes(&file, &obj, dir, budget)
}

/// Reads an `.obj` file's bytes (named `file` in errors); MTL files and textures resolve
/// against `dir` and are read within `budget` bytes.
pub(crate) fn obj_from_bytes(
    file: &str,
    obj: &[u8],
    dir: &Path,
    budget: Cell<u64>,
) -> Result<Gathered, PlantError> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // MTL files go through the same bounded reader. A missing one is tolerated (default
    // materials, as before); one that is a device or a FIFO, or too large, stops the import.
    let mtl_error = std::cell::RefCell::new(None);
    let load_mtl = |m: &Path| {
        let p = dir.join(m);
        match read_budget(&p, &budget) {
            Ok(b) => tobj::load_mtl_buf(&mut &b[..]),
            Err(e) if matches!(e.kind(), sylvan_io::ErrorKind::NotFound) => {
                Err(tobj::LoadError::OpenFileFailed)
            }
            Err(e) => {
                mtl_error.borrow_mut().get_or_insert_with(|| {
                    PlantError::file(file, format!("mtllib '{}': {e}", p.display()), e.fix())
                });
                Err(tobj::LoadError::OpenFileFailed)
            }
        }
    };
    let (models, mats) = tobj::load_obj_buf(&mut &obj[..], &opts, load_mtl).map_err(|e| {
        PlantError::file(
            file,
            format!("malformed OBJ: {e}"),
            "check the file or re-export it as OBJ",
        )
    })?;
    if let Some(e) = mtl_error.into_inner() {
        return Err(e);
    }
    let mats = mats.unwrap_or_default();
    let mut textures: Vec<Option<Tex>> = mats
        .iter()
        .map(|m| {
            m.diffuse_texture
                .as_deref()
                .and_then(|t| find_texture(dir, t, &budget))
        })
        .collect();
    let mut g = Gathered::default();
    for model in &models {
        let mesh = &model.mesh;
        if mesh.positions.len() % 3 != 0
            || mesh.texcoords.len() % 2 != 0
            || mesh.normals.len() % 3 != 0
        {
            return Err(PlantError::file(
                file,
                "malformed OBJ: attribute arrays have odd lengths",
                "re-export the mesh",
            ));
        }
        let pos: Vec<[f32; 3]> = mesh
            .positions
            .chunks_exact(3)
            .map(|p| [p[0], p[1], p[2]])
            .collect();
        let nrm: Vec<[f32; 3]> = mesh
            .normals
            .chunks_exact(3)
            .map(|p| [p[0], p[1], p[2]])
            .collect();
        // OBJ's v runs up; glTF-style v (and our leaf textures) run down.
        let uv: Vec<[f32; 2]> = mesh
            .texcoords
            .chunks_exact(2)
            .map(|p| [p[0], 1.0 - p[1]])
            .collect();
        check_indices(file, &mesh.indices, pos.len())?;
        let mat = mesh.material_id.and_then(|i| mats.get(i));
        let mname = mat.map_or("", |m| m.name.as_str());
        let leaf = is_leaf_name(mname)
            || is_leaf_name(&model.name)
            || mat.is_some_and(|m| {
                m.dissolve_texture.is_some() || m.dissolve.is_some_and(|d| d < 1.0)
            });
        let kd = mat.and_then(|m| m.diffuse).unwrap_or([1.0, 1.0, 1.0]);
        let tex = mesh
            .material_id
            .and_then(|i| textures.get(i))
            .and_then(Option::as_ref);
        let nrm_opt = (nrm.len() == pos.len()).then_some(&nrm[..]);
        let uv_opt = (uv.len() == pos.len()).then_some(&uv[..]);
        if leaf {
            append(&mut g.leaves, &pos, nrm_opt, uv_opt, &|_| kd, &mesh.indices);
            if g.leaf_texture.is_none()
                && let Some(i) = mesh.material_id
                && let Some(t) = textures.get_mut(i).and_then(Option::take)
            {
                g.leaf_texture = Some(t.into_leaf_texture());
            }
        } else {
            append(
                &mut g.wood,
                &pos,
                nrm_opt,
                uv_opt,
                &|i| {
                    let t = match (tex, uv_opt) {
                        (Some(t), Some(u)) => t.sample(u[i]),
                        _ => [1.0; 3],
                    };
                    [kd[0] * t[0], kd[1] * t[1], kd[2] * t[2]]
                },
                &mesh.indices,
            );
        }
    }
    Ok(g)
}
