// Technique `billboard-cloud` (GPSS07): planes whose pixels walk a list of the leaves
// overlapping them (§5, fig. 7), with the shader level of detail of §5.1 and the reference's
// leaf lighting (§5.2). Bind groups 1 and 2: `bindings.wgsl`.

// A corner of the box drawn for one block of a plane's cells (its back faces are drawn).
struct CloudIn {
    // Plane space: s, t and the height above the plane.
    @location(0) pst: vec3<f32>,
    @location(1) plane: u32,
    // The block's box (plane space): lowest and highest corner.
    @location(2) block_lo: vec3<f32>,
    @location(3) block_hi: vec3<f32>,
};

// A box corner in model space.
fn cloud_position(v: CloudIn) -> vec3<f32> {
    let p = planes[v.plane];
    return p.origin_cell.xyz + p.u.xyz * v.pst.x + p.v.xyz * v.pst.y + p.n.xyz * v.pst.z;
}

struct CloudOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) world: vec3<f32>,
    // Plane space (plant units).
    @location(1) pst: vec3<f32>,
    // From the point towards the eye (model space, plant units).
    @location(2) to_eye: vec3<f32>,
    @location(3) @interpolate(flat) plane: u32,
    @location(4) @interpolate(flat) rot: vec4<f32>,
    // x: presence; y: 1 where this cloud is the farther side of its cross-fade; z: the
    // instance's scale (plant units to metres).
    @location(5) @interpolate(flat) keep: vec3<f32>,
    @location(6) @interpolate(flat) block_lo: vec3<f32>,
    @location(7) @interpolate(flat) block_hi: vec3<f32>,
};

// A plane with what the upload adds (`GpuPlane` in `draw.rs`): x first record of its
// species' cloud, y its low-resolution tile pair, z its species' first list entry, w unused.
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
    let world = instance_to_world(cloud_position(v), inst.base_scale, inst.rot);
    var out: CloudOut;
    out.pos = frame.view_proj * vec4<f32>(world, 1.0);
    out.world = world;
    out.pst = v.pst;
    out.block_lo = v.block_lo;
    out.block_hi = v.block_hi;
    out.to_eye = to_eye_model;
    out.plane = v.plane;
    out.rot = inst.rot;
    let w = cloud.windows[cloud_level(v.plane)];
    let d = distance(frame.camera.xyz, inst.base_scale.xyz);
    out.keep = vec3<f32>(inst.rot.w, select(0.0, 1.0, d < 0.5 * (w.y + w.z)), inst.base_scale.w);
    return out;
}

@vertex
fn vs_cloud(v: CloudIn, inst: TreeInstance) -> CloudOut {
    let eye = instance_to_model(frame.camera.xyz, inst.base_scale, inst.rot);
    return cloud_vertex(v, inst, eye - cloud_position(v));
}

