// Technique `zfield` (BN12 §5, fig. 4): one camera-facing proxy quad per tree; per pixel the
// view ray's entry point p_v is reconstructed from the 3 grid views nearest the view
// direction in two iterations, the light ray's entry point p_l in one, and the point is lit
// with BN12's sun (eq. 7–8) and sky (eq. 9) terms. Fragment depth is p_v's. Coverage is a
// per-tree stochastic mask (§8), so trees need no sorting.
// Bind group 1: `bindings.wgsl`; the grid lookup: `directions::HEMI_GRID_WGSL`.

struct ZIn {
    @builtin(vertex_index) vertex: u32,
};

struct ZOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) world: vec3<f32>,
    // The 3 views nearest the quad's direction (eye, or sun for casters) and the species.
    @location(1) @interpolate(flat) views: vec4<u32>,
    @location(2) @interpolate(flat) weights: vec3<f32>,
    // The 3 views nearest the sun (camera pass).
    @location(3) @interpolate(flat) light_views: vec4<u32>,
    @location(4) @interpolate(flat) light_weights: vec3<f32>,
    // Instance: trunk base and scale; cos, sin, tint seed, presence.
    @location(5) @interpolate(flat) base_scale: vec4<f32>,
    @location(6) @interpolate(flat) rot: vec4<f32>,
    @location(7) @interpolate(flat) lod: f32,
};

fn hidden() -> ZOut {
    var out: ZOut;
    out.pos = vec4<f32>(0.0, 0.0, -2.0, 1.0);
    return out;
}

// A world direction in the tree's frame, folded onto the upper hemisphere.
fn model_dir_upper(a: vec3<f32>, rot: vec4<f32>) -> vec3<f32> {
    var d = instance_dir_to_model(a, rot);
    d.y = max(d.y, 0.0);
    return select(vec3<f32>(0.0, 1.0, 0.0), normalize(d), dot(d, d) > 1e-12);
}

// The proxy quad of one tree facing `toward` (the eye, or the sun when `is_dir`): BN12 §5
// step 1 (the 3 views and weights, per tree) and the quad covering the tree's box (its
// bounding sphere's silhouette).
fn z_vertex(in: ZIn, inst_in: TreeInstance, toward_world: vec3<f32>, is_dir: bool, tight: bool) -> ZOut {
    // Every species is in one list: the instance's rot.z is species + tint seed.
    let species = u32(floor(inst_in.rot.z));
    var inst = inst_in;
    inst.rot.z = fract(inst_in.rot.z);
    let sp = z_species[species];
    let centre = instance_to_world(sp.centre_radius.xyz, inst.base_scale, inst.rot);
    let radius = sp.centre_radius.w * inst.base_scale.w;
    var a = toward_world;
    var grow = 1.0;
    var dist = 0.0;
    if (!is_dir) {
        let e = toward_world - centre;
        dist = length(e);
        a = e / max(dist, 1e-6);
        grow = min(dist / sqrt(max(dist * dist - radius * radius, 1e-6)), 4.0);
        if (dist <= radius * 1.03) {
            grow = 4.0;
        }
    }
    let pick = hemi_grid_nearest3(model_dir_upper(a, inst.rot), zp.tiles.w);
    let light = hemi_grid_nearest3(model_dir_upper(frame.sun_dir.xyz, inst.rot), zp.tiles.w);
    let right = select(vec3<f32>(1.0, 0.0, 0.0), normalize(cross(vec3<f32>(0.0, 1.0, 0.0), a)), abs(a.y) < 0.9999);
    let up = cross(a, right);
    let st = array<vec2<f32>, 6>(
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, 1.0), vec2<f32>(-1.0, 1.0),
    )[in.vertex % 6u];
    // A texel is 2·radius/tile metres; a pixel covers dist / pixels_per_metre (camera) or one
    // shadow-map texel (sun).
    let texel_m = 2.0 * radius / f32(zp.tiles.x);
    var pixel_m = dist / max(frame.shadow_params.w, 1.0);
    if (is_dir) {
        let row_x = vec3<f32>(frame.view_proj[0].x, frame.view_proj[1].x, frame.view_proj[2].x);
        pixel_m = frame.shadow_params.x * 2.0 / max(length(row_x), 1e-6);
    }
    // The camera pass samples `lod_bias` mips finer (sharper; measured closer to the
    // reference on the default scene), casters at their texel footprint.
    let bias = select(zp.extra.x, 0.0, is_dir);
    let lod = max(log2(pixel_m / texel_m) + bias, 0.0);
    // The square around the sphere (camera), or for a caster only the part its 3 views can
    // cover (`caster_extent`; `tight`), in metres from the centre along right and up.
    var world = centre + (right * st.x + up * st.y) * radius * grow;
    if (is_dir && tight && zp.extra.w > 0.5) {
        // A mip ⌈lod⌉ texel overlapping the box has coverage and bilinear filtering reaches
        // one more: 2 · 2^⌈lod⌉ image texels (+ 2); the shadow map rasterises texel centres
        // (+ 2 of its texels). In model units.
        let margin = (texel_m * (2.0 * exp2(ceil(lod)) + 2.0) + 2.0 * pixel_m) / inst.base_scale.w;
        let e = caster_extent(sp, pick, instance_dir_to_model(right, inst.rot), instance_dir_to_model(up, inst.rot), instance_dir_to_model(a, inst.rot), margin) * inst.base_scale.w;
        let corner = select(e.xy, e.zw, st > vec2<f32>(0.0));
        world = centre + right * corner.x + up * corner.y;
    }
    var out: ZOut;
    out.pos = frame.view_proj * vec4<f32>(world, 1.0);
    out.world = world;
    out.views = vec4<u32>(pick.views, species);
    out.weights = pick.weights;
    out.light_views = vec4<u32>(light.views, 0u);
    out.light_weights = light.weights;
    out.base_scale = inst.base_scale;
    out.rot = inst.rot;
    out.lod = lod;
    return out;
}

