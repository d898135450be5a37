//! [`DIRECTIONS_WGSL`]: the table lookup of [`super::DirectionLut::lookup`] and the pair
//! weights of [`super::pair_weights`] for shaders, and its naga validation.

/// WGSL of [`DirectionLut::lookup`](super::DirectionLut::lookup): `fn dir_lookup_in(d: vec3<f32>, t: DirTable) -> DirLookup`
/// returns the 3 sample indices and weights for direction `d` (any length) in table `t`, whose
/// texels, faces and samples start at rows `t.texels`, `t.faces`, `t.samples` of storage the
/// includer reads through `fn dir_texel(row: u32) -> vec4<u32>`, `fn dir_face(row: u32) ->
/// vec4<u32>` and `fn dir_sample(row: u32) -> vec4<f32>` (so one shader may hold several
/// tables, e.g. in one buffer of rows). [`DirectionLut::bindings_wgsl`](super::DirectionLut::bindings_wgsl)
/// declares one table in three buffers with those accessors and `fn dir_lookup(d)`. Zero, NaN
/// and infinite `d` give the table's cell 0 with weights (1, 0, 0) where the driver keeps NaN
/// comparisons IEEE.
pub const DIRECTIONS_WGSL: &str = r#"
// MNP01 §4.1 direction table lookup (sylvan_render::directions).
const DIR_NO_FACE: u32 = 0xffffu;
const DIR_NO_SCORE: f32 = -3.4e38;
const DIR_MAX_COMPONENT: f32 = 3.4e38;

struct DirLookup {
    indices: vec3<u32>,
    weights: vec3<f32>,
}

// A table's first texel, face and sample rows and its texels per side.
struct DirTable {
    texels: u32,
    resolution: u32,
    faces: u32,
    samples: u32,
}

fn dir_octahedral_uv(d: vec3<f32>) -> vec2<f32> {
    let p = d / (abs(d.x) + abs(d.y) + abs(d.z));
    if p.z >= 0.0 {
        return p.xy;
    }
    let s = select(vec2<f32>(-1.0), vec2<f32>(1.0), p.xy >= vec2<f32>(0.0));
    return (vec2<f32>(1.0) - abs(p.yx)) * s;
}

fn dir_cell_weights(d: vec3<f32>, face: vec3<u32>, t: DirTable) -> vec3<f32> {
    let a = dir_sample(t.samples + face.x).xyz;
    let b = dir_sample(t.samples + face.y).xyz;
    let c = dir_sample(t.samples + face.z).xyz;
    let w = vec3<f32>(dot(d, cross(b, c)), dot(d, cross(c, a)), dot(d, cross(a, b)));
    let sum = w.x + w.y + w.z;
    if sum > 0.0 {
        return w / sum;
    }
    return vec3<f32>(DIR_NO_SCORE);
}

fn dir_lookup_in(d_in: vec3<f32>, table: DirTable) -> DirLookup {
    var out = DirLookup(dir_face(table.faces).xyz, vec3<f32>(1.0, 0.0, 0.0));
    let m = max(max(abs(d_in.x), abs(d_in.y)), abs(d_in.z));
    if !(m > 0.0 && m <= DIR_MAX_COMPONENT) {
        return out;
    }
    let d = normalize(d_in / m);
    let r = table.resolution;
    let t = floor((dir_octahedral_uv(d) * 0.5 + 0.5) * f32(r));
    let texel_xy = vec2<u32>(clamp(t, vec2<f32>(0.0), vec2<f32>(f32(r - 1u))));
    let texel = dir_texel(table.texels + texel_xy.y * r + texel_xy.x);
    var best = DIR_NO_SCORE;
    for (var k = 0u; k < 8u; k++) {
        let id = (texel[k >> 1u] >> ((k & 1u) * 16u)) & 0xffffu;
        if id == DIR_NO_FACE {
            break;
        }
        let face = dir_face(table.faces + id).xyz;
        let w = dir_cell_weights(d, face, table);
        let score = min(w.x, min(w.y, w.z));
        if score > best {
            best = score;
            out = DirLookup(face, w);
        }
    }
    let w = max(out.weights, vec3<f32>(0.0));
    let sum = w.x + w.y + w.z;
    out.weights = select(vec3<f32>(1.0, 0.0, 0.0), w / sum, sum > 0.0);
    return out;
}

// MNP01 §4.1 (= directions::pair_weights): the 9 pair weights view_w[i] · light_w[j], view
// major, those below min_weight dropped and the rest renormalised; all below: the largest alone.
fn dir_pair_weights(view_w: vec3<f32>, light_w: vec3<f32>, min_weight: f32) -> array<f32, 9> {
    var w: array<f32, 9>;
    var best = 0u;
    for (var k = 0u; k < 9u; k++) {
        w[k] = max(view_w[k / 3u], 0.0) * max(light_w[k % 3u], 0.0);
        if k > 0u && w[k] > w[best] {
            best = k;
        }
    }
    var sum = 0.0;
    for (var k = 0u; k < 9u; k++) {
        if w[k] < min_weight {
            w[k] = 0.0;
        }
        sum += w[k];
    }
    for (var k = 0u; k < 9u; k++) {
        w[k] = select(w[k] / sum, select(0.0, 1.0, k == best), sum <= 0.0);
    }
    return w;
}
"#;
#[cfg(test)]
mod tests {
    use super::*;
    use crate::directions::DirectionLut;

    #[test]
    fn wgsl_validates() {
        let source = format!(
            "{}{DIRECTIONS_WGSL}\n\
             @group(0) @binding(3) var<storage, read_write> out: array<vec4<f32>>;\n\
             @compute @workgroup_size(64)\n\
             fn main(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
                 let l = dir_lookup(out[id.x].xyz);\n\
                 out[id.x] = vec4<f32>(l.weights, f32(l.indices.x + l.indices.y + l.indices.z));\n\
             }}\n",
            DirectionLut::bindings_wgsl(0, 0)
        );
        let module = naga::front::wgsl::parse_str(&source)
            .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&source)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&source)));
    }
}
