// The forest field's parameters and BN12 §6's per-pixel terms (eq. 2–5, 14–16, 18–21), shared
// by the terrain (`field.wgsl`, group 1) and by the `zfield` trees that converge to the field
// (`field_zfield.wgsl`, group 2). Composed after `field_tables.wgsl`, with `@group(FIELD)`
// substituted.

struct FieldParams {
    // x: the density raster's scale (its texels' r holds Λ_h / x, trees per m²); yz: 1 / the
    // terrain's extent (m); w unused.
    density: vec4<f32>,
    // x, y: the raster's g and b scales (Σ Λⁱ aⁱ, Σ Λⁱ sⁱ: crown areas per m² from the top
    // and the side); z, w: the mix's mean crown areas ā, s̄ (m²; 0 without crowns).
    crowns: vec4<f32>,
    // rgb: ρ̄, the trees' mean albedo (linear): the mix's, where the local species are the
    // mix (`field_tree_albedo`).
    tree_albedo: vec4<f32>,
    // x: `zfield.sun_scale`; y: `zfield.sky_scale`; z: a1; w: a2 (eq. 8).
    light: vec4<f32>,
    // x: s_max, where the field takes over from the trees (m; 0: the field everywhere, no
    // trees); y: ν forced (< 0: BN12's smoothstep(0, 0.8, s/s_max)); z: the §7 handover
    // (1) or a hard switch at s_max (0); w: `handover_px`, the apparent height under which a
    // tree is left to the field (0: none).
    handover: vec4<f32>,
    // x: `zfield.sky_normal_weight` (the trees' sky blended towards what their normals see);
    // y: the species with a density layer (layers 2…, four a layer).
    sky: vec4<f32>,
    // Per species: x, y its top and side crown areas per m² of h² times its layer's scale
    // (so a layer texel times them is Λⁱ aⁱ, Λⁱ sⁱ), z its rms height (m).
    species: array<vec4<f32>, 64>,
};

@group(FIELD) @binding(0) var<uniform> field: FieldParams;
// Layer 0: Λ_h and the crown areas over the terrain (`density.rs`), normalised by
// `field.density.x`, `field.crowns.xy`; layer 1: the top areas weighted by albedo over the
// terrain's mean albedo, on layer 0's top-area scale.
@group(FIELD) @binding(5) var field_density_map: texture_2d_array<f32>;

// The field's raster at ground point `xz` (`density.rs`): r Λ_h, g Σ Λⁱ aⁱ, b Σ Λⁱ sⁱ, each
// over its scale.
fn field_raster(xz: vec2<f32>) -> vec4<f32> {
    return textureSampleLevel(field_density_map, table_sampler, xz * field.density.yz, 0, 0.0);
}

// The trees' albedo at ground point `xz`: the local species' mean (Σ Λⁱ aⁱ ρⁱ / Σ Λⁱ aⁱ,
// `density.rs`) relative to the terrain's mean, times ρ̄ — so where the local species are the
// mix it is ρ̄, which the tables were measured with; ρ̄ where no crowns are.
fn field_tree_albedo(xz: vec2<f32>) -> vec3<f32> {
    let uv = xz * field.density.yz;
    let top = textureSampleLevel(field_density_map, table_sampler, uv, 0, 0.0).g;
    let tinted = textureSampleLevel(field_density_map, table_sampler, uv, 1, 0.0).rgb;
    if (top <= 1e-4) {
        return field.tree_albedo.rgb;
    }
    return clamp(field.tree_albedo.rgb * tinted / top, vec3<f32>(0.0), vec3<f32>(1.0));
}

// The density the tables are looked up at, trees per m², from a `field_raster` sample `t`,
// for a view at zenith `theta` of the transformed space: the density of the mix's trees whose
// crowns project along it as much as the local trees' do (Σ Λⁱ(aⁱ cos θ + sⁱ′ sin θ) /
// (ā cos θ + s̄′ sin θ), side areas scaled by 2/h); Λ_h where the mix has no crowns.
fn field_density(t: vec4<f32>, theta: f32) -> f32 {
    let c = cos(theta);
    let s = sin(theta) * 2.0 / table_info.shape.x;
    let mean = field.crowns.z * c + field.crowns.w * s;
    if (mean <= 0.0) {
        return field.density.x * t.r;
    }
    return (field.crowns.x * t.g * c + field.crowns.y * t.b * s) / mean;
}

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

// The tables at ground point `xz` of normal `n` seen along `v` (towards the eye), sun `l`: `seen` = Gd
// (k_g + k_ḡ, eq. 15), `seen_lit` = 𝔾 (k_g, eq. 14), `trees_lit` = 𝕋 (k_t / (k_t + k_t̄),
// eq. 16), `trees_sky` = 𝔼 (eq. 21), `trees_sky_side` = 𝔼ₙ (𝔼's share a leaf facing the eye
// sees below its horizon), `ground_sky` = 𝔻 (eq. 19).
struct ForestTerms {
    seen: f32,
    seen_lit: f32,
    trees_lit: f32,
    trees_sky: f32,
    trees_sky_side: f32,
    ground_sky: f32,
};

