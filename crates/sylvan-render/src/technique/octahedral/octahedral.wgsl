// Technique `octahedral`: one camera-facing quad per tree, textured from the 3 baked views of
// the hemi-octahedral grid nearest the view direction, each sampled where it saw the pixel's
// ray (plane intersection + depth parallax), blended premultiplied and lit per pixel with the
// reference model (albedo, normal and depth are baked; light is not).
// Bind group 1: `bindings.wgsl`.

struct OctIn {
    @builtin(vertex_index) vertex: u32,
};

struct OctOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) world: vec3<f32>,
    // The 3 views (grid index j·grid + i) and the species.
    @location(1) @interpolate(flat) views: vec4<u32>,
    @location(2) @interpolate(flat) weights: vec3<f32>,
    // Instance: trunk base and scale; cos, sin, tint seed, presence.
    @location(3) @interpolate(flat) base_scale: vec4<f32>,
    @location(4) @interpolate(flat) rot: vec4<f32>,
    @location(5) @interpolate(flat) lod: f32,
};

// Mirrors `bake::hemi_oct_encode`: direction (y ≥ 0) → [-1, 1]².
fn hemi_oct_encode(d: vec3<f32>) -> vec2<f32> {
    let p = d.xz / max(abs(d.x) + max(d.y, 0.0) + abs(d.z), 1e-9);
    return vec2<f32>(p.x + p.y, p.x - p.y);
}

struct Pick {
    views: vec3<u32>,
    weights: vec3<f32>,
};

// Mirrors `bake::view_weights`: the grid triangle containing `d` and its barycentric weights;
// with `nearest`, only the grid view nearest `d`.
fn pick_views(d: vec3<f32>, nearest: bool) -> Pick {
    let grid = atlas.tiles.w;
    let n = f32(grid - 1u);
    let g = clamp((hemi_oct_encode(d) + 1.0) * 0.5 * n, vec2<f32>(0.0), vec2<f32>(n));
    var out: Pick;
    if (nearest) {
        let r = vec2<u32>(round(g));
        out.views = vec3<u32>(r.y * grid + r.x, 0u, 0u);
        out.weights = vec3<f32>(1.0, 0.0, 0.0);
        return out;
    }
    let cell = min(floor(g), vec2<f32>(n - 1.0));
    let f = g - cell;
    let k = u32(cell.y) * grid + u32(cell.x);
    if (f.x + f.y < 1.0) {
        out.views = vec3<u32>(k, k + 1u, k + grid);
        out.weights = vec3<f32>(1.0 - f.x - f.y, f.x, f.y);
    } else {
        out.views = vec3<u32>(k + grid + 1u, k + 1u, k + grid);
        out.weights = vec3<f32>(f.x + f.y - 1.0, 1.0 - f.y, 1.0 - f.x);
    }
    return out;
}

fn hidden() -> OctOut {
    var out: OctOut;
    out.pos = vec4<f32>(0.0, 0.0, -2.0, 1.0);
    return out;
}

