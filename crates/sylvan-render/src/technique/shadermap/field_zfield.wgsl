// `zfield` trees before a forest field (BN12 §7), group 2 (`field_common.wgsl`): their sun and
// sky converge to the field's means as they recede (eq. 22–23, ν = smoothstep(0, 0.8,
// s/s_max)), and their opacity fades by 1 − smoothstep(0.8, 1, s/s_max) while the ground
// takes their share (eq. 26–27, `field.wgsl`).

// Eq. 22–23: Ĩ_t = (1 − ν) I_t + ν Ī_t 𝕋, J̃_t = (1 − ν) J_t + ν J̄_t, the means with the
// field's own albedo (ρ̄ scaled to the local species, `field_tree_albedo`), as BN12's Ī_t
// and J̄_t are, on flat ground (the terrain's normal is not
// known here). With the pixel's own albedo instead, the band was 12 % (R), 3 % (G), 8 % (B)
// darker than the field near s_max on scene E1 (M4): ρ̄ is the mean over all 181 baked views,
// and what the crowns show at the band's grazing views is darker. `albedo` is unused (kept so
// the signature matches `field_none.wgsl`'s). `vis` is the cascades' sun
// visibility at the tree point's light entry (the mean terms take none nearer than s_max:
// `field_sun_visibility`); `height` the tree's (metres: ν goes by its own end).
fn field_tree_light(sun: vec3<f32>, sky: vec3<f32>, albedo: vec3<f32>, world: vec3<f32>, v: vec3<f32>, l: vec3<f32>, vis: f32, height: f32) -> vec3<f32> {
    let s = distance(frame.camera.xyz, world);
    let nu = field_handover_to(s, field_tree_end(height)).x;
    if (nu <= 0.0) {
        return sun + sky;
    }
    let t = forest_terms(world.xz, v, l, vec3<f32>(0.0, 1.0, 0.0));
    return mix(sun + sky, forest_trees(t, field_tree_albedo(world.xz), v, l, field_sun_visibility(vis, s)), nu);
}

// The opacity factor of a tree `height` metres tall whose trunk base is at `base` (§7's fade,
// by the tree's own distance as the chain's bands go, so a tree fades as one, over [0.8, 1] of
// its own end: `field_tree_end`, where it is `handover_px` tall, or s_max).
fn field_fade(base: vec3<f32>, height: f32) -> f32 {
    return 1.0 - field_handover_to(distance(frame.camera.xyz, base), field_tree_end(height)).y;
}