fn forest_terms(xz: vec2<f32>, v: vec3<f32>, l: vec3<f32>, n: vec3<f32>) -> ForestTerms {
    let a = forest_angles(v, l, n);
    // The view's density for what is seen; the sky's (𝔻) at 45°, the cosine-weighted mean.
    let raster = field_raster(xz);
    let lambda = field_density(raster, a.theta_v) * a.slope;
    let lambda_sky = field_density(raster, 0.7853982) * a.slope;
    let gt = table_gt(a.theta_v, a.theta_l, a.phi, lambda);
    let dec = table_dec(a.theta_v, lambda);
    var out: ForestTerms;
    out.seen = clamp(table_g_diag(a.theta_v, lambda), 0.0, 1.0);
    out.seen_lit = clamp(gt.x, 0.0, out.seen);
    out.trees_lit = gt.y;
    out.trees_sky = dec.x;
    out.trees_sky_side = dec.z;
    out.ground_sky = table_dec(a.theta_v, lambda_sky).y;
    return out;
}

// Eq. 20–21: the mean radiance of the trees seen, for albedo `rho`, the terrain's own sun
// visibility `vis`.
fn forest_trees(t: ForestTerms, rho: vec3<f32>, v: vec3<f32>, l: vec3<f32>, vis: f32) -> vec3<f32> {
    let it = rho * field.light.x * field_hotspot(v, l) * frame.sun_color.rgb * t.trees_lit * vis;
    // Eq. 21 with `zfield`'s sky (`sky_shape`): mix(S, sky_light(n), w) averaged over the tree
    // points is S 𝔼 − w (S − G) 𝔼ₙ, S the sky an upward normal sees, G the ground's.
    let up = sky_light(vec3<f32>(0.0, 1.0, 0.0));
    let sky = up * t.trees_sky - field.sky.x * (up - frame.sky_ground.rgb) * t.trees_sky_side;
    let jt = rho * field.light.y * max(sky, vec3<f32>(0.0));
    return it + jt;
}

// The sun visibility the field's mean terms take (Ī_g 𝔾/Gd, Ī_t 𝕋) from the cascades' `vis` at
// distance `s`: 𝔾 and 𝕋 already hold the trees' shadows, so where the cascades hold drawn trees
// (nearer than s_max, and their shadows up to 10 % beyond) the field takes none (BN12's eq. 17
// and 20 have no V); farther, and with the field alone, the cascades hold only the terrain and
// its relief shadows apply (a deviation: BN12 has none).
fn field_sun_visibility(vis: f32, s: f32) -> f32 {
    let smax = field.handover.x;
    if (smax <= 0.0) {
        return vis;
    }
    return mix(1.0, vis, smoothstep(smax, 1.1 * smax, s));
}

// The end of a tree `height` metres tall (BN12 §4's 3-px rule, `FieldEnd::tree_end`):
// min(s_max, where it is `handover_px` tall in the output).
fn field_tree_end(height: f32) -> f32 {
    let smax = field.handover.x;
    if (field.handover.w <= 0.0) {
        return smax;
    }
    return min(smax, height * (frame.shadow_params.w / field.handover.w));
}

// `field_handover` for trees that end at `e` (a tree's own, or a species' end).
fn field_handover_to(s: f32, e: f32) -> vec2<f32> {
    if (field.handover.x <= 0.0) {
        return vec2<f32>(1.0, 1.0);
    }
    let t = s / max(e, 1e-6);
    let nu = select(smoothstep(0.0, 0.8, t), field.handover.y, field.handover.y >= 0.0);
    let w = select(select(0.0, 1.0, t >= 1.0), smoothstep(0.8, 1.0, t), field.handover.z > 0.5);
    return vec2<f32>(nu, w);
}

// The ground's `field_handover` at ground point `xz`, distance `s`, seen at `cos_v` from the
// zenith: each species ends at its own distance (`field_tree_end` of its rms height), so ν and
// w are the species' own, weighed by the crown area each shows along the view there (layers
// 2… of the raster). Trees that all end at s_max (no pixel rule, or every species taller than
// `handover_px` there) give `field_handover(s)`.
fn field_handover_at(xz: vec2<f32>, s: f32, cos_v: f32) -> vec2<f32> {
    let smax = field.handover.x;
    let n = u32(field.sky.y);
    if (smax <= 0.0 || s >= smax || field.handover.w <= 0.0 || n == 0u) {
        return field_handover(s);
    }
    let uv = xz * field.density.yz;
    let c = clamp(cos_v, 0.0, 1.0);
    let side = sqrt(1.0 - c * c) * 2.0 / table_info.shape.x;
    var texel = vec4<f32>(0.0);
    var sum = 0.0;
    var acc = vec2<f32>(0.0);
    for (var i = 0u; i < n; i++) {
        if (i % 4u == 0u) {
            texel = textureSampleLevel(field_density_map, table_sampler, uv, 2u + i / 4u, 0.0);
        }
        let sp = field.species[i];
        let weight = texel[i % 4u] * (sp.x * c + sp.y * side);
        acc += weight * field_handover_to(s, field_tree_end(sp.z));
        sum += weight;
    }
    if (sum <= 0.0) {
        return field_handover(s);
    }
    return acc / sum;
}

// BN12 §7 at distance `s`: x = ν of eq. 22–25 (smoothstep(0, 0.8, s/s_max), or forced), y =
// w = smoothstep(0.8, 1, s/s_max), how far the trees have faded into the field (a step at
// s_max without the handover). Without trees (s_max = 0) both are 1.
fn field_handover(s: f32) -> vec2<f32> {
    let smax = field.handover.x;
    if (smax <= 0.0) {
        return vec2<f32>(1.0, 1.0);
    }
    let t = s / smax;
    let nu = select(smoothstep(0.0, 0.8, t), field.handover.y, field.handover.y >= 0.0);
    let w = select(select(0.0, 1.0, t >= 1.0), smoothstep(0.8, 1.0, t), field.handover.z > 0.5);
    return vec2<f32>(nu, w);
}