// Where a caster quad facing `a` (model space, with its `right` and `up` axes) can have
// coverage, in model units from the frames' centre along right (x, z) and up (y, w): the
// union of its 3 views' `caster_view_extent` (step 5 samples p's own projection: no
// parallax), widened by `margin`, within the bounding square.
fn caster_extent(sp: ZSpecies, pick: HemiPick, right: vec3<f32>, up: vec3<f32>, a: vec3<f32>, margin: f32) -> vec4<f32> {
    let r = sp.centre_radius.w;
    let half = 0.5 * (sp.bbox_max.xyz - sp.bbox_min.xyz);
    let mid = 0.5 * (sp.bbox_max.xyz + sp.bbox_min.xyz) - sp.centre_radius.xyz;
    var lo = vec2<f32>(1e30);
    var hi = vec2<f32>(-1e30);
    for (var i = 0u; i < 3u; i = i + 1u) {
        if (pick.weights[i] <= 0.0) {
            continue;
        }
        let e = caster_view_extent(mid, half, right, up, a, z_views[pick.views[i]].f.xyz, 0.0);
        if (e.z < e.x) {
            return vec4<f32>(-r, -r, r, r);
        }
        lo = min(lo, e.xy);
        hi = max(hi, e.zw);
    }
    return vec4<f32>(clamp(lo - margin, vec2<f32>(-r), vec2<f32>(r)), clamp(hi + margin, vec2<f32>(-r), vec2<f32>(r)));
}

// Atlas coordinates of image point `uv` of `tile`, kept inside the tile at the coarser of the
// two mips sampled. Explicit mips: llvmpipe's derivatives are wrong along triangle edges.
fn atlas_uv(tile: u32, uv: vec2<f32>, lod: f32) -> vec3<f32> {
    let in_layer = tile % zp.tiles.z;
    let cell = vec2<f32>(f32(in_layer % zp.tiles.y), f32(in_layer / zp.tiles.y));
    let half = 0.5 * exp2(ceil(lod)) / f32(zp.tiles.x);
    let at = (cell + clamp(uv, vec2<f32>(half), vec2<f32>(1.0 - half))) * zp.atlas.xy;
    return vec3<f32>(at, f32(tile / zp.tiles.z));
}

