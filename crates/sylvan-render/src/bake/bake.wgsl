// The shared baker: a plant's leaves and wood rendered orthographically into one tile per
// view. Target 0: (albedo, 1) where a surface is hit; target 1: (normal facing the camera,
// depth in [0, 1]). The view comes from the instance index (one draw per view).

struct BakeView {
    view_proj: mat4x4<f32>,
    // xyz: unit vector from the box towards the camera.
    to_camera: vec4<f32>,
};

@group(0) @binding(0) var<storage, read> views: array<BakeView>;
@group(0) @binding(1) var leaf_texture: texture_2d<f32>;
@group(0) @binding(2) var leaf_sampler: sampler;
// The back side of the leaves and their normal map (`shaders/leaf.wgsl`, prepended).
@group(0) @binding(3) var leaf_back: texture_2d<f32>;
@group(0) @binding(4) var leaf_normal_map: texture_2d<f32>;

struct VIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) color: vec3<f32>,
    @builtin(instance_index) view: u32,
};

struct VOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) uv: vec2<f32>,
    @location(2) color: vec3<f32>,
    @location(3) depth: f32,
    @location(4) @interpolate(flat) view: u32,
    // The plant-space position (for the normal map's tangent frame).
    @location(5) model: vec3<f32>,
};

struct Targets {
    @location(0) albedo: vec4<f32>,
    @location(1) normal_depth: vec4<f32>,
};

@vertex
fn vs_bake(in: VIn) -> VOut {
    var out: VOut;
    out.pos = views[in.view].view_proj * vec4<f32>(in.position, 1.0);
    out.normal = in.normal;
    out.uv = in.uv;
    out.color = in.color;
    out.depth = out.pos.z;
    out.view = in.view;
    out.model = in.position;
    return out;
}

fn facing(n: vec3<f32>, view: u32) -> vec3<f32> {
    let m = normalize(n);
    return select(m, -m, dot(m, views[view].to_camera.xyz) < 0.0);
}

// A leaf as `geometry` shades it: the front or, seen from behind, the back image, and the
// normal bent by the normal map then turned towards the camera.
@fragment
fn fs_bake_leaf(in: VOut) -> Targets {
    let dp_dx = dpdx(in.model);
    let dp_dy = dpdy(in.model);
    let duv_dx = dpdx(in.uv);
    let duv_dy = dpdy(in.uv);
    let tex = textureSample(leaf_texture, leaf_sampler, in.uv);
    let back = textureSample(leaf_back, leaf_sampler, in.uv);
    let bump = textureSample(leaf_normal_map, leaf_sampler, in.uv).rgb;
    if (tex.a < 0.5) {
        discard;
    }
    let n = normalize(in.normal);
    let behind = dot(n, views[in.view].to_camera.xyz) < 0.0;
    let bent = leaf_bumped_normal(n, dp_dx, dp_dy, duv_dx, duv_dy, bump);
    var out: Targets;
    out.albedo = vec4<f32>(select(tex.rgb, back.rgb, behind) * in.color, 1.0);
    out.normal_depth = vec4<f32>(select(bent, -bent, behind), clamp(in.depth, 0.0, 1.0));
    return out;
}

@fragment
fn fs_bake_wood(in: VOut) -> Targets {
    var out: Targets;
    out.albedo = vec4<f32>(in.color, 1.0);
    out.normal_depth = vec4<f32>(normalize(in.normal), clamp(in.depth, 0.0, 1.0));
    return out;
}