// The quad of one tree facing `toward` (the eye, or the sun when `is_dir`), the views seen
// from there and the mip level.
fn oct_vertex(in: OctIn, inst_in: TreeInstance, toward_world: vec3<f32>, is_dir: bool) -> OctOut {
    // Every species is in one list: the instance's rot.z is species + tint seed.
    let species = u32(floor(inst_in.rot.z));
    var inst = inst_in;
    inst.rot.z = fract(inst_in.rot.z);
    let sp = oct_species[species];
    let centre = instance_to_world(sp.centre_radius.xyz, inst.base_scale, inst.rot);
    let radius = sp.centre_radius.w * inst.base_scale.w;
    var a = toward_world;
    var grow = 1.0;
    var dist = 0.0;
    if (!is_dir) {
        let e = toward_world - centre;
        dist = length(e);
        a = e / max(dist, 1e-6);
        // The sphere's silhouette on the plane through its centre, seen in perspective.
        grow = min(dist / sqrt(max(dist * dist - radius * radius, 1e-6)), 4.0);
        if (dist <= radius * 1.03) {
            grow = 4.0;
        }
    }
    // The view direction in the tree's frame, folded onto the upper hemisphere.
    var d = instance_dir_to_model(a, inst.rot);
    d.y = max(d.y, 0.0);
    d = select(vec3<f32>(0.0, 1.0, 0.0), normalize(d), dot(d, d) > 1e-12);
    let pick = pick_views(d, is_dir || atlas.draw.y < 2.0);
    let right = select(vec3<f32>(1.0, 0.0, 0.0), normalize(cross(vec3<f32>(0.0, 1.0, 0.0), a)), abs(a.y) < 0.9999);
    let up = cross(a, right);
    let st = array<vec2<f32>, 6>(
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, 1.0), vec2<f32>(-1.0, 1.0),
    )[in.vertex % 6u];
    // A texel is 2·radius/tile metres; a pixel covers dist / pixels_per_metre (camera) or one
    // shadow-map texel (sun).
    let texel_m = 2.0 * radius / f32(atlas.tiles.x);
    var pixel_m = dist / max(frame.shadow_params.w, 1.0);
    if (is_dir) {
        let row_x = vec3<f32>(frame.view_proj[0].x, frame.view_proj[1].x, frame.view_proj[2].x);
        pixel_m = frame.shadow_params.x * 2.0 / max(length(row_x), 1e-6);
    }
    let lod = max(log2(pixel_m / texel_m), 0.0);
    var world = centre + (right * st.x + up * st.y) * radius * grow;
    if (is_dir && atlas.draw.w > 0.5) {
        // A caster covers only what its view can show (`caster_view_extent`), its parallax
        // moving the sample along the sun's ray by up to (R + |p − c|·sin θ)/(f·a) — |p − c|
        // at most √2 R on the quad — widened by the mips' spread (2 · 2^⌈lod⌉ + 2 image
        // texels) and 2 shadow texels; in model units, within the bounding square.
        let r = sp.centre_radius.w;
        let am = instance_dir_to_model(a, inst.rot);
        let f = oct_views[pick.views.x].f.xyz;
        let fa = dot(f, am);
        let slack = r * (1.0 + 1.4143 * sqrt(max(1.0 - fa * fa, 0.0))) / max(fa, 0.2);
        let half = 0.5 * (sp.bbox_max.xyz - sp.bbox_min.xyz);
        let mid = 0.5 * (sp.bbox_max.xyz + sp.bbox_min.xyz) - sp.centre_radius.xyz;
        let e = caster_view_extent(mid, half, instance_dir_to_model(right, inst.rot), instance_dir_to_model(up, inst.rot), am, f, slack);
        if (e.z >= e.x) {
            let margin = (texel_m * (2.0 * exp2(ceil(lod)) + 2.0) + 2.0 * pixel_m) / inst.base_scale.w;
            let lo = clamp(e.xy - margin, vec2<f32>(-r), vec2<f32>(r)) * inst.base_scale.w;
            let hi = clamp(e.zw + margin, vec2<f32>(-r), vec2<f32>(r)) * inst.base_scale.w;
            let corner = select(lo, hi, st > vec2<f32>(0.0));
            world = centre + right * corner.x + up * corner.y;
        }
    }
    var out: OctOut;
    out.pos = frame.view_proj * vec4<f32>(world, 1.0);
    out.world = world;
    out.views = vec4<u32>(pick.views, species);
    out.weights = pick.weights;
    out.base_scale = inst.base_scale;
    out.rot = inst.rot;
    out.lod = lod;
    return out;
}

// Atlas coordinates of image point `uv` of `tile`, kept inside the tile at the coarser of
// the two mips sampled (tiles are packed edge to edge). Explicit mips: llvmpipe's derivatives
// are wrong along triangle edges.
fn atlas_uv(tile: u32, uv: vec2<f32>, lod: f32) -> vec3<f32> {
    let in_layer = tile % atlas.tiles.z;
    let cell = vec2<f32>(f32(in_layer % atlas.tiles.y), f32(in_layer / atlas.tiles.y));
    let half = 0.5 * exp2(ceil(lod)) / f32(atlas.tiles.x);
    let at = (cell + clamp(uv, vec2<f32>(half), vec2<f32>(1.0 - half))) * atlas.params.yz;
    return vec3<f32>(at, f32(tile / atlas.tiles.z));
}

fn fetch_normal(tile: u32, uv: vec2<f32>, lod: f32) -> vec4<f32> {
    let a = atlas_uv(tile, uv, lod);
    return textureSampleLevel(atlas_normal, atlas_sampler, a.xy, i32(a.z), lod);
}

fn fetch_color(tile: u32, uv: vec2<f32>, lod: f32) -> vec4<f32> {
    let a = atlas_uv(tile, uv, lod);
    return textureSampleLevel(atlas_color, atlas_sampler, a.xy, i32(a.z), lod);
}

struct OctSample {
    // Premultiplied albedo, coverage (0 where the ray leaves the image).
    color: vec4<f32>,
    // Model-space unit normal.
    normal: vec3<f32>,
    // Model-space surface point on the ray.
    point: vec3<f32>,
};

