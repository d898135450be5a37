// BN12's shader-map on the terrain (§6, eq. 2–5 and 13–21): per terrain pixel, the fractions
// of ground seen and lit (𝔾, its diagonal), of trees lit (𝕋), and the sky on ground and trees
// (𝔻, 𝔼), for the local tree density, lighting the ground with the terrain's own albedo and the
// trees with the mix's mean albedo ρ̄ — `zfield`'s lighting model averaged over a forest.
// Group 1: binding 0 the field, bindings 1–4 the tables (`field_tables.wgsl`).

struct FieldParams {
    // x: tree density Λ_h (trees per m²); yzw unused.
    density: vec4<f32>,
    // rgb: ρ̄, the trees' mean albedo (linear).
    tree_albedo: vec4<f32>,
    // x: `zfield.sun_scale`; y: `zfield.sky_scale`; z: a1; w: a2 (eq. 8).
    light: vec4<f32>,
};

@group(1) @binding(0) var<uniform> field: FieldParams;

// Eq. 2–5 in BN12's transformed space S = diag(1, 2/h, 1): view and light zeniths against the
// transformed normal, the azimuth between them, and the density's slope factor.
struct ForestAngles {
    theta_v: f32,
    theta_l: f32,
    phi: f32,
    slope: f32,
};

fn forest_angles(v: vec3<f32>, l: vec3<f32>, n: vec3<f32>) -> ForestAngles {
    let s = vec3<f32>(1.0, 2.0 / table_info.shape.x, 1.0);
    let sv = normalize(v * s);
    let sl = normalize(l * s);
    let ni = normalize(n / s);
    var out: ForestAngles;
    let cv = dot(sv, ni);
    let cl = dot(sl, ni);
    out.theta_v = acos(clamp(cv, -1.0, 1.0));
    out.theta_l = acos(clamp(cl, -1.0, 1.0));
    let a = sv - cv * ni;
    let b = sl - cl * ni;
    let ab = length(a) * length(b);
    out.phi = select(0.0, acos(clamp(dot(a, b) / max(ab, 1e-12), -1.0, 1.0)), ab > 1e-4);
    out.slope = ni.y / max(n.y, 0.05);
    return out;
}

// Eq. 8, as `zfield`'s `hotspot`.
fn field_hotspot(v: vec3<f32>, l: vec3<f32>) -> f32 {
    let angle = acos(clamp(dot(v, l), -1.0, 1.0));
    return 1.0 - field.light.z * (1.0 - exp(-field.light.w * angle));
}

// Eq. 13: L = k_g Ī_g + (k_g + k_ḡ) J̄_g + (1 − k_g − k_ḡ)(𝕋 Ī_t + J̄_t) for a terrain point of
// normal `n` seen along `v` (towards the eye), sun `l`, ground albedo `ground` and the
// terrain's own sun visibility `vis` (its relief's shadows).
fn forest_radiance(n: vec3<f32>, v: vec3<f32>, l: vec3<f32>, ground: vec3<f32>, vis: f32) -> vec3<f32> {
    let ndl = max(dot(n, l), 0.0);
    let a = forest_angles(v, l, n);
    let lambda = field.density.x * a.slope;
    let gt = table_gt(a.theta_v, a.theta_l, a.phi, lambda);
    let seen = clamp(table_g_diag(a.theta_v, lambda), 0.0, 1.0);
    let seen_lit = clamp(gt.x, 0.0, seen);
    let dec = table_dec(a.theta_v, lambda);
    // Eq. 17, 19: the ground's sun and sky (𝔻: the sky through the canopy).
    let ig = ground * frame.sun_color.rgb * ndl * vis;
    let jg = ground * sky_light(n) * dec.y;
    // Eq. 20, 21 with `zfield`'s sun (eq. 7–8) and sky (eq. 9) terms.
    let rho = field.tree_albedo.rgb;
    let it = rho * field.light.x * field_hotspot(v, l) * frame.sun_color.rgb * gt.y * vis;
    let jt = rho * field.light.y * sky_light(vec3<f32>(0.0, 1.0, 0.0)) * dec.x;
    return seen_lit * ig + seen * jg + (1.0 - seen) * (it + jt);
}

@fragment
fn fs_terrain_forest(in: TerrainOut) -> @location(0) vec4<f32> {
    let n = normalize(in.normal);
    let ground = terrain_albedo(in.world, n);
    let l = frame.sun_dir.xyz;
    let v = normalize(frame.camera.xyz - in.world);
    let vis = select(sun_visibility(in.world, n * 0.15), 0.0, dot(n, l) <= 0.0);
    let lit = forest_radiance(n, v, l, ground, vis);
    return vec4<f32>(debug_tint(apply_fog(lit, in.world), in.world, TECHNIQUE_SHADERMAP), 1.0);
}