// Orthographic projection of model-space point `p` in view `k`: image coordinates, or
// outside [0, 1]² where the view does not see it.
fn view_uv(sp: ZSpecies, k: u32, p: vec3<f32>) -> vec2<f32> {
    let view = z_views[k];
    let q = (p - sp.centre_radius.xyz) / sp.centre_radius.w;
    return vec2<f32>(0.5 + 0.5 * dot(q, view.u.xyz), 0.5 - 0.5 * dot(q, view.v.xyz));
}

fn inside(uv: vec2<f32>) -> bool {
    return all(uv >= vec2<f32>(0.0)) && all(uv <= vec2<f32>(1.0));
}

// Σ wᵢ (α z, α z̄, α δ, α)ᵢ of `p` projected orthogonally in the 3 views (BN12 §5 step 3).
fn zfield3(sp: ZSpecies, views: vec3<u32>, w: vec3<f32>, p: vec3<f32>, lod: f32) -> vec4<f32> {
    var acc = vec4<f32>(0.0);
    for (var i = 0u; i < 3u; i = i + 1u) {
        if (w[i] <= 0.0) {
            continue;
        }
        let uv = view_uv(sp, views[i], p);
        if (!inside(uv)) {
            continue;
        }
        let a = atlas_uv(sp.info.x + views[i], uv, lod);
        acc = acc + w[i] * textureSampleLevel(atlas_zfield, atlas_sampler, a.xy, i32(a.z), lod);
    }
    return acc;
}

// Signed distance beyond the centre plane (model units) of a premultiplied depth.
fn plane_distance(sp: ZSpecies, premultiplied_z: f32, alpha: f32) -> f32 {
    return sp.centre_radius.w * (2.0 * premultiplied_z / alpha - 1.0);
}

struct Surface {
    // Premultiplied albedo and coverage.
    color: vec4<f32>,
    // Coverage-weighted model-space normal (not normalised).
    normal: vec3<f32>,
};

fn surface3(sp: ZSpecies, views: vec3<u32>, w: vec3<f32>, p: vec3<f32>, lod: f32) -> Surface {
    var out: Surface;
    out.color = vec4<f32>(0.0);
    out.normal = vec3<f32>(0.0);
    for (var i = 0u; i < 3u; i = i + 1u) {
        if (w[i] <= 0.0) {
            continue;
        }
        let uv = view_uv(sp, views[i], p);
        if (!inside(uv)) {
            continue;
        }
        let a = atlas_uv(sp.info.x + views[i], uv, lod);
        let c = textureSampleLevel(atlas_color, atlas_sampler, a.xy, i32(a.z), lod);
        let n = textureSampleLevel(atlas_normal, atlas_sampler, a.xy, i32(a.z), lod).xyz * 2.0 - 1.0;
        out.color = out.color + w[i] * c;
        out.normal = out.normal + (w[i] * c.a) * n;
    }
    return out;
}

// BN12 eq. 8: the empiric hotspot term, amplitude a1, width 1/a2; `v` towards the eye, `l`
// towards the sun.
fn hotspot(v: vec3<f32>, l: vec3<f32>) -> f32 {
    let angle = acos(clamp(dot(v, l), -1.0, 1.0));
    return 1.0 - zp.sun.z * (1.0 - exp(-zp.sun.w * angle));
}

// The per-tree coverage mask (BN12 §8): a pixel (supersample) is covered when the opacity
// exceeds a threshold drawn per (pixel, tree), so n uncorrelated trees of opacity α cover
// 1 − (1 − α)ⁿ; with shared masks (`per_tree_masks = false`, plain alpha to coverage) every
// tree draws the same threshold and they cover α.
fn mask_threshold(pixel: vec2<f32>, base_scale: vec4<f32>, seed: f32) -> f32 {
    var key = 1.0;
    if (zp.sky.w > 0.5) {
        key = 2.0 + fract(seed * 7.31 + base_scale.x * 0.137 + base_scale.z * 0.291) * 4093.0;
    }
    return hash13(vec3<f32>(floor(pixel), key));
}

