// Technique `geometry`: full tree meshes, instanced per species. Wood is opaque; leaves are
// alpha-tested and two-sided, lit by the sun from the front and by transmission from behind.
// Bind group 1: `bindings.wgsl`.

struct PlantIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) color: vec3<f32>,
    @builtin(vertex_index) vertex: u32,
};

struct PlantOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) color: vec3<f32>,
    // x: ambient occlusion estimate from the position in the crown.
    @location(4) ao: f32,
    // x: the instance's presence; y: this leaf's hash in [0, 1) (a leaf is 4 vertices).
    @location(5) @interpolate(flat) keep: vec2<f32>,
};

// During a level-of-detail transition a leaf is drawn when its hash is below the presence,
// so leaves appear one by one instead of the whole set popping.
fn leaf_dropped(keep: vec2<f32>) -> bool {
    return keep.y >= keep.x;
}

// The instance's presence (`inst.rot.w`) keeps that fraction of the leaves during a
// level-of-detail transition.
fn instance_transform(in: PlantIn, inst: TreeInstance) -> PlantOut {
    let world = instance_to_world(in.position, inst.base_scale, inst.rot);
    let n = instance_dir_to_world(in.normal, inst.rot);
    var out: PlantOut;
    out.pos = frame.view_proj * vec4<f32>(world, 1.0);
    out.world = world;
    out.normal = n;
    out.uv = in.uv;
    let tint = 0.85 + 0.3 * inst.rot.z;
    out.color = in.color * vec3<f32>(tint, mix(tint, 1.0, 0.5), 1.0);
    // Crown self-occlusion for the sky term.
    out.ao = crown_occlusion(in.position, species.bbox_min.xyz, species.bbox_max.xyz);
    let leaf = f32(in.vertex / max(u32(species.bbox_min.w), 1u));
    out.keep = vec2<f32>(inst.rot.w, hash13(vec3<f32>(leaf, leaf * 0.37 + 11.0, inst.rot.z * 97.0)));
    return out;
}

@vertex
fn vs_plant(in: PlantIn, inst: TreeInstance) -> PlantOut {
    return instance_transform(in, inst);
}

// During a transition the wood is kept on the share of its pixels that the leaves are kept
// (screen-door, per pixel): wood drawn whole inside a crown drawn at part of its leaves showed
// through it (a pine's leader standing above its fading billboard).
fn wood_dropped(in: PlantOut) -> bool {
    return in.keep.x < 1.0 && hash13(vec3<f32>(in.pos.xy, 7.0 + 97.0 * in.keep.y)) >= in.keep.x;
}

@fragment
fn fs_wood(in: PlantOut) -> @location(0) vec4<f32> {
    let n = normalize(in.normal);
    let l = frame.sun_dir.xyz;
    let ndl = max(dot(n, l), 0.0);
    let vis = select(sun_visibility(in.world, n * 0.05), 0.0, ndl <= 0.0);
    if (wood_dropped(in)) {
        discard;
    }
    let light = frame.sun_color.rgb * ndl * vis + sky_light(n) * in.ao;
    return vec4<f32>(debug_tint(apply_fog(in.color * light, in.world), in.world, TECHNIQUE_GEOMETRY), 1.0);
}

fn leaf_sample(uv: vec2<f32>) -> vec4<f32> {
    return textureSample(leaf_texture, leaf_sampler, uv);
}

@fragment
fn fs_leaf(in: PlantOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    // Derivatives and samples first, in uniform control flow.
    let dp_dx = dpdx(in.world);
    let dp_dy = dpdy(in.world);
    let duv_dx = dpdx(in.uv);
    let duv_dy = dpdy(in.uv);
    let tex = leaf_sample(in.uv);
    let back = textureSample(leaf_back, leaf_sampler, in.uv);
    let bump = textureSample(leaf_normal_map, leaf_sampler, in.uv).rgb;
    if (tex.a < 0.5 || leaf_dropped(in.keep)) {
        discard;
    }
    // Seen from behind: the back image, and the bent normal turned round.
    var n = leaf_bumped_normal(normalize(in.normal), dp_dx, dp_dy, duv_dx, duv_dy, bump);
    var rgb = tex.rgb;
    if (!front) {
        n = -n;
        rgb = back.rgb;
    }
    let l = frame.sun_dir.xyz;
    let ndl = dot(n, l);
    let vis = sun_visibility(in.world, vec3<f32>(0.0));
    let albedo = rgb * in.color;
    // Front: Lambert. Back: diffuse transmission through the thin leaf, yellower.
    let translucency = species.bbox_max.w;
    let transmitted = albedo * vec3<f32>(1.1, 1.25, 0.55) * translucency * max(-ndl, 0.0);
    let direct = frame.sun_color.rgb * (albedo * max(ndl, 0.0) + transmitted) * vis;
    let ambient = albedo * sky_light(n) * in.ao;
    return vec4<f32>(debug_tint(apply_fog(direct + ambient, in.world), in.world, TECHNIQUE_GEOMETRY), 1.0);
}

// Shadow casters: wood writes depth only; leaves discard by alpha.
struct ShadowOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) @interpolate(flat) keep: vec2<f32>,
};

@vertex
fn vs_plant_shadow(in: PlantIn, inst: TreeInstance) -> ShadowOut {
    let t = instance_transform(in, inst);
    var out: ShadowOut;
    out.pos = t.pos;
    out.uv = t.uv;
    out.keep = t.keep;
    return out;
}

@fragment
fn fs_leaf_shadow(in: ShadowOut) -> @location(0) vec4<f32> {
    if (textureSampleLevel(leaf_texture, leaf_sampler, in.uv, 0.0).a < 0.5 || leaf_dropped(in.keep)) {
        discard;
    }
    return opaque_caster();
}
