// The GPU-driven cull (world/cull.rs): one invocation per pooled tree of a page a pass may see;
// each survivor is appended to its (pass, species) list; then one invocation per indirect draw
// writes its arguments from the list's count.

struct PoolTree {
    base_scale: vec4<f32>,
    // x cos, y sin, z tint seed, w the species' bits
    rot: vec4<f32>,
}

struct Page {
    first: u32,
    count: u32,
    passes: u32,
    pad: u32,
}

struct List {
    offset: u32,
    capacity: u32,
}

struct Draw {
    list: u32,
    index_count: u32,
    first_index: u32,
    pad: u32,
}

struct Params {
    // pass p's plane k at 6p + k: xyz inward normal, w offset
    planes: array<vec4<f32>, 30>,
    // xyz eye, w the camera pass's far distance
    eye_far: vec4<f32>,
    // x species, y pages, z draws, w passes drawn (bit mask)
    info: vec4<u32>,
    // x: camera-pass presence falls from 1 at this distance to 0 at eye_far.w (the world's
    // tree distance); infinite for a world drawn whole
    fade: vec4<f32>,
    // per species: xyz model-space centre of its bounds, w radius (plant units)
    species: array<vec4<f32>, 64>,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> pool: array<PoolTree>;
@group(0) @binding(2) var<storage, read> pages: array<Page>;
@group(0) @binding(3) var<storage, read> lists: array<List>;
@group(0) @binding(4) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> out_trees: array<PoolTree>;
@group(0) @binding(6) var<storage, read> draws: array<Draw>;
@group(0) @binding(7) var<storage, read_write> args: array<u32>;

const PASSES: u32 = 5u;

fn inside(pass_index: u32, c: vec3<f32>, r: f32) -> bool {
    for (var k = 0u; k < 6u; k++) {
        let p = params.planes[pass_index * 6u + k];
        if (dot(p.xyz, c) + p.w < -r) {
            return false;
        }
    }
    return true;
}

@compute @workgroup_size(64)
fn cull(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let page = pages[wg.y];
    let i = wg.x * 64u + li;
    if (i >= page.count) {
        return;
    }
    let t = pool[page.first + i];
    let species = bitcast<u32>(t.rot.w);
    let local = params.species[species];
    let s = t.base_scale.w;
    let q = local.xyz * s;
    let c = t.base_scale.xyz + vec3<f32>(t.rot.x * q.x + t.rot.y * q.z, q.y, -t.rot.y * q.x + t.rot.x * q.z);
    let r = local.w * s;
    let near = distance(c, params.eye_far.xyz) - r;
    var presence = 1.0;
    if (near > params.fade.x) {
        presence = 1.0 - smoothstep(params.fade.x, params.eye_far.w, near);
    }
    for (var p = 0u; p < PASSES; p++) {
        if ((page.passes & (1u << p)) == 0u) {
            continue;
        }
        if (p == 0u && near >= params.eye_far.w) {
            continue;
        }
        if (!inside(p, c, r)) {
            continue;
        }
        let list = p * params.info.x + species;
        let slot = atomicAdd(&counters[list], 1u);
        if (slot < lists[list].capacity) {
            // Shadow casters fade with the camera's trees, so no shadow outlives its tree.
            out_trees[lists[list].offset + slot] = PoolTree(t.base_scale, vec4<f32>(t.rot.xyz, presence));
        }
    }
}

@compute @workgroup_size(64)
fn write_args(@builtin(global_invocation_id) gid: vec3<u32>) {
    let d = gid.x;
    if (d >= params.info.z) {
        return;
    }
    let draw = draws[d];
    let n = min(atomicLoad(&counters[draw.list]), lists[draw.list].capacity);
    // DrawIndexedIndirect: index count, instance count, first index, base vertex, first instance
    args[d * 5u + 0u] = draw.index_count;
    args[d * 5u + 1u] = select(0u, n, draw.index_count > 0u);
    args[d * 5u + 2u] = draw.first_index;
    args[d * 5u + 3u] = 0u;
    args[d * 5u + 4u] = 0u;
}