struct ZFragment {
    @location(0) color: vec4<f32>,
    @builtin(frag_depth) depth: f32,
};

@vertex
fn vs_zfield(in: ZIn, inst: TreeInstance) -> ZOut {
    return z_vertex(in, inst, frame.camera.xyz, false, false);
}

@fragment
fn fs_zfield(in: ZOut) -> ZFragment {
    return z_fragment(in, true);
}

// `blend`: premultiplied "over" in back-to-front order (the camera list sorted), p_v's depth
// still written; no masks.
@fragment
fn fs_zfield_blend(in: ZOut) -> ZFragment {
    return z_fragment(in, false);
}

// BN12 §5 steps 2–4 for the view ray through quad point `p` (model space) along `r`: p_v, the
// point q where iteration 2 sampled (albedo and normal are read there), the opacity α_v and
// ambient occlusion δ_v; `alpha_v` is 0 where the ray misses the tree (iteration 1's opacity
// in `alpha_1`).
struct ZHit {
    pv: vec3<f32>,
    q: vec3<f32>,
    alpha_1: f32,
    alpha_v: f32,
    delta_v: f32,
};

fn z_reconstruct(sp: ZSpecies, views: vec3<u32>, w: vec3<f32>, p: vec3<f32>, r: vec3<f32>, lod: f32) -> ZHit {
    var hit: ZHit;
    hit.pv = p;
    hit.q = p;
    hit.alpha_v = 0.0;
    hit.delta_v = 0.0;
    // Step 3, iteration 1.
    let z1 = zfield3(sp, views, w, p, lod);
    hit.alpha_1 = z1.w;
    if (z1.w < 0.004) {
        return hit;
    }
    hit.q = p + r * plane_distance(sp, z1.x, z1.w);
    // Step 4, iteration 2: p_v, its opacity α_v and ambient occlusion δ_v.
    let z2 = zfield3(sp, views, w, hit.q, lod);
    if (z2.w < 0.004) {
        return hit;
    }
    hit.alpha_v = z2.w;
    hit.pv = p + r * plane_distance(sp, z2.x, z2.w);
    hit.delta_v = clamp(z2.z / z2.w, 0.0, 1.0);
    return hit;
}

// BN12 §5 step 5: the light ray through p_v (model space, towards the sun `lm`) meets the plane
// through o facing the sun at p′ and enters the tree at p_l (one iteration); `tau` is the
// extinction along it (`opacity_scaled_tau`: τ times the optical depth the light view's
// opacity implies, relative to an opaque chord — 1 for dense crowns, less through sparse ones).
struct ZLight {
    pl: vec3<f32>,
    tau: f32,
    // The crown's opacity along the light ray (0 where it misses).
    alpha: f32,
};

fn z_light(sp: ZSpecies, views: vec3<u32>, w: vec3<f32>, pv: vec3<f32>, lm: vec3<f32>, lod: f32) -> ZLight {
    let c = sp.centre_radius.xyz;
    let p1 = pv - lm * dot(pv - c, lm);
    let zl = zfield3(sp, views, w, p1, lod);
    var out: ZLight;
    out.pl = pv;
    out.tau = zp.sun.x;
    out.alpha = zl.w;
    if (zl.w > 0.004) {
        out.pl = p1 - lm * plane_distance(sp, zl.x, zl.w);
        if (zp.atlas.w > 0.5) {
            out.tau = out.tau * log(1.0 - min(zl.w, 0.99)) / log(0.01);
        }
    }
    return out;
}

// The phase function of eq. 7 without `sun_scale`: isotropic, blended by `normal_weight`
// towards the reference's leaf response at normal `n` (Lambert + diffuse transmission).
fn phase_shape(n: vec3<f32>, l: vec3<f32>) -> f32 {
    let ndl = dot(n, l);
    let leaf = max(ndl, 0.0) + zp.atlas.z * max(-ndl, 0.0);
    return mix(1.0, leaf / 0.34, zp.sky.z);
}

