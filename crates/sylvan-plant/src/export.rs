//! Binary glTF 2.0 export: wood and leaves as two meshes with two materials (`bark`: opaque;
//! `leaves`: alpha-masked, double-sided, with the leaf texture as an embedded PNG), per-vertex
//! colours in `COLOR_0`. Written to a temporary file then renamed, so a failed export never
//! leaves a half-written file.

use crate::{Mesh, Plant, PlantError};
use serde_json::{Value, json};
use std::path::Path;

struct Bin {
    data: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.data.len().is_multiple_of(4) {
            self.data.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": self.data.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.data.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    fn floats<const N: usize>(&mut self, items: &[[f32; N]], ty: &str, minmax: bool) -> usize {
        let bytes: Vec<u8> = items
            .iter()
            .flatten()
            .flat_map(|f| f.to_le_bytes())
            .collect();
        let view = self.view(&bytes, Some(34962));
        let mut a =
            json!({"bufferView": view, "componentType": 5126, "count": items.len(), "type": ty});
        if minmax {
            let mut lo = [f32::INFINITY; N];
            let mut hi = [f32::NEG_INFINITY; N];
            for it in items {
                for k in 0..N {
                    lo[k] = lo[k].min(it[k]);
                    hi[k] = hi[k].max(it[k]);
                }
            }
            a["min"] = json!(lo.to_vec());
            a["max"] = json!(hi.to_vec());
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn indices(&mut self, idx: &[u32]) -> usize {
        let bytes: Vec<u8> = idx.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(34963));
        self.accessors.push(json!({"bufferView": view, "componentType": 5125, "count": idx.len(), "type": "SCALAR"}));
        self.accessors.len() - 1
    }

    fn mesh(&mut self, m: &Mesh, name: &str, material: usize) -> Value {
        let pos = self.floats(&m.positions, "VEC3", true);
        let nrm = self.floats(&m.normals, "VEC3", false);
        let uv = self.floats(&m.uvs, "VEC2", false);
        let col = self.floats(&m.colors, "VEC3", false);
        let ind = self.indices(&m.indices);
        json!({"name": name, "primitives": [{
            "attributes": {"POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": uv, "COLOR_0": col},
            "indices": ind, "material": material, "mode": 4}]})
    }
}

fn valid(m: &Mesh) -> bool {
    let n = m.positions.len();
    n > 0
        && !m.indices.is_empty()
        && m.normals.len() == n
        && m.uvs.len() == n
        && m.colors.len() == n
        && m.indices.iter().all(|&i| (i as usize) < n)
}

/// Encodes the plant as binary glTF bytes.
pub fn to_glb(plant: &Plant) -> Result<Vec<u8>, PlantError> {
    let mut bin = Bin {
        data: Vec::new(),
        views: Vec::new(),
        accessors: Vec::new(),
    };
    let mut meshes = Vec::new();
    let mut nodes = Vec::new();
    if valid(&plant.wood) {
        meshes.push(bin.mesh(&plant.wood, "wood", 0));
        nodes.push(json!({"name": "wood", "mesh": meshes.len() - 1}));
    }
    let mut images = Vec::new();
    let mut textures = Vec::new();
    let mut leaf_pbr = json!({"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.8});
    if valid(&plant.leaves) {
        meshes.push(bin.mesh(&plant.leaves, "leaves", 1));
        nodes.push(json!({"name": "leaves", "mesh": meshes.len() - 1}));
        let t = &plant.leaf_texture;
        if t.width > 0 && t.height > 0 && t.rgba.len() == (t.width * t.height * 4) as usize {
            let mut png = Vec::new();
            image::ImageEncoder::write_image(
                image::codecs::png::PngEncoder::new(&mut png),
                &t.rgba,
                t.width,
                t.height,
                image::ExtendedColorType::Rgba8,
            )
            .map_err(|e| {
                PlantError::file(
                    &plant.name,
                    format!("cannot encode the leaf texture: {e}"),
                    "report this bug",
                )
            })?;
            let view = bin.view(&png, None);
            images.push(json!({"bufferView": view, "mimeType": "image/png", "name": "leaf"}));
            textures.push(json!({"source": 0, "sampler": 0}));
            leaf_pbr["baseColorTexture"] = json!({"index": 0});
        }
    }
    while !bin.data.len().is_multiple_of(4) {
        bin.data.push(0);
    }
    let mut doc = json!({
        "asset": {"version": "2.0", "generator": "sylvan-plant"},
        "scene": 0,
        "scenes": [{"name": plant.name, "nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": [
            {"name": "bark", "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.9}},
            {"name": "leaves", "alphaMode": "MASK", "alphaCutoff": 0.5, "doubleSided": true, "pbrMetallicRoughness": leaf_pbr}
        ],
        "accessors": bin.accessors,
        "bufferViews": bin.views,
        "buffers": [{"byteLength": bin.data.len()}],
    });
    if !images.is_empty() {
        doc["images"] = json!(images);
        doc["textures"] = json!(textures);
        doc["samplers"] =
            json!([{"magFilter": 9729, "minFilter": 9987, "wrapS": 33071, "wrapT": 33071}]);
    }
    let mut js = serde_json::to_vec(&doc).map_err(|e| {
        PlantError::file(
            &plant.name,
            format!("cannot write JSON: {e}"),
            "report this bug",
        )
    })?;
    while !js.len().is_multiple_of(4) {
        js.push(b' ');
    }
    let total = 12 + 8 + js.len() + 8 + bin.data.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(js.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&js);
    out.extend_from_slice(&(bin.data.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin.data);
    Ok(out)
}

/// Writes the plant to `path` as binary glTF (temp file + rename).
pub fn write_glb(plant: &Plant, path: &Path) -> Result<(), PlantError> {
    let file = path.display().to_string();
    let bytes = to_glb(plant)?;
    let tmp = path.with_extension("glb.tmp");
    std::fs::write(&tmp, &bytes).map_err(|e| {
        PlantError::file(
            &file,
            format!("cannot write: {e}"),
            "check the folder exists and is writable",
        )
    })?;
    std::fs::rename(&tmp, path).map_err(|e| {
        PlantError::file(
            &file,
            format!("cannot write: {e}"),
            "check the folder is writable",
        )
    })
}
