// `hbt`'s GPU-driven frame (gpu_frame.rs): MNP01 §4's level selection, §4.1's direction
// look-ups and reconstruction weights, per tree of the world cull's per-(pass, species) lists
// (each record a tree with its presence in rot.w) — the CPU loop of `Hbt::prepare_frame` with
// the same arithmetic (`select::select` for a tree opening as a whole). Output: per pass one
// billboard list (the camera's sorted back to front by the object's distance, a counting sort
// over distance buckets as in world/cull.wgsl) and per (pass, species) one list of trees drawn
// as their meshes, with the indirect arguments of every draw. Five dispatches:
//   prep        — one invocation: each input list's start in one index space (its count read
//                 from the world cull's indirect arguments) and the selection's dispatch size;
//   select      — one invocation per listed tree: its shares (meshes, tree billboard, main
//                 branches), each billboard's record parked with its segment and place;
//   scan        — one workgroup: segment starts, the draws' arguments, the scatters' sizes;
//   scatter_bb, scatter_mesh — each parked record written at its segment's start + place.
// The direction tables (`DIRECTIONS_WGSL`, appended by gpu_frame.rs) are rows of `tables`.

struct Tree {
    base_scale: vec4<f32>,
    // x cos, y sin, z tint seed, w presence
    rot: vec4<f32>,
}

// `GpuHbtInstance` (gpu.rs).
struct Inst {
    m0: vec4<f32>,
    m1: vec4<f32>,
    m2: vec4<f32>,
    views: vec4<u32>,
    lights: vec4<u32>,
    w0: vec4<f32>,
    w1: vec4<f32>,
    w2: vec4<f32>,
    vis: vec4<u32>,
    extra: vec4<f32>,
}

// A billboard parked for its segment: the record, then (segment, place).
struct ParkedBb {
    inst: Inst,
    at: vec4<u32>,
}

struct Params {
    // xyz eye
    eye: vec4<f32>,
    // xyz towards the sun (shadow casters' view); w the reconstruction's min_weight
    sun: vec4<f32>,
    // xyz the light the billboards are lit from (the sun, or a fixed light); w pixels per
    // metre at one metre
    light: vec4<f32>,
    // eye distance where each cascade ends
    far: vec4<f32>,
    // x input lists, y species, z levels ≥ 3 (meshes drawn), w unused
    info: vec4<u32>,
    // x billboard capacity, y mesh capacity
    caps: vec4<u32>,
    // x nearest bucketed distance, y buckets per log2 of distance
    sort: vec4<f32>,
    // the direction tables: tree views, tree lights, branch views, branch lights
    dirs: array<DirTable, 4>,
    // per input list: x first record in the world's lists, y its count's word in the world's
    // indirect arguments, z pass, w species
    lists: array<vec4<u32>, 320>,
}

const BUCKETS: u32 = 4096u;
const BB_SEGS: u32 = 4100u; // BUCKETS camera buckets (far first), then one per cascade
const C_LIST: u32 = 8u;
const C_SEG: u32 = 336u;
// args: billboard draws at 12 + 4 p; mesh draws at 32 + 5 k
const A_BB: u32 = 12u;
const A_MESH: u32 = 32u;
// Shares below this are not drawn (as the CPU loop).
const SHARE_MIN: f32 = 0.002;
// Rows per species in `tables`; per placement.
const SPECIES_ROWS: u32 = 5u;
const PLACEMENT_ROWS: u32 = 5u;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> trees: array<Tree>;
@group(0) @binding(2) var<storage, read> world_args: array<u32>;
// Per species s at rows 5s..5s+4: (tree image set, first placement row, placements, has
// meshes), (texel, mesh texel, radius, 0) as f32 bits, (open lo, open hi, mesh lo, mesh hi)
// as f32 bits, (model box centre xyz as f32 bits, 0), (wood indices, leaf indices, 0, 0).
// Per placement 5 rows: its object → tree rows (3 × 4 f32 bits), (object box centre xyz, image
// set), (scale, radius, sky at corners 0–3 and 4–7 as unorm8 × 4). Then the direction tables.
@group(0) @binding(3) var<storage, read> tables: array<vec4<u32>>;
// [billboard total, mesh total, listed total, trees opened | trees meshed, 0, 0, 0 | list
// starts (C_LIST) | segment counts (C_SEG) | segment starts]
@group(0) @binding(4) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> parked_bb: array<ParkedBb>;
@group(0) @binding(6) var<storage, read_write> parked_mesh: array<vec4<u32>>;
@group(0) @binding(7) var<storage, read_write> out_bb: array<Inst>;
@group(0) @binding(8) var<storage, read_write> out_mesh: array<Tree>;
@group(0) @binding(9) var<storage, read_write> args: array<u32>;
// The selection's and the scatters' workgroup counts (x, y, z at 0, 3, 6), bound only by
// `prep` and `scan_segments`.
@group(1) @binding(0) var<storage, read_write> dispatch: array<u32>;

