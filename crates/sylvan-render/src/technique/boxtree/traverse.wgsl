// `boxtree`'s GPU-driven frame (gpu.rs): LCV04 §4.1–§4.2's per-tree traversal, on the GPU.
// Input: the world cull's per-(pass, species) lists (each record a tree with its presence in
// rot.w). Output: per pass one impostor list (the camera's sorted back to front by box
// distance, a counting sort over distance buckets as in world/cull.wgsl) and per (pass, box)
// one list of trees whose box is opened (its residual leaves and wood drawn as geometry), with
// the indirect arguments of every draw. Five dispatches:
//   prep        — one invocation: each input list's start in one index space (its count read
//                 from the world cull's indirect arguments) and the traversal's dispatch size;
//   traverse    — one invocation per listed tree: walks the species' boxes in pre-order (the
//                 CPU `traverse::traverse`, same arithmetic), parks every impostor and opened
//                 box with its segment and place in it;
//   scan        — one workgroup: segment starts (exclusive sums), the draws' arguments and the
//                 scatters' dispatch sizes;
//   scatter_imp, scatter_res — each parked record written at its segment's start + place.

struct Tree {
    base_scale: vec4<f32>,
    // x cos, y sin, z tint seed, w presence
    rot: vec4<f32>,
}

struct Impostor {
    base_scale: vec4<f32>,
    rot: vec4<f32>,
    box_index: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

// An impostor parked for its segment: a = (tree record, global box, segment, place), b.x its
// presence bits.
struct ParkedImp {
    a: vec4<u32>,
    b: vec4<u32>,
}

struct Params {
    // xyz eye; w transition band (relative to the LOD distance)
    eye_band: vec4<f32>,
    // per pass: x pixels per metre (over texel_pixels), y footprint floor (metres; 0 none),
    // [z, w) the eye distances of the receivers the pass shadows (the floor applies outside)
    views: array<vec4<f32>, 5>,
    // x input lists, y first box row in `tables`, z boxes in all, w impostor vertices per box
    info: vec4<u32>,
    // x impostor capacity, y residual capacity, z first row of the species' box runs (first
    // global box, boxes) in `tables`, w species
    caps: vec4<u32>,
    // x nearest bucketed distance, y buckets per log2 of distance
    sort: vec4<f32>,
    // per input list: x first record in the world's lists, y its count's word in the world's
    // indirect arguments, z pass, w species
    lists: array<vec4<u32>, 320>,
}

const BUCKETS: u32 = 4096u;
const IMP_SEGS: u32 = 4100u; // BUCKETS camera buckets (far first), then one per cascade
const C_LIST: u32 = 4u;
const C_SEG: u32 = 328u;
const MAX_DEPTH: u32 = 64u;
const SNAP: f32 = 0.02;
// args: impostor draws at 12 + 4 p; residual draws at 32 + 5 k (k = 2 (pass · boxes + box) +
// mesh); then those of opened boxes compacted per (pass, mesh, species)
const A_IMP: u32 = 12u;
const A_RES: u32 = 32u;
// dispatch: the multi-draw runs (gpu.rs `D_MDI`) after the three workgroup counts
const D_MDI: u32 = 9u;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> trees: array<Tree>;
@group(0) @binding(2) var<storage, read> world_args: array<u32>;
// [species: (first node row, nodes)] [nodes: (global box, depth, subtree size, has residual)]
// from row info.y, per box two rows: (centre xyz, metres per texel as bits), (wood first, wood
// count, leaf first, leaf count)
@group(0) @binding(3) var<storage, read> tables: array<vec4<u32>>;
// [imp total, res total, in total, pad | list starts (C_LIST) | segment counts (C_SEG) |
// segment starts]
@group(0) @binding(4) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> parked_imp: array<ParkedImp>;
@group(0) @binding(6) var<storage, read_write> parked_res: array<vec4<u32>>;
@group(0) @binding(7) var<storage, read_write> out_imp: array<Impostor>;
@group(0) @binding(8) var<storage, read_write> out_res: array<Tree>;
@group(0) @binding(9) var<storage, read_write> args: array<u32>;
// The traversal's and the scatters' workgroup counts (x, y, z at 0, 3, 6): a group of its own,
// bound only by `prep` and `scan_segments` (a buffer cannot be written and read as a
// dispatch's indirect arguments in one usage scope).
@group(1) @binding(0) var<storage, read_write> dispatch: array<u32>;

fn res_segs() -> u32 {
    return 5u * params.info.z;
}

fn seg_start(seg: u32) -> u32 {
    return C_SEG + IMP_SEGS + res_segs() + seg;
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

fn smoothstep01(t: f32) -> f32 {
    let x = clamp(t, 0.0, 1.0);
    return x * x * (3.0 - 2.0 * x);
}

// Metres covered by one pixel at `d` in pass `p` (traverse.rs `LodView::footprint_at`).
fn footprint_at(p: u32, d: f32) -> f32 {
    let v = params.views[p];
    let perspective = d / max(v.x, 1e-6);
    let inside = d >= v.z && d < v.w;
    return select(max(v.y, perspective), perspective, inside);
}

fn park_impostor(p: u32, src: u32, gbox: u32, w: f32, d: f32) {
    var seg = BUCKETS + p - 1u;
    if (p == 0u) {
        let level = log2(max(d, params.sort.x) / params.sort.x) * params.sort.y;
        seg = BUCKETS - 1u - min(u32(level), BUCKETS - 1u);
    }
    let slot = atomicAdd(&counters[C_SEG + seg], 1u);
    let k = atomicAdd(&counters[0], 1u);
    if (k < params.caps.x) {
        parked_imp[k] = ParkedImp(vec4<u32>(src, gbox, seg, slot), vec4<u32>(bitcast<u32>(w), 0u, 0u, 0u));
    }
}

fn park_residual(p: u32, src: u32, gbox: u32, w: f32) {
    let seg = p * params.info.z + gbox;
    let slot = atomicAdd(&counters[C_SEG + IMP_SEGS + seg], 1u);
    let k = atomicAdd(&counters[1], 1u);
    if (k < params.caps.y) {
        parked_res[k] = vec4<u32>(src, seg, slot, bitcast<u32>(w));
    }
}

@compute @workgroup_size(64)
fn traverse(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
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
    let t = trees[src];
    let species = tables[list.w];
    let band = params.eye_band.w;
    var open: array<f32, MAX_DEPTH>;
    var k = 0u;
    loop {
        if (k >= species.y) {
            break;
        }
        let node = tables[species.x + k];
        let depth = node.y;
        var w = t.rot.w;
        if (depth > 0u) {
            w = open[depth - 1u];
        }
        let row = tables[params.info.y + 2u * node.x];
        let q = bitcast<vec3<f32>>(row.xyz) * t.base_scale.w;
        let world = t.base_scale.xyz + vec3<f32>(t.rot.x * q.x + t.rot.y * q.z, q.y, -t.rot.y * q.x + t.rot.x * q.z);
        let d = distance(world, params.eye_band.xyz);
        let texel = bitcast<f32>(row.w) * t.base_scale.w;
        var imp = smoothstep01((footprint_at(p, d) / max(texel, 1e-9) - 1.0) / max(band, 1e-3));
        if (imp < SNAP) {
            imp = 0.0;
        } else if (imp > 1.0 - SNAP) {
            imp = 1.0;
        }
        if (imp > 0.0) {
            park_impostor(p, src, node.x, w * imp, d);
        }
        let o = w * (1.0 - imp);
        if (o > 0.0) {
            if (node.w != 0u) {
                park_residual(p, src, node.x, o);
            }
            open[depth] = o;
            k += 1u;
        } else {
            k += node.z;
        }
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
    scan(li, 0u, IMP_SEGS);
    scan(li, IMP_SEGS, res_segs());
    let boxes = params.info.z;
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
        let at = A_IMP + 4u * li;
        args[at] = params.info.w;
        args[at + 1u] = r.x;
        args[at + 2u] = 0u;
        args[at + 3u] = r.y;
    }
    for (var seg = li; seg < 5u * boxes; seg += 256u) {
        let gbox = seg % boxes;
        let ranges = tables[params.info.y + 2u * gbox + 1u];
        let first = atomicLoad(&counters[seg_start(IMP_SEGS + seg)]);
        let r = clipped(first, first + atomicLoad(&counters[C_SEG + IMP_SEGS + seg]), params.caps.y);
        // DrawIndexedIndirect per mesh: index count, instance count, first index, base vertex,
        // first instance (wood, then leaves)
        for (var m = 0u; m < 2u; m++) {
            let at = A_RES + 5u * (2u * seg + m);
            args[at] = ranges[2u * m + 1u];
            args[at + 1u] = r.x;
            args[at + 2u] = ranges[2u * m];
            args[at + 3u] = 0u;
            args[at + 4u] = r.y;
        }
    }
    // Multi-draw runs (gpu.rs `residual_run`): per (pass, mesh, species) the draws of its
    // opened boxes, in box order, compacted into `dispatch` after the workgroup counts, the
    // rest of the run emptied.
    storageBarrier();
    let species = params.caps.w;
    for (var k = li; k < 10u * species; k += 256u) {
        let pm = k / species; // pass · 2 + mesh
        let run = tables[params.caps.z + k % species];
        var n = 0u;
        for (var b = 0u; b < run.y; b++) {
            let src = A_RES + 5u * (2u * ((pm / 2u) * boxes + run.x + b) + pm % 2u);
            if (args[src] > 0u && args[src + 1u] > 0u) {
                let dst = D_MDI + 5u * (pm * boxes + run.x + n);
                for (var w = 0u; w < 5u; w++) {
                    dispatch[dst + w] = args[src + w];
                }
                n++;
            }
        }
        // The run's tail draws nothing (the multi-draw walks the whole run).
        for (var b = n; b < run.y; b++) {
            let dst = D_MDI + 5u * (pm * boxes + run.x + b);
            for (var w = 0u; w < 5u; w++) {
                dispatch[dst + w] = 0u;
            }
        }
    }
    if (li == 0u) {
        dispatch_size(3u, min(atomicLoad(&counters[0]), params.caps.x));
        dispatch_size(6u, min(atomicLoad(&counters[1]), params.caps.y));
    }
}

@compute @workgroup_size(64)
fn scatter_imp(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = (wg.y * 65535u + wg.x) * 64u + li;
    if (i >= min(atomicLoad(&counters[0]), params.caps.x)) {
        return;
    }
    let e = parked_imp[i];
    let at = atomicLoad(&counters[seg_start(e.a.z)]) + e.a.w;
    if (at < params.caps.x) {
        let t = trees[e.a.x];
        out_imp[at] = Impostor(t.base_scale, vec4<f32>(t.rot.xyz, bitcast<f32>(e.b.x)), e.a.y, 0u, 0u, 0u);
    }
}

@compute @workgroup_size(64)
fn scatter_res(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let i = (wg.y * 65535u + wg.x) * 64u + li;
    if (i >= min(atomicLoad(&counters[1]), params.caps.y)) {
        return;
    }
    let e = parked_res[i];
    let at = atomicLoad(&counters[seg_start(IMP_SEGS + e.y)]) + e.z;
    if (at < params.caps.y) {
        let t = trees[e.x];
        out_res[at] = Tree(t.base_scale, vec4<f32>(t.rot.xyz, bitcast<f32>(e.w)));
    }
}
