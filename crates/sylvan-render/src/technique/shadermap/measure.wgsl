// `shadermap`'s table measurement (BN12 §6, "precomputations"): a periodic z-field forest
// patch drawn along one direction d (towards the eye or the sun) with a sheared, ground-aligned
// orthographic projection, so pixel (i, j) is the same ground texel in every direction. A
// pixel is written where a tree hides the ground point's ray: the z-field's opacity α along d
// against a threshold hashed from (ground texel, tree), the same threshold in every direction,
// so two directions see the same trees the way two nearby rays do (v = l gives G = Gd exactly)
// and n trees of opacity α over one ray leave (1 − α)ⁿ of the ground visible on average.
// What is written is the highest tree point along the ray (a G-buffer for view directions, a
// light map for the sun's); `measure_eval` then counts ground and lights tree points.
// Appended to `zfield`'s shader (its bindings, the grid lookup and `zfield.wgsl`).
// frame.view_proj: the sheared projection; frame.sun_dir.xyz: d; frame.shadow_params.x:
// 1 / pixels of the patch; frame.camera.w: pixels per metre of ground.

// ---- G-buffers and light maps ----
// The z-field's view ray reconstructed (BN12 §5 steps 2–4, the `zfield` technique's own
// functions) where the (texel, tree) threshold keeps the tree. Depth: the highest point along
// the ray is the first one from the sky (frame.camera.y: the patch's top; frame.camera.z:
// trees per copy of the tile; frame.shadow_params.y: metres per ground texel).

struct MeasureHit {
    ok: bool,
    // Iteration 2 found the surface (else p_v is on the quad and δ_v unknown: the texel is
    // hidden but not a tree sample for 𝕋 and 𝔼).
    found: bool,
    id: u32,
    world: vec3<f32>,
    delta_v: f32,
    normal: vec3<f32>,
};

fn measure_hit(in: ZOut, with_normal: bool) -> MeasureHit {
    var out: MeasureHit;
    out.ok = false;
    let sp = z_species[in.views.w];
    let p = instance_to_model(in.world, in.base_scale, in.rot);
    let d = frame.sun_dir.xyz;
    let r = -instance_dir_to_model(d, in.rot);
    let hit = z_reconstruct(sp, in.views.xyz, in.weights, p, r, in.lod);
    let ground = in.world.xz - d.xz * (in.world.y / d.y);
    let texel = floor(ground * frame.camera.w);
    let key = 1.0 + fract(in.rot.z * 7.31 + in.base_scale.x * 0.137 + in.base_scale.z * 0.291) * 4093.0;
    if (hit.alpha_1 <= hash13(vec3<f32>(texel, key))) {
        return out;
    }
    out.ok = true;
    out.found = hit.alpha_v >= 0.004;
    out.id = in.light_views.w;
    out.world = instance_to_world(hit.pv, in.base_scale, in.rot);
    out.delta_v = hit.delta_v;
    out.normal = vec3<f32>(0.0, 1.0, 0.0);
    if (with_normal) {
        let s = surface3(sp, in.views.xyz, in.weights, hit.q, in.lod);
        out.normal = normalize(instance_dir_to_world(select(vec3<f32>(0.0, 1.0, 0.0), normalize(s.normal), dot(s.normal, s.normal) > 1e-12), in.rot));
    }
    return out;
}

// The tree's index in the tile: draws bind whole copies (each `frame.camera.z` trees) from a
// copy boundary, so the instance index modulo the tile's trees is the same in every copy.
// The mip is the ground texel's (frame.shadow_params.y metres) against the tree's texel, the
// same in every direction and in `measure_eval`'s light rays.
@vertex
fn vs_measure_tree(in: ZIn, inst: TreeInstance, @builtin(instance_index) id: u32) -> ZOut {
    // The whole square: this pass samples coarser mips than the casters' extent allows for.
    var out = z_vertex(in, inst, frame.sun_dir.xyz, true, false);
    out.light_views.w = id % u32(frame.camera.z);
    let sp = z_species[out.views.w];
    let texel_m = 2.0 * sp.centre_radius.w * inst.base_scale.w / f32(zp.tiles.x);
    out.lod = max(log2(frame.shadow_params.y / texel_m), 0.0);
    return out;
}

struct GBufferOut {
    @location(0) texel: vec4<u32>,
    @builtin(frag_depth) depth: f32,
};

