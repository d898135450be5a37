// The GPU-driven cull (world/cull.rs): one invocation per pooled tree of a page a pass may see;
// each survivor is appended to its (pass, group) list — a group is a species, or every species
// for a technique that draws them all in one list (then the record's rot.z is species + tint).
// A sorted camera list (back to front, for blended impostors) is filled by a counting sort
// over distance buckets: the cull counts each bucket and parks the tree, `sort_scan` turns the
// counts into far-to-near starts, `sort_scatter` writes each tree at its place. Last, one
// invocation per indirect draw writes its arguments from its list's count.

struct PoolTree {
    base_scale: vec4<f32>,
    // x cos, y sin, z tint seed, w the species' bits (in the lists: presence)
    rot: vec4<f32>,
}

// A run of consecutive pool trees (a tile's pages, or a run of them): its first tree, its
// count, the passes that see it, and its first workgroup row (one row per PAGE trees).
struct Run {
    first: u32,
    count: u32,
    passes: u32,
    row: u32,
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

// A tree parked for the sort: pool index, bucket, place in the bucket, presence bits.
struct Parked {
    tree: u32,
    bucket: u32,
    slot: u32,
    presence: u32,
}

struct Params {
    // pass p's plane k at 6p + k: xyz inward normal, w offset
    planes: array<vec4<f32>, 30>,
    // xyz eye, w the camera pass's far distance
    eye_far: vec4<f32>,
    // x groups per pass, y runs, z draws, w 1 when groups are species (else one mixed group)
    info: vec4<u32>,
    // x: camera-pass presence falls from 1 at this distance to 0 at eye_far.w (the world's
    // tree distance); infinite for a world drawn whole. y 1: the pop audit is on (`audit`)
    fade: vec4<f32>,
    // x 1: the camera list is sorted back to front; y nearest bucketed distance;
    // z buckets per log2 of distance; w sorted list capacity
    sort: vec4<f32>,
    // the band of a level-of-detail chain this list serves, by distance from the eye to the
    // trunk base: presence rises over [x, y] and falls over [z, w] (x = y: a step at x)
    band: vec4<f32>,
    // per species: xyz model-space centre of its bounds, w radius (plant units)
    species: array<vec4<f32>, 64>,
    // The caster cull (frame.rs `CasterCull::gpu_rows`): cascade c's 5 planes at 6c..6c+4 and
    // its shell (x inner, y outer) at 6c+5; at 24 the sun (xyz, zero: no cull) and the reach.
    casters: array<vec4<f32>, 25>,
    // The occlusion cull (world/hiz.rs): the view-projection of the frame the depth pyramid
    // holds, and x 1: test on, y levels, zw that frame's size in pixels.
    hiz_view_proj: mat4x4<f32>,
    hiz_info: vec4<f32>,
    // level L's x offset in its texture at [L / 4][L % 4]
    hiz_offsets: array<vec4<u32>, 4>,
    // How this request's trees end into a forest field (technique/mod.rs `FieldEnd`):
    // x metres of distance per metre of height at which a tree is `handover_px` tall (0: no
    // pixel rule), y the field's start s_max (0: no field), z 1 when the technique fades its
    // own trees (presence stops at the tree's end), else presence falls over [0.8, 1] × it.
    field_end: vec4<f32>,
    // per species its model top at [s / 4][s % 4] (a tree's height is it × its scale)
    tops: array<vec4<f32>, 16>,
}

const PASSES: u32 = 5u;
// Trees per pool page (world/mod.rs `PAGE`): a workgroup row culls one page.
const PAGE: u32 = 256u;
const BUCKETS: u32 = 4096u;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> pool: array<PoolTree>;
@group(0) @binding(2) var<storage, read> runs: array<Run>;
@group(0) @binding(3) var<storage, read> lists: array<List>;
// [lists' counts | BUCKETS bucket counts | BUCKETS bucket starts | trees occluded]
@group(0) @binding(4) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> out_trees: array<PoolTree>;
@group(0) @binding(6) var<storage, read> draws: array<Draw>;
@group(0) @binding(7) var<storage, read_write> args: array<u32>;
@group(0) @binding(8) var<storage, read_write> parked: array<Parked>;
// The previous frame's depth pyramid: per texel the farthest depth (reversed Z) under it;
// even levels in the first texture, odd in the second, side by side (world/hiz.wgsl).
@group(0) @binding(9) var hiz_even: texture_2d<f32>;
@group(0) @binding(10) var hiz_odd: texture_2d<f32>;
// The pop audit (world/pops.rs): per pool slot, the camera presence drawn this frame (1/65536,
// summed over the requests' culls); a placeholder while it is off.
@group(0) @binding(11) var<storage, read_write> audit: array<atomic<u32>>;

fn hiz_load(level: u32, t: vec2<i32>) -> f32 {
    let at = t + vec2<i32>(i32(params.hiz_offsets[level / 4u][level % 4u]), 0);
    if ((level & 1u) == 0u) {
        return textureLoad(hiz_even, at, 0).r;
    }
    return textureLoad(hiz_odd, at, 0).r;
}

fn inside(pass_index: u32, c: vec3<f32>, r: f32) -> bool {
    for (var k = 0u; k < 6u; k++) {
        let p = params.planes[pass_index * 6u + k];
        if (dot(p.xyz, c) + p.w < -r) {
            return false;
        }
    }
    return true;
}

// Whether a caster in the sphere (c, r) may shade a receiver cascade `cascade` serves: its
// shadow segment c − t·sun, t in [−r, reach + 2r], clipped by the cascade's planes, must meet
// the cascade's shell of distances from the eye (the same formula as `CasterCull::keeps`).
fn caster_keeps(cascade: u32, c: vec3<f32>, r: f32) -> bool {
    let sun_reach = params.casters[6u * 4u];
    let s = sun_reach.xyz;
    if (dot(s, s) == 0.0) {
        return true;
    }
    var t0 = -r;
    var t1 = sun_reach.w + 2.0 * r;
    for (var k = 0u; k < 5u; k++) {
        let p = params.casters[6u * cascade + k];
        let a = dot(p.xyz, c) + p.w + r;
        let b = dot(p.xyz, s);
        if (b > 0.0) {
            t1 = min(t1, a / b);
        } else if (b < 0.0) {
            t0 = max(t0, a / b);
        } else if (a < 0.0) {
            return false;
        }
    }
    if (t0 > t1) {
        return false;
    }
    let shell = params.casters[6u * cascade + 5u];
    let d = c - params.eye_far.xyz;
    let nearest = clamp(dot(d, s), t0, t1);
    let min_distance = length(d - s * nearest);
    let max_distance = max(length(d - s * t0), length(d - s * t1));
    return min_distance <= shell.y + r && max_distance >= shell.x - r;
}

// Whether the box (c ± r) is hidden behind what the previous frame drew: its nearest depth
// (reversed Z: the largest) is farther than the farthest depth of the pyramid texels under its
// screen rectangle, read at the level where that rectangle spans at most 2×2 texels. A box
// reaching behind the previous eye or outside its view is not hidden.
fn occluded(c: vec3<f32>, r: f32) -> bool {
    if (params.hiz_info.x < 0.5) {
        return false;
    }
    var lo = vec2<f32>(1e30);
    var hi = vec2<f32>(-1e30);
    var nearest = 0.0;
    for (var k = 0u; k < 8u; k++) {
        let s = vec3<f32>(f32(k & 1u), f32((k >> 1u) & 1u), f32(k >> 2u)) * 2.0 - 1.0;
        let clip = params.hiz_view_proj * vec4<f32>(c + s * r, 1.0);
        if (clip.w <= 1e-3) {
            return false;
        }
        let ndc = clip.xyz / clip.w;
        lo = min(lo, ndc.xy);
        hi = max(hi, ndc.xy);
        nearest = max(nearest, ndc.z);
    }
    if (any(lo < vec2<f32>(-1.0)) || any(hi > vec2<f32>(1.0)) || nearest >= 1.0) {
        return false;
    }
    let size = params.hiz_info.zw;
    // Pixels (y down) of the rectangle's corners.
    let p0 = vec2<f32>(lo.x * 0.5 + 0.5, 0.5 - hi.y * 0.5) * size;
    let p1 = vec2<f32>(hi.x * 0.5 + 0.5, 0.5 - lo.y * 0.5) * size;
    let extent = max(max(p1.x - p0.x, p1.y - p0.y), 1.0);
    // A texel of level L covers 2^(L+1) pixels a side.
    let levels = u32(params.hiz_info.y);
    let level = min(u32(max(ceil(log2(extent)) - 1.0, 0.0)), levels - 1u);
    let first = (vec2<u32>(size) + 1u) / 2u;
    let dims = vec2<i32>(max(first >> vec2<u32>(level), vec2<u32>(1u))) - 1;
    let texel = f32(2u << level);
    let t0 = min(vec2<i32>(floor(p0 / texel)), dims);
    let t1 = min(vec2<i32>(floor(p1 / texel)), dims);
    var farthest = 1.0;
    for (var y = t0.y; y <= t1.y; y++) {
        for (var x = t0.x; x <= t1.x; x++) {
            farthest = min(farthest, hiz_load(level, vec2<i32>(x, y)));
        }
    }
    return nearest < farthest;
}

// smoothstep from e0 to e1; with e1 <= e0 a step at e0 (as the CPU's `common::smoothstep`).
fn ramp(e0: f32, e1: f32, x: f32) -> f32 {
    if (e1 <= e0) {
        return select(0.0, 1.0, x >= e0);
    }
    return smoothstep(e0, e1, x);
}

// BN12 §7 and §4's 3-px rule (`FieldEnd::presence`): a tree `height` metres tall at `d` ends at
// min(s_max, height × k), fading over [0.8, 1] of it (or stopping there).
fn field_end_presence(height: f32, d: f32) -> f32 {
    var e = params.field_end.y;
    if (params.field_end.x > 0.0) {
        e = min(e, height * params.field_end.x);
    }
    if (params.field_end.z > 0.5) {
        return select(1.0, 0.0, d >= e);
    }
    return 1.0 - ramp(0.8 * e, e, d);
}

fn list_count() -> u32 {
    return PASSES * params.info.x;
}

// The record a list holds for pool tree `t` with `presence`.
fn listed(t: PoolTree, presence: f32) -> PoolTree {
    let species = bitcast<u32>(t.rot.w);
    var z = t.rot.z;
    if (params.info.w == 0u) {
        z = f32(species) + t.rot.z;
    }
    return PoolTree(t.base_scale, vec4<f32>(t.rot.xy, z, presence));
}

@compute @workgroup_size(64)
fn cull(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    // The run holding this row: the last whose first row is at or before it.
    var lo = 0u;
    var hi = params.info.y;
    while (hi - lo > 1u) {
        let mid = (lo + hi) / 2u;
        if (runs[mid].row <= wg.y) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let page = runs[lo];
    let i = (wg.y - page.row) * PAGE + wg.x * 64u + li;
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
    let centre_distance = distance(c, params.eye_far.xyz);
    let near = centre_distance - r;
    var presence = 1.0;
    if (near > params.fade.x) {
        presence = 1.0 - smoothstep(params.fade.x, params.eye_far.w, near);
    }
    let base_distance = distance(t.base_scale.xyz, params.eye_far.xyz);
    presence *= ramp(params.band.x, params.band.y, base_distance)
        * (1.0 - ramp(params.band.z, params.band.w, base_distance));
    if (presence > 0.0 && params.field_end.y > 0.0) {
        presence *= field_end_presence(params.tops[species / 4u][species % 4u] * s, base_distance);
    }
    if (presence <= 0.0) {
        return;
    }
    let group = select(0u, species, params.info.w == 1u);
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
        if (p == 0u && params.fade.y > 0.5) {
            // Before the occlusion test: a hidden tree is not a vanished one.
            atomicAdd(&audit[page.first + i], u32(presence * 65536.0 + 0.5));
        }
        if (p == 0u && occluded(c, r)) {
            atomicAdd(&counters[list_count() + 2u * BUCKETS], 1u);
            continue;
        }
        if (p > 0u && !caster_keeps(p - 1u, c, r)) {
            continue;
        }
        let list = p * params.info.x + group;
        let slot = atomicAdd(&counters[list], 1u);
        if (p == 0u && params.sort.x > 0.5) {
            // Far buckets get the high numbers; scan lays them out first.
            let level = log2(max(centre_distance, params.sort.y) / params.sort.y) * params.sort.z;
            let bucket = min(u32(level), BUCKETS - 1u);
            let in_bucket = atomicAdd(&counters[list_count() + bucket], 1u);
            if (slot < lists[list].capacity) {
                parked[slot] = Parked(page.first + i, bucket, in_bucket, bitcast<u32>(presence));
            }
            continue;
        }
        if (slot < lists[list].capacity) {
            // Shadow casters fade with the camera's trees, so no shadow outlives its tree.
            out_trees[lists[list].offset + slot] = listed(t, presence);
        }
    }
}

// One workgroup: bucket starts, farthest bucket first (exclusive sums from the top).
var<workgroup> partial: array<u32, 256>;

@compute @workgroup_size(256)
fn sort_scan(@builtin(local_invocation_index) li: u32) {
    let per = BUCKETS / 256u;
    let base = list_count();
    // Thread li owns buckets from the top: BUCKETS-1-li*per down to BUCKETS-(li+1)*per.
    var sum = 0u;
    for (var k = 0u; k < per; k++) {
        sum += atomicLoad(&counters[base + BUCKETS - 1u - (li * per + k)]);
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
    for (var k = 0u; k < per; k++) {
        let b = BUCKETS - 1u - (li * per + k);
        atomicStore(&counters[base + BUCKETS + b], run);
        run += atomicLoad(&counters[base + b]);
    }
}

@compute @workgroup_size(64)
fn sort_scatter(@builtin(global_invocation_id) gid: vec3<u32>) {
    let list = 0u; // the camera pass's one mixed list
    let n = min(atomicLoad(&counters[list]), lists[list].capacity);
    let i = gid.y * 65535u * 64u + gid.x;
    if (i >= n) {
        return;
    }
    let e = parked[i];
    let at = atomicLoad(&counters[list_count() + BUCKETS + e.bucket]) + e.slot;
    if (at < lists[list].capacity) {
        out_trees[lists[list].offset + at] = listed(pool[e.tree], bitcast<f32>(e.presence));
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
    // (a draw with index_count 0 is a non-indexed draw of `first_index` vertices: same layout
    // as DrawIndirect's vertex count, instance count, first vertex, first instance)
    if (draw.index_count == 0u) {
        args[d * 5u + 0u] = draw.first_index;
        args[d * 5u + 1u] = n;
        args[d * 5u + 2u] = 0u;
        args[d * 5u + 3u] = 0u;
        args[d * 5u + 4u] = 0u;
        return;
    }
    args[d * 5u + 0u] = draw.index_count;
    args[d * 5u + 1u] = n;
    args[d * 5u + 2u] = draw.first_index;
    args[d * 5u + 3u] = 0u;
    args[d * 5u + 4u] = 0u;
}
