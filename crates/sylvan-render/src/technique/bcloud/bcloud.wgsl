// Technique `billboard-cloud` (GPSS07): planes whose pixels walk a list of the leaves
// overlapping them (§5, fig. 7), with the shader level of detail of §5.1 and the reference's
// leaf lighting (§5.2). Bind groups 1 and 2: `bindings.wgsl`.

struct CloudIn {
    @location(0) position: vec3<f32>,
    @location(1) st: vec2<f32>,
    @location(2) plane: u32,
};

struct CloudOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) world: vec3<f32>,
    // Plane coordinates (plant units).
    @location(1) st: vec2<f32>,
    // From the point towards the eye (model space, plant units).
    @location(2) to_eye: vec3<f32>,
    @location(3) @interpolate(flat) plane: u32,
    @location(4) @interpolate(flat) rot: vec4<f32>,
    // x: presence; y: 1 where this cloud is the farther side of its cross-fade.
    @location(5) @interpolate(flat) keep: vec2<f32>,
};

// A plane with what the upload adds (`GpuPlane` in `draw.rs`): x first record of its
// species' cloud, y its low-resolution tile pair, z its species' first list entry, w the
// steepest ray its lists hold (f32 bits, `Cloud::parallax`).
struct PlaneExtra {
    extra: vec4<u32>,
};
@group(1) @binding(10) var<storage, read> plane_extra: array<PlaneExtra>;

fn cloud_level(plane: u32) -> u32 {
    if (plane < cloud.level_first.y) {
        return 0u;
    }
    if (plane < cloud.level_first.z) {
        return 1u;
    }
    return 2u;
}

fn cloud_vertex(v: CloudIn, inst: TreeInstance, to_eye_model: vec3<f32>) -> CloudOut {
    let world = instance_to_world(v.position, inst.base_scale, inst.rot);
    var out: CloudOut;
    out.pos = frame.view_proj * vec4<f32>(world, 1.0);
    out.world = world;
    out.st = v.st;
    out.to_eye = to_eye_model;
    out.plane = v.plane;
    out.rot = inst.rot;
    let w = cloud.windows[cloud_level(v.plane)];
    let d = distance(frame.camera.xyz, inst.base_scale.xyz);
    out.keep = vec2<f32>(inst.rot.w, select(0.0, 1.0, d < 0.5 * (w.y + w.z)));
    return out;
}

@vertex
fn vs_cloud(v: CloudIn, inst: TreeInstance) -> CloudOut {
    let eye = instance_to_model(frame.camera.xyz, inst.base_scale, inst.rot);
    return cloud_vertex(v, inst, eye - v.position);
}

@vertex
fn vs_cloud_shadow(v: CloudIn, inst: TreeInstance) -> CloudOut {
    return cloud_vertex(v, inst, instance_dir_to_model(frame.sun_dir.xyz, inst.rot));
}

fn unpack_oct(v: u32) -> vec3<f32> {
    let p = unpack2x16snorm(v);
    let z = 1.0 - abs(p.x) - abs(p.y);
    let t = max(-z, 0.0);
    let q = vec2<f32>(p.x - sign(p.x) * t, p.y - sign(p.y) * t);
    return normalize(vec3<f32>(q, z));
}

// During a cross-fade a leaf is kept when its hash is below the presence on the nearer side
// of the fade and above one minus it on the farther side, so the two sides draw complementary
// leaves (`geometry` keeps hash < presence: it is always the nearer side).
fn leaf_kept(leaf: u32, keep: vec2<f32>, seed: f32) -> bool {
    let l = f32(leaf);
    let h = hash13(vec3<f32>(l, l * 0.37 + 11.0, seed * 97.0));
    if (keep.y > 0.5) {
        return h >= 1.0 - keep.x;
    }
    return h < keep.x;
}

// What a pixel of a plane shows.
struct CloudHit {
    // 0: nothing; 1: a leaf; 2: the low-resolution image.
    kind: u32,
    // Normal facing the viewer (model space).
    n: vec3<f32>,
    albedo: vec3<f32>,
    ao: f32,
};

fn atlas_uv(a: vec4<u32>, tile: u32, f: vec2<f32>, inv_tile: f32) -> vec3<f32> {
    let k = tile % a.y;
    let cell = vec2<f32>(f32(k % a.x), f32(k / a.x));
    let g = clamp(f, vec2<f32>(0.5 * inv_tile), vec2<f32>(1.0 - 0.5 * inv_tile));
    return vec3<f32>((cell + g) / vec2<f32>(f32(a.x), f32(a.z)), f32(tile / a.y));
}

