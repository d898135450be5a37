// Technique `hbt` (MNP01 §4.1, §4.2, appendix): per billboard (a tree, or an object of an
// opened tree), the 9 BTF images of the 3 view samples × 3 light samples enclosing the eye and
// sun directions, summed with their weights in one fragment, plus the 3 ambient images; lit by
// the sun times the visibility cube-maps' transmittance (interpolated from the box's 8
// corners) and the sky times their sky term; composited premultiplied over the background.
// Bind group 1: `bindings.wgsl`.

struct HbtIn {
    @builtin(vertex_index) vertex: u32,
    // Rows of the model → world affine map (a similarity).
    @location(4) m0: vec4<f32>,
    @location(5) m1: vec4<f32>,
    @location(6) m2: vec4<f32>,
    // xyz: the 3 view samples; w: image set.
    @location(7) views: vec4<u32>,
    // xyz: the 3 light samples.
    @location(8) lights: vec4<u32>,
    // Pair weights w[3·view + light], row-major.
    @location(9) w0: vec4<f32>,
    @location(10) w1: vec4<f32>,
    @location(11) w2: vec4<f32>,
    // Sun (xy) and sky (zw) transmittance at the box's 8 corners, unorm8 × 4 each.
    @location(12) vis: vec4<u32>,
    // x tint seed, y presence, z uniform scale, w world bounding radius.
    @location(13) extra: vec4<f32>,
};

struct HbtOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) world: vec3<f32>,
    // Model-space point on the quad.
    @location(1) model: vec3<f32>,
    @location(2) @interpolate(flat) views: vec4<u32>,
    @location(3) @interpolate(flat) lights: vec4<u32>,
    @location(4) @interpolate(flat) w0: vec4<f32>,
    @location(5) @interpolate(flat) w1: vec4<f32>,
    @location(6) @interpolate(flat) w2: vec4<f32>,
    // x: first view row, y: end row (cross: one row per quad); z: unused.
    @location(7) @interpolate(flat) rows: vec4<u32>,
    // x: tint seed; y: presence; z: uniform scale; w: world bounding radius.
    @location(8) @interpolate(flat) extra: vec4<f32>,
    // Mip level: log2 of (a pixel's footprint on the quad / a texel), computed per vertex
    // (implicit derivatives are wrong along triangle edges on llvmpipe; see boxtree).
    @location(9) lod: f32,
    @location(10) @interpolate(flat) vis: vec4<u32>,
    // The box centre in world space (where the object's own shadow caster stands).
    @location(11) @interpolate(flat) centre: vec3<f32>,
};

fn hbt_to_world(p: vec3<f32>, in: HbtIn) -> vec3<f32> {
    let q = vec4<f32>(p, 1.0);
    return vec3<f32>(dot(in.m0, q), dot(in.m1, q), dot(in.m2, q));
}

// World direction → model space, up to scale (the transpose of a similarity's linear part).
fn hbt_to_model_dir(d: vec3<f32>, in: HbtIn) -> vec3<f32> {
    return in.m0.xyz * d.x + in.m1.xyz * d.y + in.m2.xyz * d.z;
}

// Trilinear interpolation of 8 unorm8 corner values (corner k: bit 0 x, bit 1 y, bit 2 z).
fn corners8(lo: u32, hi: u32, q: vec3<f32>) -> f32 {
    let a = unpack4x8unorm(lo);
    let b = unpack4x8unorm(hi);
    let y0 = mix(vec2<f32>(a.x, b.x), vec2<f32>(a.y, b.y), q.x);
    let y1 = mix(vec2<f32>(a.z, b.z), vec2<f32>(a.w, b.w), q.x);
    let z = mix(y0, y1, q.y);
    return mix(z.x, z.y, q.z);
}

fn pair_weight(in: HbtOut, k: u32) -> f32 {
    if (k < 4u) {
        return in.w0[k];
    }
    if (k < 8u) {
        return in.w1[k - 4u];
    }
    return in.w2[k - 8u];
}

fn hidden() -> HbtOut {
    var out: HbtOut;
    out.pos = vec4<f32>(0.0, 0.0, -2.0, 1.0);
    return out;
}