// Eq. 9's L_sky: the sky an upward normal sees, blended by `sky_normal_weight` towards what
// the baked normal `n` sees (as `geometry` lights a leaf: seen from the side, a leaf facing
// the eye sees half sky, half ground).
fn sky_shape(n: vec3<f32>) -> vec3<f32> {
    return mix(sky_light(vec3<f32>(0.0, 1.0, 0.0)), sky_light(n), zp.more.x);
}

// Eq. 9's cylindrical hole: the sky seen `d` metres below the crown's top through a forest
// of `density` trees per m².
fn sky_hole(d: f32, density: f32) -> f32 {
    return 1.0 / (1.0 + d * d * density * 0.25);
}

fn z_fragment(in: ZOut, masked: bool) -> ZFragment {
    let sp = z_species[in.views.w];
    // Step 2: p, where the view ray meets the plane through o facing the eye (the quad).
    let p = instance_to_model(in.world, in.base_scale, in.rot);
    let eye = instance_to_model(frame.camera.xyz, in.base_scale, in.rot);
    let r = normalize(p - eye);
    let hit = z_reconstruct(sp, in.views.xyz, in.weights, p, r, in.lod);
    if (hit.alpha_v < 0.004) {
        discard;
    }
    let pv = hit.pv;
    let q = hit.q;
    let alpha_v = hit.alpha_v;
    let delta_v = hit.delta_v;
    let world = instance_to_world(pv, in.base_scale, in.rot);
    // Coverage: presence (LOD cross-fade) by optical depth, the fade into a forest field
    // (linear in opacity, by the tree's own distance: BN12 §7), then the tree's mask.
    let a = presence_alpha(alpha_v, in.rot.w) * field_fade(in.base_scale.xyz, sp.bbox_max.y * in.base_scale.w);
    if (masked && a <= mask_threshold(in.pos.xy, in.base_scale, in.rot.z)) {
        discard;
    }
    if (!masked && a < 0.004) {
        discard;
    }
    let lm = instance_dir_to_model(frame.sun_dir.xyz, in.rot);
    let light = z_light(sp, in.light_views.xyz, in.light_weights, pv, lm, in.lod);
    let pl = light.pl;
    let tau = light.tau;
    let path_m = max(dot(pl - pv, lm), 0.0) * in.base_scale.w;
    let world_l = instance_to_world(pl, in.base_scale, in.rot);
    // Albedo and normal where the second iteration sampled.
    let s = surface3(sp, in.views.xyz, in.weights, q, in.lod);
    let tint = 0.85 + 0.3 * in.rot.z;
    let albedo = s.color.rgb / max(s.color.a, 1e-4) * vec3<f32>(tint, mix(tint, 1.0, 0.5), 1.0);
    let n = normalize(instance_dir_to_world(select(vec3<f32>(0.0, 1.0, 0.0), normalize(s.normal), dot(s.normal, s.normal) > 1e-12), in.rot));
    let l = frame.sun_dir.xyz;
    let v = normalize(frame.camera.xyz - world);
    // Eq. 7: ρ p(v, l) exp(−τ‖p_l − p_v‖) F(v, l) V(p_l) L_sun; the phase function is
    // isotropic (scaled by `sun_scale`), optionally blended towards the reference's leaf
    // response at the baked normal (`normal_weight`).
    let phase = zp.sun.y * phase_shape(n, l);
    // The tree's own crown along the sun is its exp(−τ…) term, not the cascades' (its caster,
    // with the opacity it casts, is in the translucent sum when `shadow_opacity` is on:
    // `zp.extra.z`).
    let own = -log(1.0 - clamp(presence_alpha(light.alpha, in.rot.w) * field_fade(in.base_scale.xyz, sp.bbox_max.y * in.base_scale.w), 0.0, 0.999)) * zp.extra.z;
    let vis = sun_visibility_own(world_l, vec3<f32>(0.0), own);
    let sun = frame.sun_color.rgb * albedo * phase * exp(-tau * path_m) * hotspot(v, l) * vis;
    // Eq. 9: sky × δ_v × the cylindrical hole of the local density Λ_h(x), d below the
    // crown's top, × the slope term (1 + n·u_z)/2 of the ground under the tree — both from the
    // ground cover at the trunk (`ground_cover`); where it holds no tile (or with
    // `density_per_ha` set) the scene's one density and flat ground.
    let top = instance_to_world(sp.bbox_max.xyz, in.base_scale, in.rot).y;
    let d = max(top - world.y, 0.0);
    let cover = ground_cover(in.base_scale.xz);
    let known = cover.w >= 0.0;
    let density = select(zp.sky.y, cover.z, known && zp.extra.y < 0.5);
    let slope = select(1.0, 0.5 * (1.0 + cover.w), known);
    let hole = sky_hole(d, density) * slope;
    let sky = albedo * sky_shape(n) * zp.sky.x * delta_v * hole;
    // Eq. 22–23: towards the forest field's means as the tree recedes (none without one).
    let light_v = field_tree_light(sun, sky, albedo, world, v, l, vis, sp.bbox_max.y * in.base_scale.w);
    let lit = debug_tint(apply_fog(light_v, world), world, TECHNIQUE_ZFIELD);
    var out: ZFragment;
    out.color = select(vec4<f32>(lit * a, a), vec4<f32>(lit, 1.0), masked);
    let clip = frame.view_proj * vec4<f32>(world, 1.0);
    out.depth = clamp(clip.z / max(clip.w, 1e-6), 0.0, 1.0);
    return out;
}