// View `k` of species `sp` seen along the model-space ray `p + t·r`: where the ray meets the
// view's plane, then `steps` times moved to the point of the ray at the height the baked
// depth gives under the current sample (depth 0 is `radius` towards the view, 1 `radius` away).
fn view_sample(sp: OctSpecies, k: u32, p: vec3<f32>, r: vec3<f32>, lod: f32) -> OctSample {
    let view = oct_views[k];
    let c = sp.centre_radius.xyz;
    let radius = sp.centre_radius.w;
    let tile = sp.info.x + k;
    // The ray runs against f (towards the view's far side); keep oblique rays bounded.
    let denom = min(dot(r, view.f.xyz), -0.2);
    let base = dot(c - p, view.f.xyz);
    var h = 0.0;
    var x = p + r * (base / denom);
    var uv = vec2<f32>(0.5 + 0.5 * dot(x - c, view.u.xyz) / radius, 0.5 - 0.5 * dot(x - c, view.v.xyz) / radius);
    let steps = u32(atlas.draw.x);
    for (var s = 0u; s < steps; s = s + 1u) {
        h = radius * (1.0 - 2.0 * fetch_normal(tile, uv, lod).w);
        x = p + r * ((base + h) / denom);
        uv = vec2<f32>(0.5 + 0.5 * dot(x - c, view.u.xyz) / radius, 0.5 - 0.5 * dot(x - c, view.v.xyz) / radius);
    }
    var out: OctSample;
    out.point = x;
    if (any(uv < vec2<f32>(0.0)) || any(uv > vec2<f32>(1.0))) {
        out.color = vec4<f32>(0.0);
        out.normal = view.f.xyz;
        return out;
    }
    out.color = fetch_color(tile, uv, lod);
    out.normal = fetch_normal(tile, uv, lod).xyz * 2.0 - 1.0;
    return out;
}

@vertex
fn vs_octahedral(in: OctIn, inst: TreeInstance) -> OctOut {
    return oct_vertex(in, inst, frame.camera.xyz, false);
}

@fragment
fn fs_octahedral(in: OctOut) -> @location(0) vec4<f32> {
    let sp = oct_species[in.views.w];
    let p = instance_to_model(in.world, in.base_scale, in.rot);
    let r = normalize(instance_dir_to_model(in.world - frame.camera.xyz, in.rot));
    var color = vec4<f32>(0.0);
    var normal = vec3<f32>(0.0);
    var point = vec3<f32>(0.0);
    for (var i = 0u; i < 3u; i = i + 1u) {
        let w = in.weights[i];
        if (w <= 0.0) {
            continue;
        }
        let s = view_sample(sp, in.views[i], p, r, in.lod);
        color = color + w * s.color;
        normal = normal + (w * s.color.a) * s.normal;
        point = point + (w * s.color.a) * s.point;
    }
    let alpha = color.a;
    if (alpha < 0.004) {
        discard;
    }
    let a = presence_alpha(alpha, in.rot.w);
    if (a < 0.002) {
        discard;
    }
    let model = point / alpha;
    let n = normalize(instance_dir_to_world(select(vec3<f32>(0.0, 1.0, 0.0), normalize(normal), dot(normal, normal) > 1e-12), in.rot));
    let world = instance_to_world(model, in.base_scale, in.rot);
    let tint = 0.85 + 0.3 * in.rot.z;
    let albedo = color.rgb * vec3<f32>(tint, mix(tint, 1.0, 0.5), 1.0);
    let l = frame.sun_dir.xyz;
    let ndl = dot(n, l);
    let vis = sun_visibility(world, vec3<f32>(0.0));
    let transmitted = albedo * vec3<f32>(1.1, 1.25, 0.55) * atlas.params.x * max(-ndl, 0.0);
    let direct = frame.sun_color.rgb * (albedo * max(ndl, 0.0) + transmitted) * vis;
    let ambient = albedo * sky_light(n) * crown_occlusion(model, sp.bbox_min.xyz, sp.bbox_max.xyz);
    let fogged = apply_fog_premultiplied(direct + ambient, alpha, world);
    // Debug view "technique": octahedral is index 7 of `TechniqueKind::ALL`.
    let lit = debug_tint(fogged / alpha, world, TECHNIQUE_OCTAHEDRAL) * alpha;
    return vec4<f32>(lit * (a / alpha), a);
}

// Shadow casters: the quad facing the sun, textured from the grid view nearest the sun; each
// texel occludes with probability equal to its coverage (3×3 PCF softens it) at the depth of
// the parallaxed surface, pushed a little away from the sun.
@vertex
fn vs_octahedral_shadow(in: OctIn, inst: TreeInstance) -> OctOut {
    return oct_vertex(in, inst, frame.sun_dir.xyz, true);
}

@fragment
fn fs_octahedral_shadow(in: OctOut) -> ShadowFragment {
    let sp = oct_species[in.views.w];
    let p = instance_to_model(in.world, in.base_scale, in.rot);
    let r = -instance_dir_to_model(frame.sun_dir.xyz, in.rot);
    let s = view_sample(sp, in.views.x, p, r, in.lod);
    if (presence_alpha(s.color.a, in.rot.w) <= hash13(vec3<f32>(in.pos.xy, 3.0 + 97.0 * in.rot.z))) {
        discard;
    }
    let offset = atlas.draw.z * sp.centre_radius.w * in.base_scale.w;
    let world = instance_to_world(s.point, in.base_scale, in.rot) - frame.sun_dir.xyz * offset;
    return ShadowFragment(opaque_caster(), clip_depth(world));
}
