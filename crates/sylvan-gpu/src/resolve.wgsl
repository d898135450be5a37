// Box-filter resolve of a supersampled linear HDR image, then tone mapping to the output
// (an sRGB target: the hardware applies the sRGB transfer on store).

struct Params {
    factor: u32,
    exposure: f32,
    _pad: vec2<f32>,
};

@group(0) @binding(0) var src: texture_2d<f32>;
@group(0) @binding(1) var<uniform> params: Params;

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // One triangle covering the viewport.
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

// ACES filmic fit (Narkowicz 2015): keeps highlights soft, saturates gently.
fn aces(x: vec3<f32>) -> vec3<f32> {
    let a = 2.51;
    let b = 0.03;
    let c = 2.43;
    let d = 0.59;
    let e = 0.14;
    return clamp((x * (a * x + b)) / (x * (c * x + d) + e), vec3<f32>(0.0), vec3<f32>(1.0));
}

@fragment
fn fs_main(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let f = params.factor;
    let base = vec2<u32>(pos.xy) * f;
    var sum = vec3<f32>(0.0);
    for (var y = 0u; y < f; y = y + 1u) {
        for (var x = 0u; x < f; x = x + 1u) {
            // Tone-map each sample, then average: antialiased edges between bright sky and
            // dark foliage look right on screen (averaging HDR first lets the sky win).
            sum = sum + aces(textureLoad(src, vec2<i32>(base + vec2<u32>(x, y)), 0).rgb * params.exposure);
        }
    }
    return vec4<f32>(sum / f32(f * f), 1.0);
}
