// Shared by every Sylvan shader: the frame uniforms (group 0) and the lighting model.
// Bindings are declared once here; the Rust layouts in `frame.rs` use the same indices.

const CASCADES: u32 = 4u;

struct Frame {
    view_proj: mat4x4<f32>,
    inv_view_proj: mat4x4<f32>,
    cascade_view_proj: array<mat4x4<f32>, 4>,
    // xyz: eye position; w: fog half distance in metres (0 = no fog).
    camera: vec4<f32>,
    // xyz: unit vector towards the sun; w: 1 if shadows are on.
    sun_dir: vec4<f32>,
    // rgb: sun irradiance; w: exposure.
    sun_color: vec4<f32>,
    sky_zenith: vec4<f32>,
    sky_horizon: vec4<f32>,
    sky_ground: vec4<f32>,
    // Far distance (view depth, metres) of each cascade.
    cascade_far: vec4<f32>,
    // x: shadow map texel size (1/resolution); y: time; zw: unused.
    shadow_params: vec4<f32>,
};

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var shadow_map: texture_depth_2d_array;
@group(0) @binding(2) var shadow_sampler: sampler_comparison;

// Fraction of sunlight reaching `world` (1 = lit), 3×3 PCF in the cascade covering it.
fn sun_visibility(world: vec3<f32>, normal_offset: vec3<f32>) -> f32 {
    if (frame.sun_dir.w < 0.5) {
        return 1.0;
    }
    let dist = distance(world, frame.camera.xyz);
    var cascade = CASCADES;
    for (var i = 0u; i < CASCADES; i = i + 1u) {
        if (dist < frame.cascade_far[i]) {
            cascade = i;
            break;
        }
    }
    if (cascade == CASCADES) {
        return 1.0;
    }
    let p = frame.cascade_view_proj[cascade] * vec4<f32>(world + normal_offset * f32(cascade + 1u), 1.0);
    let ndc = p.xyz / p.w;
    let uv = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
    if (any(uv < vec2<f32>(0.0)) || any(uv > vec2<f32>(1.0)) || ndc.z > 1.0) {
        return 1.0;
    }
    let t = frame.shadow_params.x;
    var lit = 0.0;
    for (var y = -1; y <= 1; y = y + 1) {
        for (var x = -1; x <= 1; x = x + 1) {
            lit = lit + textureSampleCompareLevel(shadow_map, shadow_sampler,
                uv + vec2<f32>(f32(x), f32(y)) * t, i32(cascade), ndc.z);
        }
    }
    // Fade out over the last 10% of the last cascade instead of a hard edge.
    let fade = smoothstep(0.9, 1.0, dist / frame.cascade_far[CASCADES - 1u]);
    return mix(lit / 9.0, 1.0, fade);
}

// Hemispherical sky light arriving on a surface with normal `n` (unoccluded).
fn sky_light(n: vec3<f32>) -> vec3<f32> {
    let up = n.y * 0.5 + 0.5;
    let sky = mix(frame.sky_horizon.rgb, frame.sky_zenith.rgb, 0.5);
    return mix(frame.sky_ground.rgb, sky, up);
}

// Exponential distance fog towards the horizon colour, with a little sun in-scatter.
fn apply_fog(color: vec3<f32>, world: vec3<f32>) -> vec3<f32> {
    let half_dist = frame.camera.w;
    if (half_dist <= 0.0) {
        return color;
    }
    let v = world - frame.camera.xyz;
    let d = length(v);
    let f = 1.0 - exp2(-d / half_dist);
    let sun_amount = pow(max(dot(v / d, frame.sun_dir.xyz), 0.0), 8.0);
    let fog = mix(frame.sky_horizon.rgb, frame.sun_color.rgb * 0.35, sun_amount * 0.4);
    return mix(color, fog, f);
}

// Cheap integer hash → [0, 1).
fn hash13(p: vec3<f32>) -> f32 {
    var q = fract(p * 0.1031);
    q = q + dot(q, q.zyx + 31.32);
    return fract((q.x + q.y) * q.z);
}