// The low-resolution image of `plane` from side `back` at rectangle point `f` (colour,
// normal + occlusion).
fn lowres(plane: u32, f: vec2<f32>, df: vec2<f32>, back: bool) -> array<vec4<f32>, 2> {
    let tile = plane_extra[plane].extra.y * 2u + select(0u, 1u, back);
    if (cloud_level(plane) == 0u) {
        let a = atlas_uv(cloud.atlas_near, tile, f, cloud.draw.z);
        let lod = log2(max(max(df.x, df.y) / cloud.draw.z, 1e-6));
        return array<vec4<f32>, 2>(
            textureSampleLevel(near_color, atlas_sampler, a.xy, i32(a.z), lod),
            textureSampleLevel(near_normal, atlas_sampler, a.xy, i32(a.z), lod),
        );
    }
    let a = atlas_uv(cloud.atlas_far, tile, f, cloud.draw.w);
    let lod = log2(max(max(df.x, df.y) / cloud.draw.w, 1e-6));
    return array<vec4<f32>, 2>(
        textureSampleLevel(far_color, atlas_sampler, a.xy, i32(a.z), lod),
        textureSampleLevel(far_normal, atlas_sampler, a.xy, i32(a.z), lod),
    );
}

// The hashed alpha test of low-resolution texels (stable on the plane: 4 × 4 thresholds per
// texel, per plane and tree).
fn lowres_kept(alpha: f32, in: CloudOut, f: vec2<f32>) -> bool {
    let tile = select(1.0 / cloud.draw.w, 1.0 / cloud.draw.z, cloud_level(in.plane) == 0u);
    let q = floor(f * tile * 4.0);
    let h = hash13(vec3<f32>(q.x + 0.5, q.y + f32(in.plane) * 0.61, in.rot.z * 131.0 + 7.0));
    return presence_alpha(alpha, in.keep.x) > h;
}

// The ray a plane pixel walks with (`layers::parallax_ray`): towards the eye, bent where it
// is steeper than `parallax` to that slope.
fn parallax_ray(to_eye: vec3<f32>, parallax: f32) -> vec3<f32> {
    let side = length(to_eye.xy);
    let limit = parallax * abs(to_eye.z);
    if (side > limit) {
        return vec3<f32>(to_eye.xy * (limit / side), to_eye.z);
    }
    return to_eye;
}