// x: tree + 1; y: p_v's height (f32 bits); z: δ_v (16-bit unorm), or all ones where iteration 2
// missed; w: the normal (8-bit snorm).
@fragment
fn fs_measure_gbuffer(in: ZOut) -> GBufferOut {
    let h = measure_hit(in, true);
    if (!h.ok) {
        discard;
    }
    var out: GBufferOut;
    let delta = select(0xffffffffu, pack2x16unorm(vec2<f32>(h.delta_v, 0.0)), h.found);
    out.texel = vec4<u32>(h.id + 1u, bitcast<u32>(h.world.y), delta, pack4x8snorm(vec4<f32>(h.normal, 0.0)));
    out.depth = clamp(1.0 - h.world.y / frame.camera.y, 0.0, 1.0);
    return out;
}

struct LightMapOut {
    @location(0) texel: vec2<u32>,
    @builtin(frag_depth) depth: f32,
};

// x: tree + 1 of the highest point along the light ray; y: its height (f32 bits).
@fragment
fn fs_measure_light(in: ZOut) -> LightMapOut {
    let h = measure_hit(in, false);
    if (!h.ok) {
        discard;
    }
    var out: LightMapOut;
    out.texel = vec2<u32>(h.id + 1u, bitcast<u32>(h.world.y));
    out.depth = clamp(1.0 - h.world.y / frame.camera.y, 0.0, 1.0);
    return out;
}

// ---- Evaluation: every (view, light) pair from one G-buffer and one light map ----

struct Eval {
    // xyz: towards the view; w: patch side (m).
    view: vec4<f32>,
    // x: texels per side; y: trees in the tile; z: λ (trees/m²); w: the stride between the
    // texels evaluated (every texel's tree is in the G-buffer; 𝕋 and 𝔼 need fewer samples).
    sizes: vec4<f32>,
    // xy: the view G-buffer's tile origin; z: light-map atlas tiles per row; w: the entry of
    // this dispatch's first light.
    tiles: vec4<u32>,
    // x: the view's first sky entry (of two); y: 1 if this dispatch sums the sky (its first
    // light is the first of all); z: the index in `lights` of this dispatch's first light.
    sky: vec4<u32>,
};

@group(2) @binding(0) var<uniform> ev: Eval;
@group(2) @binding(1) var gbuffer: texture_2d<u32>;
@group(2) @binding(2) var light_maps: texture_2d<u32>;
// Two vec4 per tree of the tile (copy (0, 0)): base_scale, rot (as `GpuTreeInstance`).
@group(2) @binding(3) var<storage, read> trees: array<vec4<f32>>;
// xyz: towards the sun, per light direction (a uniform: the compute stage's storage buffers
// stay within the downlevel four).
@group(2) @binding(4) var<uniform> lights: array<vec4<f32>, 1024>;
// Per (view, light) entry: Σ S′ (2¹² per unit), tree samples, ground texels seen and lit; per
// view's sky entries (two): Σ δ·hole (2¹⁴ per unit), tree samples, ground texels seen, then
// Σ δ·hole·(1 − n_y)/2 (the same unit; 𝔼ₙ).
@group(2) @binding(5) var<storage, read_write> acc: array<atomic<u32>>;

var<workgroup> wg_sun: atomic<u32>;
var<workgroup> wg_trees: atomic<u32>;
var<workgroup> wg_ground: atomic<u32>;
var<workgroup> wg_sky: atomic<u32>;
var<workgroup> wg_sky_side: atomic<u32>;
var<workgroup> wg_seen: atomic<u32>;

const SUN_ONE: f32 = 4096.0;
const SKY_ONE: f32 = 16384.0;

