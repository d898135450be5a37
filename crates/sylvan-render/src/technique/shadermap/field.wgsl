// BN12's shader-map on the terrain (§6, eq. 13–21, and §7's eq. 24–27): per terrain pixel, the
// fractions of ground seen and lit (𝔾, its diagonal), of trees lit (𝕋), and the sky on ground
// and trees (𝔻, 𝔼), for the local tree density, lighting the ground with the terrain's own
// albedo and the trees with the mix's mean albedo ρ̄ — `zfield`'s lighting model averaged over
// a forest (the local species' albedo where they differ from the mix: `field_tree_albedo`).
// Nearer than s_max, where trees are drawn, the ground converges to the field's mean
// (eq. 24–25) and takes the trees' share as they fade (eq. 26–27).
// Group 1: binding 0 the field, bindings 1–4 the tables (`field_tables.wgsl`,
// `field_common.wgsl`).

// The ground's radiance at ground point `xz`, distance `s`, normal `n`, seen along `v`
// (towards the eye), sun
// `l`, albedo `ground`, the cascades' sun visibility `vis` (the relief's shadows, and the drawn
// trees' where the cascades hold them: `field_sun_visibility`).
//
// `contrast` is eq. 10's Δ at this pixel (`ground_contrast`).
//
// Eq. 24–25: Ĩ_g = (1 − ν) I_g + ν Ī_g 𝔾/Gd, J̃_g = (1 − ν) J_g + ν J̄_g, with eq. 12's
// J_g = J̄_g Δ (δ_g from 𝔻, as eq. 18) and J̄_g the sky × 𝔻 (eq. 19).
// ν and w are each species' own, weighed by its crown area there (`field_handover_at`: a
// species ends where its trees are `handover_px` tall, or at s_max).
// Eq. 26–27, mean-preserving (a deviation): the trees drawn over this pixel cover c (1 − w)
// of it on average (c = 1 − Gd, their opacity × (1 − w)), so the ground shows the trees' mean
// with μ = c w / (1 − c (1 − w)), which makes the pixel's tree share exactly c at every w
// (BN12's μ = c w dips to c − c²/4 at w = ½). At w = 1 this is eq. 13:
// L = k_g Ī_g + (k_g + k_ḡ) J̄_g + (1 − k_g − k_ḡ)(𝕋 Ī_t + J̄_t).
fn forest_radiance(xz: vec2<f32>, n: vec3<f32>, v: vec3<f32>, l: vec3<f32>, ground: vec3<f32>, vis: f32, s: f32, contrast: f32) -> vec3<f32> {
    let ndl = max(dot(n, l), 0.0);
    let t = forest_terms(xz, v, l, n);
    let h = field_handover_at(xz, s, dot(v, n));
    let sun_open = ground * frame.sun_color.rgb * ndl;
    let sun_g = sun_open * vis;
    let sky_g = ground * sky_light(n);
    let lit_share = select(1.0, t.seen_lit / t.seen, t.seen > 1e-5);
    let vis_mean = field_sun_visibility(vis, s);
    let sun_mean = sun_open * vis_mean * lit_share;
    let ig = mix(sun_g, sun_mean, h.x);
    let jg = sky_g * t.ground_sky * mix(contrast, 1.0, h.x);
    let trees = forest_trees(t, field_tree_albedo(xz), v, l, vis_mean);
    let mu = min(field_tree_share(t, h.y) * field_cover_gain(xz, v, n, s), 1.0);
    return (1.0 - mu) * (ig + jg) + mu * trees;
}

// BN12 §4 and §7's "Γ/A replacing Λ", mean-preserving: the field's tree share μ is scaled by
// g = Γ/Γ̄, Γ the crowns' cover from above (the ground cover's disks, `world/cover.rs`) filtered
// over the pixel's footprint on the ground and Γ̄ its local mean — so the field's trees lie
// where the trees are (a tree fading out leaves its share under its own crown), g averages to
// 1 over Γ̄'s support, and μ g still starts from 0 as the drawn trees start fading. Where the
// footprint reaches a tile per texel, no tile is held, or trees end, g = 1 (the field of the
// density alone).
fn field_cover_gain(xz: vec2<f32>, v: vec3<f32>, n: vec3<f32>, s: f32) -> f32 {
    let footprint = s / (frame.shadow_params.w * max(abs(dot(v, n)), 0.05));
    let c = ground_cover_filtered(xz, footprint);
    if (c.w < 0.0 || c.y <= 1e-3) {
        return 1.0;
    }
    // Where trees end the cover does (`ground_cover_weight`, by the distance `s`).
    let end = frame.cover_extra.z;
    return mix(1.0, c.x / c.y, c.z * (1.0 - smoothstep(end * 0.9, end, s)));
}

// Eq. 27's μ, mean-preserving: the share of a pixel the field gives to trees when the drawn
// trees over it have faded by `w` (`forest_radiance`).
fn field_tree_share(t: ForestTerms, w: f32) -> f32 {
    let c = 1.0 - t.seen;
    return c * w / max(1.0 - c * (1.0 - w), 1e-5);
}

@fragment
fn fs_terrain_forest(in: TerrainOut) -> @location(0) vec4<f32> {
    let n = normalize(in.normal);
    let ground = terrain_albedo(in.world, n);
    let l = frame.sun_dir.xyz;
    let v = normalize(frame.camera.xyz - in.world);
    let vis = select(sun_visibility(in.world, n * 0.15), 0.0, dot(n, l) <= 0.0);
    let s = distance(frame.camera.xyz, in.world);
    if (debug_mode() == DEBUG_COVERAGE) {
        let t = forest_terms(in.world.xz, v, l, n);
        let share = min(field_tree_share(t, field_handover_at(in.world.xz, s, dot(v, n)).y) * field_cover_gain(in.world.xz, v, n, s), 1.0);
        return vec4<f32>(target_output(vec3<f32>(share)), 1.0);
    }
    let lit = forest_radiance(in.world.xz, n, v, l, ground, vis, s, ground_contrast(in.world));
    return vec4<f32>(debug_tint(apply_fog(lit, in.world), in.world, TECHNIQUE_SHADERMAP), 1.0);
}
