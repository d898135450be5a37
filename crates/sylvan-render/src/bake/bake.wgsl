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
    return out;
}

fn facing(n: vec3<f32>, view: u32) -> vec3<f32> {
    let m = normalize(n);
    return select(m, -m, dot(m, views[view].to_camera.xyz) < 0.0);
}

@fragment
fn fs_bake_leaf(in: VOut) -> Targets {
    let tex = textureSample(leaf_texture, leaf_sampler, in.uv);
    if (tex.a < 0.5) {
        discard;
    }
    var out: Targets;
    out.albedo = vec4<f32>(tex.rgb * in.color, 1.0);
    out.normal_depth = vec4<f32>(facing(in.normal, in.view), clamp(in.depth, 0.0, 1.0));
    return out;
}

@fragment
fn fs_bake_wood(in: VOut) -> Targets {
    var out: Targets;
    out.albedo = vec4<f32>(in.color, 1.0);
    out.normal_depth = vec4<f32>(normalize(in.normal), clamp(in.depth, 0.0, 1.0));
    return out;
}
