// The sky behind everything: zenith-to-horizon gradient, ground colour below, and the sun.

struct SkyOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) ndc: vec2<f32>,
};

@vertex
fn vs_sky(@builtin(vertex_index) i: u32) -> SkyOut {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    let ndc = uv * 2.0 - 1.0;
    var out: SkyOut;
    // At the far plane: depth 0 with reversed Z, 1 with standard Z.
    out.pos = vec4<f32>(ndc, frame.main_target.y, 1.0);
    out.ndc = ndc;
    return out;
}

@fragment
fn fs_sky(in: SkyOut) -> @location(0) vec4<f32> {
    // A point on the pixel's ray, just short of the far plane in either depth convention.
    let far = frame.inv_view_proj * vec4<f32>(in.ndc, mix(0.0001, 0.9999, frame.main_target.y), 1.0);
    let dir = normalize(far.xyz / far.w - frame.camera.xyz);
    let h = dir.y;
    var color = mix(frame.sky_horizon.rgb, frame.sky_zenith.rgb, pow(clamp(h, 0.0, 1.0), 0.45));
    if (h < 0.0) {
        color = mix(frame.sky_horizon.rgb, frame.sky_ground.rgb, clamp(-h * 4.0, 0.0, 1.0));
    }
    let s = max(dot(dir, frame.sun_dir.xyz), 0.0);
    color = color + frame.sun_color.rgb * (pow(s, 600.0) * 8.0 + pow(s, 12.0) * 0.08);
    return vec4<f32>(target_output(color), 1.0);
}