@compute @workgroup_size(8, 8, 1)
fn measure_eval(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    if (li == 0u) {
        atomicStore(&wg_sun, 0u);
        atomicStore(&wg_trees, 0u);
        atomicStore(&wg_ground, 0u);
        atomicStore(&wg_sky, 0u);
        atomicStore(&wg_sky_side, 0u);
        atomicStore(&wg_seen, 0u);
    }
    workgroupBarrier();
    let px = u32(ev.sizes.x);
    let side = ev.view.w;
    let stride = u32(ev.sizes.w);
    let light_index = gid.z;
    let cols = ev.tiles.z;
    let origin = vec2<i32>(i32((light_index % cols) * px), i32((light_index / cols) * px));
    let sky_pass = light_index == 0u && ev.sky.y == 1u;
    if (gid.x < px && gid.y < px) {
        let g = textureLoad(gbuffer, vec2<i32>(ev.tiles.xy + gid.xy), 0);
        // 𝔾 and its diagonal: every texel; the same texel of the light map is the same ground.
        if (g.x == 0u) {
            if (textureLoad(light_maps, origin + vec2<i32>(gid.xy), 0).x == 0u) {
                atomicAdd(&wg_ground, 1u);
            }
            if (sky_pass) {
                atomicAdd(&wg_seen, 1u);
            }
        }
        // 𝕋 and 𝔼: the trees of every `stride`-th texel.
        let on_grid = all((gid.xy % vec2<u32>(stride)) == vec2<u32>(stride / 2u));
        if (g.x != 0u && g.z != 0xffffffffu && on_grid) {
            let id = g.x - 1u;
            var base_scale = trees[2u * id];
            var rot = trees[2u * id + 1u];
            let species = u32(floor(rot.z));
            rot.z = fract(rot.z);
            let sp = z_species[species];
            let v = ev.view.xyz;
            let ground = (vec2<f32>(gid.xy) + 0.5) * side / f32(px);
            let world = vec3<f32>(ground.x, 0.0, ground.y) + v * (bitcast<f32>(g.y) / v.y);
            // The copy of the tile this tree is in: its points lie within a crown radius of
            // its base, far less than half a tile.
            base_scale = vec4<f32>(base_scale.xyz + vec3<f32>(round((world.x - base_scale.x) / side), 0.0, round((world.z - base_scale.z) / side)) * side, base_scale.w);
            let pv = instance_to_model(world, base_scale, rot);
            let l = lights[ev.sky.z + light_index].xyz;
            let lm = instance_dir_to_model(l, rot);
            let pick = hemi_grid_nearest3(model_dir_upper(l, rot), zp.tiles.w);
            let texel_m = 2.0 * sp.centre_radius.w * base_scale.w / f32(zp.tiles.x);
            let lod = max(log2(side / f32(px) / texel_m), 0.0);
            let zl = z_light(sp, pick.views, pick.weights, pv, lm, lod);
            let path_m = max(dot(zl.pl - pv, lm), 0.0) * base_scale.w;
            let n = normalize(unpack4x8snorm(g.w).xyz + vec3<f32>(0.0, 1e-6, 0.0));
            let phase = phase_shape(n, l);
            // V(p_l): the light map's highest point along the light ray through p_l is this
            // tree (any copy of it) or lies below p_l.
            let wl = instance_to_world(zl.pl, base_scale, rot);
            let gl = wl.xz - l.xz * (wl.y / l.y);
            let t = vec2<i32>(floor(gl / side * f32(px))) % vec2<i32>(i32(px));
            let tl = (t + vec2<i32>(i32(px))) % vec2<i32>(i32(px));
            let m = textureLoad(light_maps, origin + tl, 0);
            let own = m.x == 0u || m.x - 1u == id;
            let lit = select(0.0, 1.0, own || bitcast<f32>(m.y) <= wl.y + 0.05 * sp.centre_radius.w * base_scale.w);
            let s = phase * exp(-zl.tau * path_m) * lit;
            atomicAdd(&wg_sun, u32(s * SUN_ONE + 0.5));
            atomicAdd(&wg_trees, 1u);
            if (sky_pass) {
                let top = instance_to_world(sp.bbox_max.xyz, base_scale, rot).y;
                let hole = sky_hole(max(top - world.y, 0.0), ev.sizes.z);
                let delta = unpack2x16unorm(g.z).x;
                atomicAdd(&wg_sky, u32(delta * hole * SKY_ONE + 0.5));
                atomicAdd(&wg_sky_side, u32(delta * hole * 0.5 * (1.0 - n.y) * SKY_ONE + 0.5));
            }
        }
    }
    workgroupBarrier();
    if (li == 0u) {
        let entry = 3u * (ev.tiles.w + light_index);
        atomicAdd(&acc[entry], atomicLoad(&wg_sun));
        atomicAdd(&acc[entry + 1u], atomicLoad(&wg_trees));
        atomicAdd(&acc[entry + 2u], atomicLoad(&wg_ground));
        if (sky_pass) {
            let e = 3u * ev.sky.x;
            atomicAdd(&acc[e], atomicLoad(&wg_sky));
            atomicAdd(&acc[e + 1u], atomicLoad(&wg_trees));
            atomicAdd(&acc[e + 2u], atomicLoad(&wg_seen));
            atomicAdd(&acc[e + 3u], atomicLoad(&wg_sky_side));
        }
    }
}