fn dir_texel(row: u32) -> vec4<u32> {
    return tables[row];
}

fn dir_face(row: u32) -> vec4<u32> {
    return tables[row];
}

fn dir_sample(row: u32) -> vec4<f32> {
    return bitcast<vec4<f32>>(tables[row]);
}

fn mesh_segs() -> u32 {
    return 5u * params.info.y;
}

fn seg_start(seg: u32) -> u32 {
    return C_SEG + BB_SEGS + mesh_segs() + seg;
}

fn dispatch_size(at: u32, n: u32) {
    let groups = (n + 63u) / 64u;
    dispatch[at] = min(groups, 65535u);
    dispatch[at + 1u] = (groups + 65534u) / 65535u;
    dispatch[at + 2u] = 1u;
}

@compute @workgroup_size(1)
fn prep() {
    var total = 0u;
    for (var l = 0u; l < params.info.x; l++) {
        atomicStore(&counters[C_LIST + l], total);
        total += world_args[params.lists[l].y];
    }
    atomicStore(&counters[C_LIST + params.info.x], total);
    atomicStore(&counters[2], total);
    dispatch_size(0u, total);
}

// `common::smoothstep`: with e1 ≤ e0 a hard step at e0.
fn step_share(e0: f32, e1: f32, x: f32) -> f32 {
    if (e1 <= e0) {
        return select(0.0, 1.0, x >= e0);
    }
    let t = clamp((x - e0) / (e1 - e0), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

// Whether pass `p` draws the meshes of an object `d` metres from the eye with radius `r`:
// the camera, or a cascade that shades it (draw.rs `receives_in`).
fn receives_in(p: u32, d: f32, r: f32) -> bool {
    if (p == 0u) {
        return true;
    }
    let c = p - 1u;
    var near = 0.0;
    if (c > 0u) {
        near = params.far[c - 1u];
    }
    return d + r >= near && d - r <= params.far[c];
}

fn to_model_dir(d: vec3<f32>, c: f32, s: f32) -> vec3<f32> {
    return vec3<f32>(c * d.x - s * d.z, d.y, s * d.x + c * d.z);
}

fn row_f(r: u32) -> vec4<f32> {
    return bitcast<vec4<f32>>(tables[r]);
}

// A billboard record (gpu.rs `billboard`): rows of `to_world`, image set, look-ups,
// visibility (sun lo, hi, sky lo, hi), tint, presence, scale, radius.
fn billboard(m0: vec4<f32>, m1: vec4<f32>, m2: vec4<f32>, image_set: u32, v: DirLookup, l: DirLookup,
             vis: vec4<u32>, extra: vec4<f32>) -> Inst {
    let w = dir_pair_weights(v.weights, l.weights, params.sun.w);
    return Inst(m0, m1, m2, vec4<u32>(v.indices, image_set), vec4<u32>(l.indices, 0u),
        vec4<f32>(w[0], w[1], w[2], w[3]), vec4<f32>(w[4], w[5], w[6], w[7]),
        vec4<f32>(w[8], 0.0, 0.0, 0.0), vis, extra);
}

// A shadow caster (gpu.rs `caster`): the nearest view sample to the sun alone.
fn caster(m0: vec4<f32>, m1: vec4<f32>, m2: vec4<f32>, image_set: u32, v: DirLookup, extra: vec4<f32>) -> Inst {
    // gpu.rs `caster_sample`: the largest weight quantised to 1/1024, the first of equal ones
    // (a tie in exact arithmetic broken alike on the CPU and here).
    let q = floor(v.weights * 1024.0);
    var best = 0u;
    for (var k = 1u; k < 3u; k++) {
        if (q[k] > q[best]) {
            best = k;
        }
    }
    var w = array<f32, 12>(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    w[3u * best] = 1.0;
    return Inst(m0, m1, m2, vec4<u32>(v.indices, image_set), vec4<u32>(0u),
        vec4<f32>(w[0], w[1], w[2], w[3]), vec4<f32>(w[4], w[5], w[6], w[7]),
        vec4<f32>(w[8], 0.0, 0.0, 0.0), vec4<u32>(0xffffffffu), extra);
}

fn park_bb(p: u32, inst: Inst, d: f32) {
    var seg = BUCKETS + p - 1u;
    if (p == 0u) {
        let level = log2(max(d, params.sort.x) / params.sort.x) * params.sort.y;
        seg = BUCKETS - 1u - min(u32(level), BUCKETS - 1u);
    }
    let slot = atomicAdd(&counters[C_SEG + seg], 1u);
    let k = atomicAdd(&counters[0], 1u);
    if (k < params.caps.x) {
        parked_bb[k] = ParkedBb(inst, vec4<u32>(seg, slot, 0u, 0u));
    }
}

fn park_mesh(p: u32, s: u32, src: u32, w: f32) {
    let seg = p * params.info.y + s;
    let slot = atomicAdd(&counters[C_SEG + BB_SEGS + seg], 1u);
    let k = atomicAdd(&counters[1], 1u);
    if (k < params.caps.y) {
        parked_mesh[k] = vec4<u32>(src, seg, slot, bitcast<u32>(w));
    }
}

// Row `i` of the 3 × 4 product of a similarity `a` (rows a0..a2) and one `b` (rows b0..b2).
fn product_row(a: vec4<f32>, b0: vec4<f32>, b1: vec4<f32>, b2: vec4<f32>) -> vec4<f32> {
    let r = a.x * b0 + a.y * b1 + a.z * b2;
    return vec4<f32>(r.xyz, r.w + a.w);
}

@compute @workgroup_size(64)
fn select_levels(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = (wg.y * 65535u + wg.x) * 64u + li;
    if (i >= atomicLoad(&counters[2])) {
        return;
    }
    var l = 0u;
    loop {
        if (l + 1u >= params.info.x || i < atomicLoad(&counters[C_LIST + l + 1u])) {
            break;
        }
        l++;
    }
    let list = params.lists[l];
    let src = list.x + (i - atomicLoad(&counters[C_LIST + l]));
    let p = list.z;
    let s = list.w;
    let t = trees[src];
    let head = tables[SPECIES_ROWS * s];
    let sizes = row_f(SPECIES_ROWS * s + 1u);
    let switches = row_f(SPECIES_ROWS * s + 2u);
    let centre = row_f(SPECIES_ROWS * s + 3u).xyz;
    let c = t.rot.x;
    let sn = t.rot.y;
    let k = t.base_scale.w;
    let m0 = vec4<f32>(c * k, 0.0, sn * k, t.base_scale.x);
    let m1 = vec4<f32>(0.0, k, 0.0, t.base_scale.y);
    let m2 = vec4<f32>(-sn * k, 0.0, c * k, t.base_scale.z);
    let world_centre = vec3<f32>(dot(m0, vec4<f32>(centre, 1.0)), dot(m1, vec4<f32>(centre, 1.0)),
        dot(m2, vec4<f32>(centre, 1.0)));
    let eye = params.eye.xyz - world_centre;
    let dist = max(length(eye), 1e-3);
    let presence = t.rot.w;
    let ppm = params.light.w;
    let radius = sizes.z * k;
    // MNP01 §4 (select.rs `select`, the tree opening as a whole): the level below where the
    // tree's texels would be magnified, the meshes where the level above them would be.
    var open = 0.0;
    if (head.z > 0u) {
        open = step_share(switches.x, switches.y, sizes.x * k * ppm / dist);
    }
    var mesh = 0.0;
    if (params.info.z != 0u && head.w != 0u && receives_in(p, dist, radius)) {
        mesh = step_share(switches.z, switches.w, sizes.y * k * ppm / dist);
    }
    let whole = mesh * presence;
    var tree_bb = (1.0 - open) * (1.0 - mesh) * presence;
    var below = open * (1.0 - mesh) * presence;
    if (p > 0u) {
        // Trees opened into BTFs only cast at the tree level.
        tree_bb += below;
        below = 0.0;
    }
    if (whole > SHARE_MIN) {
        park_mesh(p, s, src, whole);
    }
    let extra = vec4<f32>(t.rot.z, tree_bb, k, radius);
    if (p > 0u) {
        if (tree_bb > SHARE_MIN) {
            let v = dir_lookup_in(to_model_dir(params.sun.xyz, c, sn), params.dirs[0]);
            park_bb(p, caster(m0, m1, m2, head.x, v, extra), 0.0);
        }
        return;
    }
    if (whole > SHARE_MIN || below > SHARE_MIN) {
        atomicAdd(&counters[3], 1u);
        if (whole > SHARE_MIN) {
            atomicAdd(&counters[4], 1u);
        }
    }
    let light_model = to_model_dir(params.light.xyz, c, sn);
    // No scene-level cube-maps on the GPU path (mod.rs): the tree's own visibility is 1.
    let open_sky = vec4<u32>(0xffffffffu);
    if (tree_bb > SHARE_MIN) {
        let v = dir_lookup_in(to_model_dir(eye, c, sn), params.dirs[0]);
        let lt = dir_lookup_in(light_model, params.dirs[1]);
        park_bb(0u, billboard(m0, m1, m2, head.x, v, lt, open_sky, extra), dist);
    }
    if (below <= SHARE_MIN) {
        return;
    }
    for (var j = 0u; j < head.z; j++) {
        let r = head.y + PLACEMENT_ROWS * j;
        let p0 = row_f(r);
        let p1 = row_f(r + 1u);
        let p2 = row_f(r + 2u);
        let info = tables[r + 3u];
        let more = tables[r + 4u];
        let o0 = product_row(m0, p0, p1, p2);
        let o1 = product_row(m1, p0, p1, p2);
        let o2 = product_row(m2, p0, p1, p2);
        let oc = bitcast<vec3<f32>>(info.xyz);
        let centre_o = vec3<f32>(dot(o0, vec4<f32>(oc, 1.0)), dot(o1, vec4<f32>(oc, 1.0)),
            dot(o2, vec4<f32>(oc, 1.0)));
        let eye_o = params.eye.xyz - centre_o;
        // Tree model → object directions: the transpose of the placement's linear part
        // (a similarity), normalised.
        let ve = to_model_dir(eye_o, c, sn);
        let vo = ve.x * p0.xyz + ve.y * p1.xyz + ve.z * p2.xyz;
        let lo = light_model.x * p0.xyz + light_model.y * p1.xyz + light_model.z * p2.xyz;
        let v = dir_lookup_in(select(vec3<f32>(0.0, 1.0, 0.0), vo, dot(vo, vo) > 0.0), params.dirs[2]);
        let lt = dir_lookup_in(select(vec3<f32>(0.0, 1.0, 0.0), lo, dot(lo, lo) > 0.0), params.dirs[3]);
        var inst = billboard(o0, o1, o2, info.w, v, lt,
            vec4<u32>(0xffffffffu, 0xffffffffu, more.z, more.w),
            vec4<f32>(t.rot.z, below, k * bitcast<f32>(more.x), bitcast<f32>(more.y) * k));
        inst.lights.w = 1u;
        park_bb(0u, inst, max(length(eye_o), 1e-3));
    }
}

var<workgroup> partial: array<u32, 256>;

// Exclusive sums of the `n` segment counts from `first` into their starts, by one workgroup.
fn scan(li: u32, first: u32, n: u32) {
    let per = (n + 255u) / 256u;
    let lo = min(li * per, n);
    let hi = min(lo + per, n);
    var sum = 0u;
    for (var s = lo; s < hi; s++) {
        sum += atomicLoad(&counters[C_SEG + first + s]);
    }
    partial[li] = sum;
    workgroupBarrier();
    if (li == 0u) {
        var run = 0u;
        for (var j = 0u; j < 256u; j++) {
            let v = partial[j];
            partial[j] = run;
            run += v;
        }
    }
    workgroupBarrier();
    var run = partial[li];
    for (var s = lo; s < hi; s++) {
        atomicStore(&counters[seg_start(first + s)], run);
        run += atomicLoad(&counters[C_SEG + first + s]);
    }
    workgroupBarrier();
}

// The instances [first, end) of a draw, clipped to `cap`: (count, first instance).
fn clipped(first: u32, end: u32, cap: u32) -> vec2<u32> {
    let a = min(first, cap);
    let b = min(end, cap);
    return vec2<u32>(b - a, a);
}

@compute @workgroup_size(256)
fn scan_segments(@builtin(local_invocation_index) li: u32) {
    scan(li, 0u, BB_SEGS);
    scan(li, BB_SEGS, mesh_segs());
    if (li < 5u) {
        var a = BUCKETS + li - 1u;
        var b = a + 1u;
        if (li == 0u) {
            a = 0u;
            b = BUCKETS;
        }
        let end = atomicLoad(&counters[seg_start(b - 1u)]) + atomicLoad(&counters[C_SEG + b - 1u]);
        let r = clipped(atomicLoad(&counters[seg_start(a)]), end, params.caps.x);
        // DrawIndirect: vertex count, instance count, first vertex, first instance
        let at = A_BB + 4u * li;
        args[at] = 6u;
        args[at + 1u] = r.x;
        args[at + 2u] = 0u;
        args[at + 3u] = r.y;
    }
    let species = params.info.y;
    for (var seg = li; seg < 5u * species; seg += 256u) {
        let counts = tables[SPECIES_ROWS * (seg % species) + 4u];
        let first = atomicLoad(&counters[seg_start(BB_SEGS + seg)]);
        let r = clipped(first, first + atomicLoad(&counters[C_SEG + BB_SEGS + seg]), params.caps.y);
        // DrawIndexedIndirect per mesh: index count, instance count, first index, base vertex,
        // first instance (wood, then leaves)
        for (var m = 0u; m < 2u; m++) {
            let at = A_MESH + 5u * (2u * seg + m);
            args[at] = counts[m];
            args[at + 1u] = r.x;
            args[at + 2u] = 0u;
            args[at + 3u] = 0u;
            args[at + 4u] = r.y;
        }
    }
    if (li == 0u) {
        dispatch_size(3u, min(atomicLoad(&counters[0]), params.caps.x));
        dispatch_size(6u, min(atomicLoad(&counters[1]), params.caps.y));
    }
}

@compute @workgroup_size(64)
fn scatter_bb(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = (wg.y * 65535u + wg.x) * 64u + li;
    if (i >= min(atomicLoad(&counters[0]), params.caps.x)) {
        return;
    }
    let e = parked_bb[i];
    let at = atomicLoad(&counters[seg_start(e.at.x)]) + e.at.y;
    if (at < params.caps.x) {
        out_bb[at] = e.inst;
    }
}

@compute @workgroup_size(64)
fn scatter_mesh(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = (wg.y * 65535u + wg.x) * 64u + li;
    if (i >= min(atomicLoad(&counters[1]), params.caps.y)) {
        return;
    }
    let e = parked_mesh[i];
    let at = atomicLoad(&counters[seg_start(BB_SEGS + e.y)]) + e.z;
    if (at < params.caps.y) {
        let t = trees[e.x];
        out_mesh[at] = Tree(t.base_scale, vec4<f32>(t.rot.xyz, bitcast<f32>(e.w)));
    }
}
