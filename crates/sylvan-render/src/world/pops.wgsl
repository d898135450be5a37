// The pop audit (world/pops.rs, `sylvan bench --count-pops`): per pool slot, the presence the
// camera pass drew this frame — summed over the culls of every list request by `cull.wgsl`, in
// units of 1/65536 — against the last frame's. Counts the trees inside the view in both frames
// (their sphere wholly inside both camera frusta) that appeared, vanished or changed presence
// by more than the world's fades can move it in one frame (`step`). A slot holding another tree
// than last frame (its tile evicted, another inserted) is the old tree vanishing and the new
// one appearing.

struct PoolTree {
    base_scale: vec4<f32>,
    // x cos, y sin, z tint seed, w the species' bits
    rot: vec4<f32>,
}

struct Params {
    now_planes: array<vec4<f32>, 6>,
    prev_planes: array<vec4<f32>, 6>,
    // x slots, y 1 when the last frame is comparable (else the slots are only stored)
    info: vec4<u32>,
    // x the largest presence change the fades allow this frame
    step: vec4<f32>,
    // per species: xyz model-space centre of its bounds, w radius (plant units)
    species: array<vec4<f32>, 64>,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> pool: array<PoolTree>;
// This frame's drawn presence per slot (1/65536), cleared here for the next frame.
@group(0) @binding(2) var<storage, read_write> drawn: array<atomic<u32>>;
// Per slot: (centre, radius) and (presence, 0, 0, 0) of the tree drawn last frame.
@group(0) @binding(3) var<storage, read_write> prev: array<vec4<f32>>;
// appeared, vanished, jumped, the largest such change (1/65536)
@group(0) @binding(4) var<storage, read_write> counts: array<atomic<u32>>;

fn wholly_inside(planes: ptr<function, array<vec4<f32>, 6>>, s: vec4<f32>) -> bool {
    for (var k = 0u; k < 6u; k++) {
        let p = (*planes)[k];
        if (dot(p.xyz, s.xyz) + p.w < s.w) {
            return false;
        }
    }
    return true;
}

fn in_view(s: vec4<f32>) -> bool {
    var now = params.now_planes;
    var before = params.prev_planes;
    return wholly_inside(&now, s) && wholly_inside(&before, s);
}

fn count(k: u32, change: f32) {
    atomicAdd(&counts[k], 1u);
    atomicMax(&counts[3], u32(change * 65536.0));
}

@compute @workgroup_size(64)
fn audit(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let slot = (wg.y * 65535u + wg.x) * 64u + li;
    if (slot >= params.info.x) {
        return;
    }
    let q = atomicLoad(&drawn[slot]);
    atomicStore(&drawn[slot], 0u);
    let now = f32(q) / 65536.0;
    var sphere = vec4<f32>(0.0);
    if (q > 0u) {
        let t = pool[slot];
        let local = params.species[bitcast<u32>(t.rot.w)];
        let s = t.base_scale.w;
        let m = local.xyz * s;
        sphere = vec4<f32>(t.base_scale.xyz + vec3<f32>(t.rot.x * m.x + t.rot.y * m.z, m.y,
            -t.rot.y * m.x + t.rot.x * m.z), local.w * s);
    }
    let was = prev[2u * slot];
    let before = prev[2u * slot + 1u].x;
    let step = params.step.x;
    if (params.info.y == 1u) {
        if (q > 0u && before > 0.0 && all(was == sphere)) {
            let change = abs(now - before);
            if (change > step && in_view(sphere)) {
                count(2u, change);
            }
        } else {
            if (before > step && in_view(was)) {
                count(1u, before);
            }
            if (now > step && in_view(sphere)) {
                count(0u, now);
            }
        }
    }
    prev[2u * slot] = sphere;
    prev[2u * slot + 1u] = vec4<f32>(now, 0.0, 0.0, 0.0);
}