// GPSS07 §5: the cell's list walked from the side seen until an opaque, kept leaf texel, at
// most `entries` of them (§5.1), else the low-resolution image; `shade` also fetches the leaf's
// colour and normal.
fn evaluate(in: CloudOut, shade: bool, layered: bool) -> CloudHit {
    let p = planes[in.plane];
    let x = plane_extra[in.plane].extra;
    let dst_dx = dpdx(in.st);
    let dst_dy = dpdy(in.st);
    let size = vec2<f32>(p.n.w, bitcast<f32>(p.grid.w));
    let f = (in.st - vec2<f32>(p.u.w, p.v.w)) / size;
    let df = vec2<f32>(length(dst_dx / size), length(dst_dy / size));
    // Towards the eye in plane space, and the ray the leaves are met with.
    let eye = vec3<f32>(dot(in.to_eye, p.u.xyz), dot(in.to_eye, p.v.xyz), dot(in.to_eye, p.n.xyz));
    let ray = parallax_ray(eye, bitcast<f32>(x.w));
    let back = eye.z < 0.0;
    var hit: CloudHit;
    hit.kind = 0u;
    var len = 0u;
    var start = 0u;
    var entries = 0u;
    if (layered) {
        let cell_m = p.origin_cell.w;
        let c = clamp(vec2<i32>(floor((in.st - vec2<f32>(p.u.w, p.v.w)) / cell_m)), vec2<i32>(0), vec2<i32>(p.grid.xy) - 1);
        let packed = cells[p.grid.z + u32(c.y) * p.grid.x + u32(c.x)];
        len = packed & 255u;
        start = (packed >> 8u) + x.z;
        // The projected diagonal of a hash cell, in pixels.
        let per_px = max(length(dst_dx), length(dst_dy));
        let diag = 1.41421356 * cell_m / max(per_px, 1e-9);
        entries = min(len, u32(floor(cloud.draw.x * diag)));
        let tex = vec2<f32>(textureDimensions(leaf_texture));
        for (var i = 0u; i < entries; i = i + 1u) {
            let e = lists[start + select(i, len - 1u - i, back)];
            let r = records[x.x + e];
            // The ray through this pixel met with the leaf's plane (deviation: GPSS07 draws
            // the leaf image where it lies projected on the billboard).
            let m = cross(r.to_u, r.to_v);
            let me = dot(m, ray);
            if (abs(me) <= 1e-6 * length(m) * length(ray)) {
                continue;
            }
            let w = vec3<f32>(in.st, 0.0) - r.origin;
            let hit3 = w - ray * (dot(m, w) / me);
            let uv = vec2<f32>(dot(r.to_u, hit3), dot(r.to_v, hit3));
            let lo = unpack2x16unorm(r.uv_min);
            let hi = unpack2x16unorm(r.uv_max);
            if (any(uv < lo) || any(uv > hi)) {
                continue;
            }
            // d uv / d st along the ray: the leaf's texels per plane offset.
            let bray = vec2<f32>(dot(r.to_u, ray), dot(r.to_v, ray));
            let jm = mat2x2<f32>(
                vec2<f32>(r.to_u.x, r.to_v.x) - bray * (m.x / me),
                vec2<f32>(r.to_u.y, r.to_v.y) - bray * (m.y / me),
            );
            // The footprint's minor axis (as anisotropic filtering would): a leaf oblique to
            // the view is squeezed, and the major axis would blur its cut-out away.
            let lod = log2(max(min(length(jm * dst_dx * tex), length(jm * dst_dy * tex)), 1e-6));
            let a = textureSampleLevel(leaf_texture, leaf_sampler, uv, lod).a;
            if (a < 0.5 || !leaf_kept(e, in.keep, in.rot.z)) {
                continue;
            }
            hit.kind = 1u;
            if (shade) {
                let n = unpack_oct(r.normal);
                let t = unpack_oct(r.tangent);
                let flip = select(1.0, -1.0, ((r.color >> 24u) & 1u) == 1u);
                let b = cross(n, t) * flip;
                let m3 = textureSampleLevel(leaf_normal_map, leaf_sampler, uv, lod).rgb * 2.0 - vec3<f32>(1.0);
                let bent = normalize(t * m3.x + b * m3.y + n * m3.z);
                let front = dot(n, in.to_eye) >= 0.0;
                var rgb = textureSampleLevel(leaf_texture, leaf_sampler, uv, lod).rgb;
                if (!front) {
                    rgb = textureSampleLevel(leaf_back, leaf_sampler, uv, lod).rgb;
                }
                let col = unpack4x8unorm(r.color).rgb;
                hit.albedo = rgb * col;
                hit.n = select(-bent, bent, front);
                let q = clamp((uv - lo) / max(hi - lo, vec2<f32>(1e-6)), vec2<f32>(0.0), vec2<f32>(1.0));
                let ao = unpack4x8unorm(r.ao);
                hit.ao = mix(mix(ao.x, ao.y, q.x), mix(ao.z, ao.w, q.x), q.y);
            }
            return hit;
        }
        if (entries >= len) {
            return hit;
        }
    }
    // The entries ran out (or this cloud has only its low-resolution images).
    let s = lowres(in.plane, f, df, back);
    if (s[0].a <= 0.0 || !lowres_kept(s[0].a, in, f)) {
        return hit;
    }
    hit.kind = 2u;
    hit.albedo = s[0].rgb / s[0].a;
    hit.n = normalize(s[1].xyz * 2.0 - vec3<f32>(1.0));
    hit.ao = s[1].w;
    return hit;
}

// `geometry`'s leaf lighting (front Lambert, back transmission, sky × occlusion, shadows, fog).
fn cloud_light(in: CloudOut, hit: CloudHit) -> vec4<f32> {
    let n = instance_dir_to_world(hit.n, in.rot);
    let l = frame.sun_dir.xyz;
    let ndl = dot(n, l);
    let vis = sun_visibility(in.world, vec3<f32>(0.0));
    let tint = 0.85 + 0.3 * in.rot.z;
    let albedo = hit.albedo * vec3<f32>(tint, mix(tint, 1.0, 0.5), 1.0);
    let transmitted = albedo * vec3<f32>(1.1, 1.25, 0.55) * cloud.draw.y * max(-ndl, 0.0);
    let direct = frame.sun_color.rgb * (albedo * max(ndl, 0.0) + transmitted) * vis;
    let ambient = albedo * sky_light(n) * hit.ao;
    let c = apply_fog(direct + ambient, in.world);
    return vec4<f32>(debug_tint_lod(c, in.world, TECHNIQUE_BILLBOARD_CLOUD, cloud_level(in.plane)), 1.0);
}

@fragment
fn fs_cloud(in: CloudOut) -> @location(0) vec4<f32> {
    let hit = evaluate(in, true, true);
    if (hit.kind == 0u) {
        discard;
    }
    return cloud_light(in, hit);
}

@fragment
fn fs_cloud_lowres(in: CloudOut) -> @location(0) vec4<f32> {
    let hit = evaluate(in, true, false);
    if (hit.kind == 0u) {
        discard;
    }
    return cloud_light(in, hit);
}

@fragment
fn fs_cloud_shadow(in: CloudOut) -> @location(0) vec4<f32> {
    if (evaluate(in, false, true).kind == 0u) {
        discard;
    }
    return opaque_caster();
}

@fragment
fn fs_cloud_lowres_shadow(in: CloudOut) -> @location(0) vec4<f32> {
    if (evaluate(in, false, false).kind == 0u) {
        discard;
    }
    return opaque_caster();
}
