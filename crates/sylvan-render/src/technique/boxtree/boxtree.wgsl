// Technique `boxtree` (LCV04 §4): a box's images drawn on its planes through the box centre,
// lit per texel with the same model as the geometry (albedo, normal and depth are baked; light
// is not), blended back to front with premultiplied alpha.
// Bind group 1: `bindings.wgsl`.

struct ImpostorIn {
    @builtin(vertex_index) vertex: u32,
    // With the tree instance (`TreeInstance`, locations 4 and 5): the box drawn.
    @location(6) box_index: u32,
};

struct ImpostorOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) world: vec3<f32>,
    // Model-space point on the plane.
    @location(2) model: vec3<f32>,
    // x: box; y: plane; z: side (1 front, 0 back).
    @location(3) @interpolate(flat) ids: vec3<u32>,
    // x: presence × plane weight; y: tint seed; z: cos; w: sin.
    @location(4) @interpolate(flat) weight: vec4<f32>,
    // The tree's uniform scale.
    @location(5) @interpolate(flat) scale: f32,
    // The plane normal as drawn (model space; turned towards the viewer for a billboard).
    @location(6) @interpolate(flat) axis: vec3<f32>,
    // Mip level: log2 of (screen footprint of a pixel on the plane / texel size).
    @location(7) lod: f32,
};

// One plane's corner; `toward` is the model-space unit direction the box is seen from (the
// eye, or the sun for shadows). Each plane's optical depth is weighted by (toward·f)², the
// weights normalised to sum to 1, so a plane seen edge-on vanishes and one seen face-on
// carries the whole box (exact along the baked directions).
fn impostor_vertex(in: ImpostorIn, inst: TreeInstance, toward_world: vec3<f32>, view_proj: mat4x4<f32>, is_dir: bool) -> ImpostorOut {
    var out: ImpostorOut;
    let b = boxes[in.box_index];
    let plane = in.vertex / 6u;
    let corner = in.vertex % 6u;
    if (plane >= b.info.z) {
        out.pos = vec4<f32>(0.0, 0.0, -2.0, 1.0);
        return out;
    }
    var p = b.planes[plane];
    var toward = toward_world;
    if (!is_dir) {
        toward = toward_world - instance_to_world(b.planes[0].centre.xyz, inst.base_scale, inst.rot);
    }
    let d = normalize(instance_dir_to_model(toward, inst.rot));
    var w = 1.0;
    var c = 1.0;
    if ((b.info.w & 1u) == 1u) {
        // Billboard: turn the plane about Y to face the viewer.
        let h = vec2<f32>(d.x, d.z);
        let f = select(vec3<f32>(0.0, 0.0, 1.0), normalize(vec3<f32>(h.x, 0.0, h.y)), dot(h, h) > 1e-8);
        p.f = vec4<f32>(f, 0.0);
        p.u = vec4<f32>(cross(p.v.xyz, f), p.u.w);
    } else {
        var total = 0.0;
        for (var i = 0u; i < b.info.z; i = i + 1u) {
            let ci = dot(d, b.planes[i].f.xyz);
            total = total + ci * ci;
        }
        c = dot(d, p.f.xyz);
        w = c * c / max(total, 1e-6);
    }
    // A plane seen (almost) edge-on contributes nothing: skip its fragments entirely. Shadow
    // maps (3×3 PCF, stochastic coverage) skip planes carrying under a tenth of the box.
    if (w * inst.rot.w < select(0.01, 0.1, is_dir)) {
        out.pos = vec4<f32>(0.0, 0.0, -2.0, 1.0);
        return out;
    }
    let st = array<vec2<f32>, 6>(
        vec2<f32>(0.0, 1.0), vec2<f32>(1.0, 1.0), vec2<f32>(1.0, 0.0),
        vec2<f32>(0.0, 1.0), vec2<f32>(1.0, 0.0), vec2<f32>(0.0, 0.0),
    )[corner];
    let model = p.centre.xyz + p.u.xyz * ((2.0 * st.x - 1.0) * p.u.w) + p.v.xyz * ((1.0 - 2.0 * st.y) * p.v.w);
    let world = instance_to_world(model, inst.base_scale, inst.rot);
    out.pos = view_proj * vec4<f32>(world, 1.0);
    // A texel is 2·half/tile metres; a pixel at distance D covers D / pixels_per_metre metres,
    // stretched by 1/|cos| across a plane seen obliquely.
    let texel_m = 2.0 * max(p.u.w, p.v.w) * inst.base_scale.w / f32(atlas.tiles.x);
    var pixel_m = 0.0;
    if (is_dir) {
        // Shadow maps: orthographic, one texel per shadow-map texel of the first cascade.
        let row_x = vec3<f32>(frame.view_proj[0].x, frame.view_proj[1].x, frame.view_proj[2].x);
        pixel_m = frame.shadow_params.x * 2.0 / max(length(row_x), 1e-6);
    } else {
        pixel_m = distance(world, frame.camera.xyz) / max(frame.shadow_params.w, 1.0);
    }
    out.lod = max(log2(pixel_m / (texel_m * max(abs(c), 0.2))), 0.0);
    out.uv = st;
    out.world = world;
    out.model = model;
    out.ids = vec3<u32>(in.box_index, plane, select(0u, 1u, c >= 0.0));
    out.weight = vec4<f32>(w * inst.rot.w, inst.rot.z, inst.rot.x, inst.rot.y);
    out.scale = inst.base_scale.w;
    out.axis = p.f.xyz;
    return out;
}