// Shadow casters (BN12 §5): the quad facing the sun, step 5 only, at the max depth z̄ (the
// trees' back side, so they do not shadow their own lit side); opaque where α > ½ (the 3×3
// PCF softens the edges), or with `shadow_opacity` translucent (`fs_zfield_shadow_soft`): the
// crown's optical depth accumulates in the cascades' translucent layers, so what lies behind
// overlapping crowns gets the product of what each lets through (BN12's soft shadows).
@vertex
fn vs_zfield_shadow(in: ZIn, inst: TreeInstance) -> ZOut {
    return z_vertex(in, inst, frame.sun_dir.xyz, true, true);
}

// A caster's opacity (`w`, with the tree's presence and its fade into a forest field) and the
// clip depth of its back side (`z̄`, x) — or opacity 0 where the z-field is empty.
fn caster(in: ZOut) -> vec2<f32> {
    let sp = z_species[in.views.w];
    let p = instance_to_model(in.world, in.base_scale, in.rot);
    let lm = instance_dir_to_model(frame.sun_dir.xyz, in.rot);
    let z = zfield3(sp, in.views.xyz, in.weights, p, in.lod);
    if (z.w < 0.004) {
        return vec2<f32>(0.0);
    }
    let back = p - lm * plane_distance(sp, z.y, z.w);
    let world = instance_to_world(back, in.base_scale, in.rot);
    let a = presence_alpha(z.w, in.rot.w) * field_fade(in.base_scale.xyz, sp.bbox_max.y * in.base_scale.w);
    return vec2<f32>(clip_depth(world), a);
}

@fragment
fn fs_zfield_shadow(in: ZOut) -> ShadowFragment {
    let c = caster(in);
    let sp = z_species[in.views.w];
    // While the tree cross-fades with another technique, or into a forest field (BN12 §7),
    // its shadow fades stochastically by opacity (a threshold hashed per pixel and tree).
    let fading = in.rot.w < 0.999 || field_fade(in.base_scale.xyz, sp.bbox_max.y * in.base_scale.w) < 0.999;
    let threshold = select(0.5, hash13(vec3<f32>(in.pos.xy, 3.0 + 97.0 * in.rot.z)), fading);
    if (c.y <= max(threshold, 0.004)) {
        discard;
    }
    return ShadowFragment(vec4<f32>(1.0), c.x);
}

@fragment
fn fs_zfield_shadow_soft(in: ZOut) -> TranslucentFragment {
    let c = caster(in);
    if (c.y < 0.004) {
        discard;
    }
    return translucent_caster(c.y, c.x);
}
