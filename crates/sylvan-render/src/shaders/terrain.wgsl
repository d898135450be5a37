// Terrain: a height grid lit by sun (Lambert, cascaded shadows) and hemispherical sky light,
// occluded by the trees around (BN12 eq. 10–12, `ground_sky`).

struct TerrainIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
};

struct TerrainOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
};

@vertex
fn vs_terrain(in: TerrainIn) -> TerrainOut {
    var out: TerrainOut;
    out.pos = frame.view_proj * vec4<f32>(in.position, 1.0);
    out.world = in.position;
    out.normal = in.normal;
    return out;
}

@vertex
fn vs_terrain_shadow(in: TerrainIn) -> @builtin(position) vec4<f32> {
    return frame.view_proj * vec4<f32>(in.position, 1.0);
}

// Value noise for ground colour variation (no texture needed).
fn vnoise(p: vec2<f32>) -> f32 {
    let i = floor(p);
    let f = fract(p);
    let u = f * f * (3.0 - 2.0 * f);
    let a = hash13(vec3<f32>(i, 0.0));
    let b = hash13(vec3<f32>(i + vec2<f32>(1.0, 0.0), 0.0));
    let c = hash13(vec3<f32>(i + vec2<f32>(0.0, 1.0), 0.0));
    let d = hash13(vec3<f32>(i + vec2<f32>(1.0, 1.0), 0.0));
    return mix(mix(a, b, u.x), mix(c, d, u.x), u.y);
}

// The ground's linear albedo at `world` with normal `n`: meadow to forest-floor tones varied
// at two scales, rock where steep (shared with `shadermap`'s `fs_terrain_forest`).
fn terrain_albedo(world: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let variation = vnoise(world.xz * 0.02) * 0.6 + vnoise(world.xz * 0.11) * 0.4;
    let grass = mix(vec3<f32>(0.040, 0.058, 0.018), vec3<f32>(0.085, 0.080, 0.036), variation);
    let rock = vec3<f32>(0.13, 0.12, 0.105);
    let steep = smoothstep(0.72, 0.55, n.y);
    return mix(grass, rock, steep);
}

@fragment
fn fs_terrain(in: TerrainOut) -> @location(0) vec4<f32> {
    let n = normalize(in.normal);
    let albedo = terrain_albedo(in.world, n);
    let l = frame.sun_dir.xyz;
    let ndl = max(dot(n, l), 0.0);
    let vis = select(sun_visibility(in.world, n * 0.15), 0.0, ndl <= 0.0);
    let light = frame.sun_color.rgb * ndl * vis + sky_light(n) * ground_sky(in.world);
    return vec4<f32>(debug_tint(apply_fog(albedo * light, in.world), in.world, -1), 1.0);
}