// A quad through the box centre: facing `toward` (world; a point when `is_dir` is false) for
// facing projection, or the frame of view row `quad` for cross projection.
fn hbt_vertex(in: HbtIn, toward_world: vec3<f32>, view_proj: mat4x4<f32>, is_dir: bool, cross_mode: bool) -> HbtOut {
    let sp = species_info[in.views.w];
    let quad = in.vertex / 6u;
    let corner = in.vertex % 6u;
    let lo = sp.min.xyz;
    let hi = sp.max.xyz;
    let centre = (lo + hi) * 0.5;
    let h = (hi - lo) * 0.5;
    var u: vec3<f32>;
    var v: vec3<f32>;
    var hu: f32;
    var hv: f32;
    var rows = vec4<u32>(0u, 3u, 0u, 0u);
    if (cross_mode) {
        var ws = array<f32, 9>(in.w0.x, in.w0.y, in.w0.z, in.w0.w, in.w1.x, in.w1.y, in.w1.z, in.w1.w, in.w2.x);
        if (quad >= 3u) {
            return hidden();
        }
        let a = ws[quad * 3u] + ws[quad * 3u + 1u] + ws[quad * 3u + 2u];
        if (a <= 0.0) {
            return hidden();
        }
        let fr = frames[sp.info.w + in.views[quad]];
        u = fr.u.xyz;
        v = fr.v.xyz;
        hu = fr.u.w;
        hv = fr.v.w;
        rows = vec4<u32>(quad, quad + 1u, 0u, 0u);
    } else {
        if (quad > 0u) {
            return hidden();
        }
        var toward = toward_world;
        if (!is_dir) {
            toward = toward_world - hbt_to_world(centre, in);
        }
        let f = normalize(hbt_to_model_dir(toward, in));
        let up = select(vec3<f32>(0.0, 0.0, 1.0), vec3<f32>(0.0, 1.0, 0.0), abs(f.y) < 0.99);
        v = normalize(up - f * dot(up, f));
        u = cross(v, f);
        // The box's projection along f (as `PlaneFrame::for_box`), a little wider so the
        // samples' frames (baked with a free border) are covered.
        hu = dot(abs(u), h) * 1.1;
        hv = dot(abs(v), h) * 1.1;
    }
    let st = array<vec2<f32>, 6>(
        vec2<f32>(0.0, 1.0), vec2<f32>(1.0, 1.0), vec2<f32>(1.0, 0.0),
        vec2<f32>(0.0, 1.0), vec2<f32>(1.0, 0.0), vec2<f32>(0.0, 0.0),
    )[corner];
    let model = centre + u * ((2.0 * st.x - 1.0) * hu) + v * ((1.0 - 2.0 * st.y) * hv);
    let world = hbt_to_world(model, in);
    var out: HbtOut;
    out.pos = view_proj * vec4<f32>(world, 1.0);
    out.world = world;
    out.model = model;
    out.views = in.views;
    out.lights = in.lights;
    out.w0 = in.w0;
    out.w1 = in.w1;
    out.w2 = in.w2;
    out.rows = rows;
    out.extra = in.extra;
    out.vis = in.vis;
    out.centre = hbt_to_world(centre, in);
    // A texel is 2·half/tile metres of the image framing the box (≈ the quad's extent).
    let texel_m = 2.0 * max(dot(abs(u), h), dot(abs(v), h)) * in.extra.z / f32(atlas.tiles.x);
    var pixel_m = 0.0;
    if (is_dir) {
        // Shadow maps: orthographic, one texel per shadow-map texel.
        let row_x = vec3<f32>(view_proj[0].x, view_proj[1].x, view_proj[2].x);
        pixel_m = frame.shadow_params.x * 2.0 / max(length(row_x), 1e-6);
    } else {
        pixel_m = distance(world, frame.camera.xyz) / max(frame.shadow_params.w, 1.0);
    }
    let bias = select(atlas.params.w, 0.0, is_dir);
    out.lod = max(log2(pixel_m / max(texel_m, 1e-6)) + bias, 0.0);
    return out;
}

// Image coordinates of a model-space point in view sample `view`'s frame; outside [0, 1]²
// the image is empty.
fn sample_uv(sp: HbtSet, view: u32, model: vec3<f32>) -> vec2<f32> {
    let fr = frames[sp.info.w + view];
    let q = model - (sp.min.xyz + sp.max.xyz) * 0.5;
    return vec2<f32>(dot(q, fr.u.xyz) / fr.u.w * 0.5 + 0.5, 0.5 - dot(q, fr.v.xyz) / fr.v.w * 0.5);
}

fn fetch(tile: u32, uv: vec2<f32>, lod: f32) -> vec4<f32> {
    let per_row = atlas.tiles.y;
    let in_layer = tile % atlas.tiles.z;
    let cell = vec2<f32>(f32(in_layer % per_row), f32(in_layer / per_row));
    // Keep the bilinear footprint inside this tile at the coarser mip sampled.
    let half = 0.5 * exp2(ceil(lod)) / f32(atlas.tiles.x);
    let a = (cell + clamp(uv, vec2<f32>(half), vec2<f32>(1.0 - half))) * atlas.params.xy;
    return textureSampleLevel(atlas_color, atlas_sampler, a, i32(tile / atlas.tiles.z), lod);
}

fn inside(uv: vec2<f32>) -> bool {
    return all(uv >= vec2<f32>(0.0)) && all(uv <= vec2<f32>(1.0));
}

@vertex
fn vs_hbt(in: HbtIn) -> HbtOut {
    return hbt_vertex(in, frame.camera.xyz, frame.view_proj, false, atlas.tiles.w == 1u);
}