struct Texel {
    // Premultiplied albedo, coverage.
    color: vec4<f32>,
    // Unit normal (model space, facing the viewer's side), depth in the box.
    normal_depth: vec4<f32>,
    // Which image: 1 front, 0 back, 2 front seen mirrored from behind.
    image: u32,
};

fn fetch(in: ImpostorOut) -> Texel {
    let b = boxes[in.ids.x];
    let sides = b.info.y;
    var image = 1u;
    var tile = b.info.x + in.ids.y * sides;
    if (in.ids.z == 0u) {
        if (sides == 2u) {
            tile = tile + 1u;
            image = 0u;
        } else {
            image = 2u;
        }
    }
    let per_row = atlas.tiles.y;
    let in_layer = tile % atlas.tiles.z;
    let cell = vec2<f32>(f32(in_layer % per_row), f32(in_layer / per_row));
    // Explicit level of detail (implicit derivatives are wrong along triangle edges on
    // llvmpipe, which drew every quad edge as a line of the tile's average colour). Tiles are
    // packed edge to edge and tightly framed, so the bilinear footprint is also kept inside
    // this tile at the coarser of the two mips sampled, or neighbours would bleed in.
    let half = 0.5 * exp2(ceil(in.lod)) / f32(atlas.tiles.x);
    let uv = (cell + clamp(in.uv, vec2<f32>(half), vec2<f32>(1.0 - half))) * atlas.params.yz;
    let layer = i32(tile / atlas.tiles.z);
    var t: Texel;
    t.color = textureSampleLevel(atlas_color, atlas_sampler, uv, layer, in.lod);
    t.normal_depth = textureSampleLevel(atlas_normal, atlas_sampler, uv, layer, in.lod);
    t.image = image;
    return t;
}

@vertex
fn vs_impostor(in: ImpostorIn, inst: TreeInstance) -> ImpostorOut {
    return impostor_vertex(in, inst, frame.camera.xyz, frame.view_proj, false);
}

@fragment
fn fs_impostor(in: ImpostorOut) -> @location(0) vec4<f32> {
    let t = fetch(in);
    let alpha = t.color.a;
    if (alpha < 0.004) {
        discard;
    }
    // The plane's opacity: the texel's optical depth scaled by the plane's weight × presence.
    let a = presence_alpha(alpha, in.weight.x);
    if (a < 0.002) {
        discard;
    }
    let b = boxes[in.ids.x];
    let p = b.planes[in.ids.y];
    var n = normalize(t.normal_depth.xyz * 2.0 - 1.0);
    let f = in.axis;
    if ((b.info.w & 1u) == 1u) {
        // Billboard: the image was baked from +Z; turn its normals with the quad.
        n = vec3<f32>(n.x * f.z + n.z * f.x, n.y, -n.x * f.x + n.z * f.z);
    }
    if (t.image == 2u) {
        // Mirrored use of the front image: reflect the normal through the plane.
        n = n - 2.0 * dot(n, f) * f;
    }
    // Where the texel's surface is: on the plane, moved along f by its baked depth.
    let side = select(-1.0, 1.0, t.image != 0u);
    let model = in.model + f * side * p.centre.w * (1.0 - 2.0 * t.normal_depth.w);
    let rot = vec4<f32>(in.weight.z, in.weight.w, 0.0, 0.0);
    let world = in.world + instance_dir_to_world(model - in.model, rot) * in.scale;
    let nw = normalize(instance_dir_to_world(n, rot));

    let tint = 0.85 + 0.3 * in.weight.y;
    let albedo = t.color.rgb * vec3<f32>(tint, mix(tint, 1.0, 0.5), 1.0);
    let l = frame.sun_dir.xyz;
    let ndl = dot(nw, l);
    let vis = sun_visibility(world, vec3<f32>(0.0));
    let transmitted = albedo * vec3<f32>(1.1, 1.25, 0.55) * atlas.params.x * max(-ndl, 0.0);
    let direct = frame.sun_color.rgb * (albedo * max(ndl, 0.0) + transmitted) * vis;
    let ambient = albedo * sky_light(nw) * crown_occlusion(model, b.plant_min.xyz, b.plant_max.xyz);
    // Fog on premultiplied colour: the fog colour enters with this texel's coverage.
    let fogged = apply_fog_premultiplied(direct + ambient, alpha, world);
    // Debug view "technique": impostors in the boxtree colour, paler for finer boxes (opened
    // geometry stays geometry's colour).
    let lit = debug_tint_lod(fogged / alpha, world, TECHNIQUE_BOXTREE, b.info.w >> 1u) * alpha;
    return vec4<f32>(lit * (a / alpha), a);
}

// Stochastic (screen-door) opacity for the shadow maps: a texel occludes with probability
// equal to its plane opacity seen from the sun; the 3×3 PCF turns that into soft shadow.
@vertex
fn vs_impostor_shadow(in: ImpostorIn, inst: TreeInstance) -> ImpostorOut {
    return impostor_vertex(in, inst, frame.sun_dir.xyz, frame.view_proj, true);
}

@fragment
fn fs_impostor_shadow(in: ImpostorOut) -> @location(0) vec4<f32> {
    let t = fetch(in);
    let a = presence_alpha(t.color.a, in.weight.x);
    if (a <= hash13(vec3<f32>(in.pos.xy, f32(in.ids.y) * 7.0))) {
        discard;
    }
    return opaque_caster();
}