@vertex
fn vs_cloud_shadow(v: CloudIn, inst: TreeInstance) -> CloudOut {
    // The light's eye is far away along the sun's direction.
    return cloud_vertex(v, inst, instance_dir_to_model(frame.sun_dir.xyz, inst.rot) * SUN_EYE);
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
fn leaf_kept(leaf: u32, keep: vec3<f32>, seed: f32) -> bool {
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
    // From the drawn box point to the point seen (plane space).
    offset: vec3<f32>,
    // The leaf's face normal (model space; leaves only) and the pixel's footprint across the
    // ray (plant units), for the shadow casters' slope-scaled offset.
    face: vec3<f32>,
    footprint: f32,
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

// How far the shadow passes put the light's eye (plant units; `vs_cloud_shadow`).
const SUN_EYE: f32 = 1.0e6;
// Most hash cells one ray walks through a slab (`layers::MAX_CELLS`).
const MAX_CELLS: u32 = 64u;

// Where the ray `o + λ d` meets the box [lo, hi]: (λ in, λ out); in > out where it misses.
fn ray_box(o: vec3<f32>, d: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>) -> vec2<f32> {
    let inv = 1.0 / select(d, vec3<f32>(1e-20), abs(d) < vec3<f32>(1e-20));
    let a = (lo - o) * inv;
    let b = (hi - o) * inv;
    let near = min(a, b);
    let far = max(a, b);
    return vec2<f32>(max(max(near.x, near.y), near.z), min(min(far.x, far.y), far.z));
}

// GPSS07 §5 through a slab (`layers::walk`): the pixel's ray followed through the drawn
// block's box cell by cell of the hash grid, nearest first; in each cell the nearest opaque,
// kept leaf of its list where the ray meets it inside the cell — at most `entries` list entries
// in all (§5.1), else the low-resolution image where the ray crosses the plane; `shade` also
// fetches the leaf's colour and normal.
fn evaluate(in: CloudOut, shade: bool, layered: bool) -> CloudHit {
    let p = planes[in.plane];
    let x = plane_extra[in.plane].extra;
    // Plane space: towards the eye, its distance, and the ray away from it.
    let te = vec3<f32>(dot(in.to_eye, p.u.xyz), dot(in.to_eye, p.v.xyz), dot(in.to_eye, p.n.xyz));
    let eye_dist = length(te);
    let d = -te / max(eye_dist, 1e-20);
    // The pixel's footprint across the ray (plant units per pixel, x and y).
    let gx0 = dpdx(in.pst);
    let gy0 = dpdy(in.pst);
    let gx = gx0 - d * dot(gx0, d);
    let gy = gy0 - d * dot(gy0, d);
    let rmin = vec2<f32>(p.u.w, p.v.w);
    let size = vec2<f32>(p.n.w, bitcast<f32>(p.grid.w));
    // The ray enters the block's box at `q` (or starts at the eye) and leaves it `span` later.
    let box = ray_box(in.pst, d, in.block_lo, in.block_hi);
    let back_in = max(box.x, -eye_dist);
    let q = in.pst + d * back_in;
    let span = max(box.y - back_in, 0.0);
    let back = te.z < 0.0;
    var hit: CloudHit;
    hit.kind = 0u;
    hit.offset = vec3<f32>(0.0);
    hit.face = p.n.xyz;
    hit.footprint = max(length(gx), length(gy));
    var exhausted = false;
    if (layered) {
        let cm = p.origin_cell.w;
        let n = vec2<i32>(p.grid.xy);
        // The projected diagonal of a hash cell, in pixels.
        let per_px = max(length(gx), length(gy));
        let diag = 1.41421356 * cm / max(per_px, 1e-9);
        var budget = u32(floor(cloud.draw.x * diag));
        let tex = vec2<f32>(textureDimensions(leaf_texture));
        var c = clamp(vec2<i32>(floor((q.xy - rmin) / cm)), vec2<i32>(0), n - 1);
        let step = select(vec2<i32>(-1), vec2<i32>(1), d.xy >= vec2<f32>(0.0));
        let inv = 1.0 / select(d.xy, vec2<f32>(1e-20), abs(d.xy) < vec2<f32>(1e-20));
        var enter = 0.0;
        exhausted = true;
        for (var k = 0u; k < MAX_CELLS; k = k + 1u) {
            let edge = rmin + vec2<f32>(c + max(step, vec2<i32>(0))) * cm;
            let tn = (edge - q.xy) * inv;
            let exit = min(min(tn.x, tn.y), span);
            let packed = cells[p.grid.z + u32(c.y) * p.grid.x + u32(c.x)];
            let len = packed & 255u;
            let start = (packed >> 8u) + x.z;
            if (len > budget) {
                break;
            }
            budget = budget - len;
            let eps = 1e-4 * cm;
            var best = 3.0e38;
            for (var i = 0u; i < len; i = i + 1u) {
                let e = lists[start + select(i, len - 1u - i, back)];
                let r = records[x.x + e];
                // The ray met with the leaf's plane (deviation: GPSS07 draws the leaf image
                // where it lies projected on the billboard).
                let m = cross(r.to_u, r.to_v);
                let md = dot(m, d);
                if (abs(md) <= 1e-6 * length(m)) {
                    continue;
                }
                let w = q - r.origin;
                let lambda = -dot(m, w) / md;
                if (lambda < enter - eps || lambda > exit + eps || lambda >= best) {
                    continue;
                }
                let h3 = w + d * lambda;
                let uv = vec2<f32>(dot(r.to_u, h3), dot(r.to_v, h3));
                let lo = unpack2x16unorm(r.uv_min);
                let hi = unpack2x16unorm(r.uv_max);
                if (any(uv < lo) || any(uv > hi)) {
                    continue;
                }
                // d uv / d (ray offset across it): the leaf's texels per pixel.
                let tu = r.to_u - m * (dot(r.to_u, d) / md);
                let tv = r.to_v - m * (dot(r.to_v, d) / md);
                // The footprint's minor axis (as anisotropic filtering would): a leaf oblique
                // to the view is squeezed, and the major axis would blur its cut-out away.
                let fx = vec2<f32>(dot(tu, gx), dot(tv, gx)) * tex;
                let fy = vec2<f32>(dot(tu, gy), dot(tv, gy)) * tex;
                // Shadow casters test the full-resolution alpha, as `geometry`'s do.
                let lod = select(0.0, log2(max(min(length(fx), length(fy)), 1e-6)), shade);
                let a = textureSampleLevel(leaf_texture, leaf_sampler, uv, lod).a;
                if (a < 0.5 || !leaf_kept(e, in.keep, in.rot.z)) {
                    continue;
                }
                best = lambda;
                hit.kind = 1u;
                hit.face = unpack_oct(r.normal);
                hit.offset = q + d * lambda - in.pst;
                if (shade) {
                    let qa = clamp((uv - lo) / max(hi - lo, vec2<f32>(1e-6)), vec2<f32>(0.0), vec2<f32>(1.0));
                    // The blade's normal there (`LeafRecord::normal_at`).
                    let cn = r.corner_normals;
                    let n = normalize(mix(
                        mix(unpack_oct(cn.x), unpack_oct(cn.y), qa.x),
                        mix(unpack_oct(cn.z), unpack_oct(cn.w), qa.x),
                        qa.y,
                    ));
                    let t0 = unpack_oct(r.tangent);
                    let t = normalize(t0 - n * dot(t0, n));
                    let flip = select(1.0, -1.0, ((r.color >> 24u) & 1u) == 1u);
                    let b = cross(n, t) * flip;
                    let m3 = textureSampleLevel(leaf_normal_map, leaf_sampler, uv, lod).rgb * 2.0 - vec3<f32>(1.0);
                    let bent = normalize(t * m3.x + b * m3.y + n * m3.z);
                    let front = dot(unpack_oct(r.normal), in.to_eye) >= 0.0;
                    var rgb = textureSampleLevel(leaf_texture, leaf_sampler, uv, lod).rgb;
                    if (!front) {
                        rgb = textureSampleLevel(leaf_back, leaf_sampler, uv, lod).rgb;
                    }
                    let col = unpack4x8unorm(r.color).rgb;
                    hit.albedo = rgb * col;
                    hit.n = select(-bent, bent, front);
                    let ao = unpack4x8unorm(r.ao);
                    hit.ao = mix(mix(ao.x, ao.y, qa.x), mix(ao.z, ao.w, qa.x), qa.y);
                }
            }
            if (hit.kind != 0u) {
                return hit;
            }
            if (exit >= span) {
                exhausted = false;
                break;
            }
            if (tn.x <= tn.y) {
                c.x = c.x + step.x;
            } else {
                c.y = c.y + step.y;
            }
            if (any(c < vec2<i32>(0)) || any(c >= n)) {
                exhausted = false;
                break;
            }
            enter = exit;
        }
        if (!exhausted) {
            return hit;
        }
    }
    // The entries ran out (or this cloud has only its low-resolution images): the image where
    // the ray crosses the plane.
    var cross_l = 0.0;
    if (abs(d.z) > 1e-6) {
        cross_l = clamp(-q.z / d.z, 0.0, span);
    }
    let st = q.xy + d.xy * cross_l;
    let f = (st - rmin) / size;
    if (any(f < vec2<f32>(0.0)) || any(f > vec2<f32>(1.0))) {
        return hit;
    }
    let df = vec2<f32>(length(gx.xy / size), length(gy.xy / size));
    let s = lowres(in.plane, f, df, back);
    if (s[0].a <= 0.0 || !lowres_kept(s[0].a, in, f)) {
        return hit;
    }
    hit.kind = 2u;
    hit.offset = q + d * cross_l - in.pst;
    hit.albedo = s[0].rgb / s[0].a;
    hit.n = normalize(s[1].xyz * 2.0 - vec3<f32>(1.0));
    hit.ao = s[1].w;
    return hit;
}

// The world point a pixel shows (`offset` from the drawn box point, plane space).
fn hit_world(in: CloudOut, hit: CloudHit) -> vec3<f32> {
    let p = planes[in.plane];
    let o = p.u.xyz * hit.offset.x + p.v.xyz * hit.offset.y + p.n.xyz * hit.offset.z;
    return in.world + instance_dir_to_world(o * in.keep.z, in.rot);
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

// A box pixel: its colour and the depth of the point it shows (the box's own depth is not the
// leaf's, so leaves of crossing planes and the wood occlude each other where they lie).
struct CloudFragment {
    @location(0) color: vec4<f32>,
    @builtin(frag_depth) depth: f32,
};

@fragment
fn fs_cloud(in: CloudOut) -> CloudFragment {
    let hit = evaluate(in, true, true);
    if (hit.kind == 0u) {
        discard;
    }
    var lit = in;
    lit.world = hit_world(in, hit);
    var out: CloudFragment;
    out.color = cloud_light(lit, hit);
    out.depth = clip_depth(lit.world);
    return out;
}

// The far cloud's boxes are flat: the drawn point is the point shown.
@fragment
fn fs_cloud_lowres(in: CloudOut) -> @location(0) vec4<f32> {
    let hit = evaluate(in, true, false);
    if (hit.kind == 0u) {
        discard;
    }
    return cloud_light(in, hit);
}

// How far a shadow caster's depth is pushed away from the sun, in shadow-map texels at the
// leaf's slope to the sun (the pipeline's slope-scaled depth bias, which `geometry`'s leaves
// get, does not apply to a written depth): `SHADOW_PUSH` × (1 + slope), slope ≤ 16. Measured on
// the chestnut (ꟻLIP at 800 / 400 px): 0.5 → 0.092 / 0.085, 1 → 0.090 / 0.083, 2 → 0.093 /
// 0.084, 3 → 0.096 / 0.087, 6 → 0.104 / 0.093; a fixed 3 cm 0.098 / 0.090.
const SHADOW_PUSH: f32 = 1.0;

@fragment
fn fs_cloud_shadow(in: CloudOut) -> ShadowFragment {
    let hit = evaluate(in, false, true);
    if (hit.kind == 0u) {
        discard;
    }
    let c = abs(dot(instance_dir_to_world(hit.face, in.rot), frame.sun_dir.xyz));
    let slope = min(sqrt(max(1.0 - c * c, 0.0)) / max(c, 1e-3), 16.0);
    let push = SHADOW_PUSH * (1.0 + slope) * hit.footprint * in.keep.z;
    return ShadowFragment(opaque_caster(), clip_depth(hit_world(in, hit) - frame.sun_dir.xyz * push));
}

@fragment
fn fs_cloud_lowres_shadow(in: CloudOut) -> @location(0) vec4<f32> {
    if (evaluate(in, false, false).kind == 0u) {
        discard;
    }
    return opaque_caster();
}