@fragment
fn fs_hbt(in: HbtOut) -> @location(0) vec4<f32> {
    let sp = species_info[in.views.w];
    let lod = in.lod;
    let lights = sp.info.y;
    let views = sp.counts.x;
    var direct = vec4<f32>(0.0);
    var sky = vec3<f32>(0.0);
    var ground = vec3<f32>(0.0);
    var rows_weight = 0.0;
    for (var i = in.rows.x; i < in.rows.y; i = i + 1u) {
        let view = in.views[i];
        let uv = sample_uv(sp, view, in.model);
        let a = pair_weight(in, 3u * i) + pair_weight(in, 3u * i + 1u) + pair_weight(in, 3u * i + 2u);
        rows_weight = rows_weight + a;
        if (a <= 0.0 || !inside(uv)) {
            continue;
        }
        // Every image of a view sample has the same coverage: where the sky image is empty,
        // the others are too (most of the quad), so they are not fetched.
        let sky_texel = fetch(sp.info.z + view, uv, lod);
        if (sky_texel.a < 0.002) {
            continue;
        }
        for (var j = 0u; j < 3u; j = j + 1u) {
            let w = pair_weight(in, 3u * i + j);
            if (w > 0.0) {
                direct = direct + w * fetch(sp.info.x + view * lights + in.lights[j], uv, lod);
            }
        }
        sky = sky + a * sky_texel.rgb;
        ground = ground + a * fetch(sp.info.z + views + view, uv, lod).rgb;
    }
    // Presence (a level's share during a transition) scales optical depth, not opacity: two
    // levels cross-fading over each other keep the object's coverage, where scaling opacity
    // thinned it (one pine mid-switch: 44 % less darkening against the sky than the reference).
    var alpha = presence_alpha(direct.a, in.extra.y);
    if (in.rows.y - in.rows.x == 1u) {
        // Cross projection: this plane carries the fraction `rows_weight` of the object, as
        // optical depth (as boxtree's planes), so planes over each other add up to the image's
        // opacity rather than to a third of it each.
        let cover = direct.a / max(rows_weight, 1e-6);
        alpha = presence_alpha(cover, rows_weight * in.extra.y);
    }
    if (alpha < 0.002) {
        discard;
    }
    let tint = 0.85 + 0.3 * in.extra.x;
    let tint3 = vec3<f32>(tint, mix(tint, 1.0, 0.5), 1.0);
    // MNP01 §4.2: the visibility cube-maps' transmittance, interpolated across the box: the
    // sky term always, the sun unless it comes from the cascades.
    let q = clamp((in.model - sp.min.xyz) / max(sp.max.xyz - sp.min.xyz, vec3<f32>(1e-6)),
        vec3<f32>(0.0), vec3<f32>(1.0));
    let sky_vis = corners8(in.vis.z, in.vis.w, q);
    var vis = corners8(in.vis.x, in.vis.y, q);
    if (atlas.params.z > 0.5) {
        // Received shadow from the cascades (its own shadowing is in the BTF): the billboard
        // point taken towards the sun just past the plane of the object's own caster (the
        // sun-facing quad through its centre), so that its own caster does not shadow it
        // again, while neighbours standing between it and the sun still do, point by point.
        let l = frame.sun_dir.xyz;
        let past = max(-dot(in.world - in.centre, l), 0.0) + atlas.shading.x * in.extra.w;
        vis = sun_visibility(in.world + l * past, vec3<f32>(0.0));
    }
    let sky_color = mix(frame.sky_horizon.rgb, frame.sky_zenith.rgb, 0.5);
    // The sums are premultiplied by `direct.a`; rescale them to the output's opacity.
    let lit = tint3 * (alpha / max(direct.a, 1e-6)) * (frame.sun_color.rgb * vis * direct.rgb
        + sky_color * sky * sky_vis + frame.sky_ground.rgb * ground);
    let fogged = apply_fog_premultiplied(lit, alpha, in.world);
    return vec4<f32>(debug_tint_lod(fogged / alpha, in.world, TECHNIQUE_HBT, in.lights.w) * alpha, alpha);
}

// Shadow casters: the quad facing the sun, each texel occluding with probability equal to the
// reconstructed coverage seen from the sun (the 3×3 PCF turns that into soft shadow).
@vertex
fn vs_hbt_shadow(in: HbtIn) -> HbtOut {
    return hbt_vertex(in, frame.sun_dir.xyz, frame.view_proj, true, false);
}

@fragment
fn fs_hbt_shadow(in: HbtOut) -> @location(0) vec4<f32> {
    let sp = species_info[in.views.w];
    let lod = in.lod;
    var alpha = 0.0;
    for (var i = 0u; i < 3u; i = i + 1u) {
        let view = in.views[i];
        let uv = sample_uv(sp, view, in.model);
        let a = pair_weight(in, 3u * i) + pair_weight(in, 3u * i + 1u) + pair_weight(in, 3u * i + 2u);
        if (a > 0.0 && inside(uv)) {
            alpha = alpha + a * fetch(sp.info.z + view, uv, lod).a;
        }
    }
    // The tree's tint seed decorrelates the thresholds of overlapping trees.
    if (presence_alpha(alpha, in.extra.y) <= hash13(vec3<f32>(in.pos.xy, 3.0 + 97.0 * in.extra.x))) {
        discard;
    }
    return opaque_caster();
}
