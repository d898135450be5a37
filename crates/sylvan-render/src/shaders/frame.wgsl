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
    // x: shadow map texel size (1/resolution); y: time; z: debug view (`DebugView`); w: pixels
    // covered by one metre at one metre in the output image (height / (2 tan(fov_y / 2))).
    shadow_params: vec4<f32>,
    // The main pass's target (`MainTarget`): x: colour output (0 radiance, 1 × exposure,
    // 2 exposure + tone curve); y: depth of the far plane (0 reversed-Z, 1 standard).
    main_target: vec4<f32>,
    // The ground cover (`world/cover.rs`): x tile side (m); y atlas cells per side; z BN12's
    // a3 (eq. 10); w 1 when the ground's sky is occluded.
    cover: vec4<f32>,
    // x trees per m² where no cover tile is held; y mean tree height (m); z distance where
    // trees end (m); w the stored density's top (trees per m²).
    cover_extra: vec4<f32>,
    // x the cover's texel side (m); y its mip levels (down to a texel a tile).
    cover_lod: vec4<f32>,
};

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var shadow_map: texture_depth_2d_array;
@group(0) @binding(2) var shadow_sampler: sampler_comparison;
// Main passes only (the shadow passes' group 0 holds the uniforms alone).
@group(0) @binding(3) var cover_atlas: texture_2d<f32>;
@group(0) @binding(4) var cover_tags: texture_2d<u32>;
@group(0) @binding(5) var cover_sampler: sampler;
// The cascades' translucent layer (BN12 §5's soft shadows, `PassKind::ShadowTranslucent`):
// r Σσ, g Σσz, b n over the n translucent casters in front of the opaque ones (σ = −ln(1 − α),
// z their depth), a the nearest one's depth (1: none).
@group(0) @binding(6) var shadow_translucent: texture_2d_array<f32>;

// An opaque shadow caster's output: its depth (location 0 is not written).
struct ShadowFragment {
    @location(0) unused: vec4<f32>,
    @builtin(frag_depth) depth: f32,
};

// A translucent shadow caster's output (`PassKind::ShadowTranslucent`): σ, σz, 1 (summed) and
// its depth (alpha, the nearest kept by `Min`); the depth attachment only tests it against
// the opaque casters.
struct TranslucentFragment {
    @location(0) layer: vec4<f32>,
    @builtin(frag_depth) depth: f32,
};

// A translucent caster of opacity `alpha` at clip depth `depth`.
fn translucent_caster(alpha: f32, depth: f32) -> TranslucentFragment {
    let sigma = -log(1.0 - clamp(alpha, 0.0, 0.999));
    return TranslucentFragment(vec4<f32>(sigma, sigma * depth, 1.0, depth), depth);
}

// The depth buffer's value at a world point (this pass's projection), clamped to [0, 1]: for
// fragment stages that write the depth of the point they show.
fn clip_depth(world: vec3<f32>) -> f32 {
    let clip = frame.view_proj * vec4<f32>(world, 1.0);
    return clamp(clip.z / clip.w, 0.0, 1.0);
}

// An opaque caster's colour output (not written: `PassKind::Shadow`'s targets have empty write
// masks; kept so that casters that test coverage and discard have one fragment signature).
fn opaque_caster() -> vec4<f32> {
    return vec4<f32>(1.0);
}

@fragment
fn fs_shadow_opaque() -> @location(0) vec4<f32> {
    return opaque_caster();
}

// The optical depth of the translucent casters in front of a receiver at depth `z` behind the
// nearest one (at `front`), from their sums `od` (Σσ, Σσz, n): the n casters are taken as
// spread evenly along the sun from `front` to the end their σ-weighted mean depth implies
// (2 mean − front), so a receiver between crowns gets the share in front of it and one behind
// them all (the ground under a stand) gets every one. One caster: all of it.
fn translucent_depth(od: vec3<f32>, front: f32, z: f32) -> f32 {
    if (od.z <= 1.001) {
        return od.x;
    }
    let mean = od.y / max(od.x, 1e-6);
    let span = max(2.0 * (mean - front), 0.0);
    let layer = span / (od.z - 1.0);
    return od.x * clamp((z - front + layer) / max(span + layer, 1e-9), 0.0, 1.0);
}

// The shadow cascade covering `world` (by view distance), or CASCADES beyond the last one.
fn cascade_index(world: vec3<f32>) -> u32 {
    let dist = distance(world, frame.camera.xyz);
    for (var i = 0u; i < CASCADES; i = i + 1u) {
        if (dist < frame.cascade_far[i]) {
            return i;
        }
    }
    return CASCADES;
}

// Fraction of sunlight reaching `world` (1 = lit), 3×3 PCF in the cascade covering it: 0
// behind an opaque caster, behind translucent ones the light they let through.
fn sun_visibility(world: vec3<f32>, normal_offset: vec3<f32>) -> f32 {
    return sun_visibility_own(world, normal_offset, 0.0);
}

// `sun_visibility` of a point inside a translucent caster of optical depth `own` along the sun
// (a z-field tree's light entry point: its own crown is in the texel's sum, and its own
// shadowing is the tree's own term), which is taken out of the sum.
fn sun_visibility_own(world: vec3<f32>, normal_offset: vec3<f32>, own: f32) -> f32 {
    if (frame.sun_dir.w < 0.5) {
        return 1.0;
    }
    let dist = distance(world, frame.camera.xyz);
    let cascade = cascade_index(world);
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
    let size = vec2<f32>(textureDimensions(shadow_translucent).xy);
    var lit = 0.0;
    for (var y = -1; y <= 1; y = y + 1) {
        for (var x = -1; x <= 1; x = x + 1) {
            let tap = uv + vec2<f32>(f32(x), f32(y)) * t;
            let open = textureSampleCompareLevel(shadow_map, shadow_sampler, tap, i32(cascade), ndc.z);
            // Behind the nearest translucent caster (with a margin for its 16-bit depth), the
            // light the translucent casters in front let through (BN12 §5: opacity in the
            // shadow maps for soft shadows).
            let texel = clamp(vec2<i32>(tap * size), vec2<i32>(0), vec2<i32>(size) - 1);
            let layer = textureLoad(shadow_translucent, texel, i32(cascade), 0);
            var through = 1.0;
            if (ndc.z > layer.a * (1.0 + 1e-3)) {
                through = exp(-max(translucent_depth(layer.rgb, layer.a, ndc.z) - own, 0.0));
            }
            lit = lit + open * through;
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

// The ground cover at world (x, z) (`world/cover.rs`): x Γ, the share covered by crowns seen
// from above; y Γ̄, its local mean; z Λ_h, trees per m² around; w the terrain's n·u_z. Where no
// tile is held: Γ = Γ̄ = 0, the scene's mean density, w = -1 (unknown). Main passes only.
fn ground_cover(xz: vec2<f32>) -> vec4<f32> {
    let fallback = vec4<f32>(0.0, 0.0, frame.cover_extra.x, -1.0);
    if (frame.cover.w < 0.5) {
        return fallback;
    }
    let n = i32(frame.cover.y);
    let tile = vec2<i32>(floor(xz / frame.cover.x));
    let cell = ((tile % n) + vec2<i32>(n)) % n;
    let tag = textureLoad(cover_tags, cell, 0).r;
    if (any(tile < vec2<i32>(0)) || tag != u32(tile.x) + u32(tile.y) * 65536u + 1u) {
        return fallback;
    }
    let t = textureSampleLevel(cover_atlas, cover_sampler, xz / (frame.cover.x * frame.cover.y), 0.0);
    return vec4<f32>(t.r, t.g, t.b * t.b * frame.cover_extra.w, t.a);
}

// The cover's Γ (x) and Γ̄ (y) at ground point `xz`, filtered over `footprint` metres (the
// atlas's mip at that size: BN12 §4's quadtree of coverage below the world's tile), and z how
// much of the detail the coarsest level still keeps (0 there: its texel is a whole tile); w −1
// where no tile is held.
fn ground_cover_filtered(xz: vec2<f32>, footprint: f32) -> vec4<f32> {
    let c = ground_cover(xz);
    if (c.w < 0.0) {
        return vec4<f32>(0.0, 0.0, 0.0, -1.0);
    }
    let top = frame.cover_lod.y - 1.0;
    let lod = clamp(log2(max(footprint, 1e-6) / frame.cover_lod.x), 0.0, top);
    let t = textureSampleLevel(cover_atlas, cover_sampler, xz / (frame.cover.x * frame.cover.y), lod);
    return vec4<f32>(t.r, t.g, clamp(top - lod, 0.0, 1.0), 1.0);
}

// Fades the ground cover's effect out where trees end (`[world] tree_distance_m`, over its
// last 10 %, as the trees' presence does).
fn ground_cover_weight(world: vec3<f32>) -> f32 {
    let end = frame.cover_extra.z;
    return 1.0 - smoothstep(end * 0.9, end, distance(world, frame.camera.xyz));
}

// BN12 eq. 10: Δ = 1 − a3 (Γ − Γ̄), darker under crowns and brighter between them, averaging
// to 1 (Γ̄ is Γ's local mean); 1 where the cover is off or trees end.
fn ground_contrast(world: vec3<f32>) -> f32 {
    return mix(1.0, cover_delta(ground_cover(world.xz)), ground_cover_weight(world));
}

// Eq. 10's Δ of a `ground_cover` sample, unfaded.
fn cover_delta(c: vec4<f32>) -> f32 {
    return max(1.0 - frame.cover.z * (c.x - c.y), 0.0);
}

// The share of its open sky the ground at `world` sees through the trees (BN12 eq. 12 without
// the slope, which `sky_light` has): δ_g Δ, with δ_g the ambient occlusion at the bottom of
// eq. 9's cylindrical hole as deep as the mean tree (1 / (1 + H² Λ_h / 4)) for the local
// density — BN12 takes δ_g from its table 𝔻 (§6), which only a shader-map has; 1 where the
// cover is off.
fn ground_sky(world: vec3<f32>) -> f32 {
    if (frame.cover.w < 0.5) {
        return 1.0;
    }
    let c = ground_cover(world.xz);
    let h = frame.cover_extra.y;
    let delta_g = 1.0 / (1.0 + h * h * c.z * 0.25);
    let occluded = clamp(delta_g * cover_delta(c), 0.0, 1.0);
    return mix(1.0, occluded, ground_cover_weight(world));
}

// Exponential distance fog towards the horizon colour, with a little sun in-scatter:
// rgb the fog colour, a the fog fraction at `world`.
fn fog_at(world: vec3<f32>) -> vec4<f32> {
    let half_dist = frame.camera.w;
    if (half_dist <= 0.0) {
        return vec4<f32>(0.0);
    }
    let v = world - frame.camera.xyz;
    let d = length(v);
    let f = 1.0 - exp2(-d / half_dist);
    let sun_amount = pow(max(dot(v / max(d, 1e-6), frame.sun_dir.xyz), 0.0), 8.0);
    let fog = mix(frame.sky_horizon.rgb, frame.sun_color.rgb * 0.35, sun_amount * 0.4);
    return vec4<f32>(fog, f);
}

fn apply_fog(color: vec3<f32>, world: vec3<f32>) -> vec3<f32> {
    let fog = fog_at(world);
    return mix(color, fog.rgb, fog.a);
}

// The same for a premultiplied colour of coverage `alpha`.
fn apply_fog_premultiplied(color: vec3<f32>, alpha: f32, world: vec3<f32>) -> vec3<f32> {
    let fog = fog_at(world);
    return mix(color, fog.rgb * alpha, fog.a);
}

// Crown self-occlusion for the sky term, from a model-space point's place in the plant's
// bounding box: points deep inside the crown see less sky. Shared by every tree technique so
// that they all shade like the reference.
fn crown_occlusion(p: vec3<f32>, bbox_min: vec3<f32>, bbox_max: vec3<f32>) -> f32 {
    let centre = (bbox_min + bbox_max) * 0.5;
    let half_extent = max((bbox_max - bbox_min) * 0.5, vec3<f32>(1e-3));
    let q = (p - centre) / half_extent;
    let radial = clamp(length(q.xz), 0.0, 1.0);
    let height = clamp((p.y - bbox_min.y) / (2.0 * half_extent.y), 0.0, 1.0);
    return clamp(0.35 + 0.45 * radial + 0.3 * height, 0.0, 1.0);
}

// Cheap integer hash → [0, 1).
fn hash13(p: vec3<f32>) -> f32 {
    var q = fract(p * 0.1031);
    q = q + dot(q, q.zyx + 31.32);
    return fract((q.x + q.y) * q.z);
}

// A tree instance (`GpuTreeInstance` in `instances.rs`), the one per-tree vertex layout: every
// per-tree technique's vertex entry points take it as their second input.
struct TreeInstance {
    // xyz: trunk base (world); w: uniform scale from plant units to metres.
    @location(4) base_scale: vec4<f32>,
    // x: cos(rotation about Y); y: sin(rotation); z: tint seed in [0, 1); w: presence in [0, 1]
    // (1: whole; less during a level-of-detail transition).
    @location(5) rot: vec4<f32>,
};

// A model-space direction in world space (the instance's rotation about Y).
fn instance_dir_to_world(d: vec3<f32>, rot: vec4<f32>) -> vec3<f32> {
    return vec3<f32>(rot.x * d.x + rot.y * d.z, d.y, -rot.y * d.x + rot.x * d.z);
}

// A world direction in model space (the inverse rotation).
fn instance_dir_to_model(d: vec3<f32>, rot: vec4<f32>) -> vec3<f32> {
    return vec3<f32>(rot.x * d.x - rot.y * d.z, d.y, rot.y * d.x + rot.x * d.z);
}

// Where an image-based caster's quad can have coverage from one baked view. The quad faces
// `a` through the frames' centre, with axes `right` and `up` (model space); the view images
// the box (centre `mid` relative to the frames' centre, half sides `half`) along `f`. A quad
// point p shows what lies on the line through it along f, shifted along a by up to `slack`
// (parallax; 0 without), so it can be covered only inside the box's oblique projection along
// f onto the quad's plane — the box's extent along `right − a (f·right)/(f·a)` (and likewise
// up) — widened by the shift's image `slack (f·right, f·up)/(f·a)`. Returns (lo.xy, hi.xy)
// in model units along (right, up); w < lo.x when the view is too oblique to bound (f·a <
// 0.05).
fn caster_view_extent(mid: vec3<f32>, half: vec3<f32>, right: vec3<f32>, up: vec3<f32>, a: vec3<f32>, f: vec3<f32>, slack: f32) -> vec4<f32> {
    let fa = dot(f, a);
    if (fa < 0.05) {
        return vec4<f32>(1.0, 1.0, -1.0, -1.0);
    }
    let t = vec2<f32>(dot(f, right), dot(f, up)) / fa;
    let wr = right - a * t.x;
    let wu = up - a * t.y;
    let c = vec2<f32>(dot(mid, wr), dot(mid, wu));
    let e = vec2<f32>(dot(half, abs(wr)), dot(half, abs(wu))) + abs(t) * slack;
    return vec4<f32>(c - e, c + e);
}

// A model-space point (plant units) in world space.
fn instance_to_world(p: vec3<f32>, base_scale: vec4<f32>, rot: vec4<f32>) -> vec3<f32> {
    return instance_dir_to_world(p * base_scale.w, rot) + base_scale.xyz;
}

// A world point in model space (plant units).
fn instance_to_model(p: vec3<f32>, base_scale: vec4<f32>, rot: vec4<f32>) -> vec3<f32> {
    return instance_dir_to_model(p - base_scale.xyz, rot) / base_scale.w;
}

// The opacity of a texel of coverage `alpha` drawn with presence `presence` during a
// level-of-detail cross-fade: by optical depth, so two levels fading over each other keep the
// object's coverage (`1 − (1 − α)^w`; α capped below 1 so a fading opaque texel still fades).
fn presence_alpha(alpha: f32, presence: f32) -> f32 {
    return 1.0 - pow(1.0 - min(alpha, 0.995), presence);
}

// Debug views (`frame.shadow_params.z`, `DebugView` in Rust): 0 none, 1 colour by technique,
// 2 colour by shadow cascade, 3 coverage (trees white, terrain black).
const DEBUG_TECHNIQUE: u32 = 1u;
const DEBUG_CASCADES: u32 = 2u;
const DEBUG_COVERAGE: u32 = 3u;

fn debug_mode() -> u32 {
    return u32(frame.shadow_params.z + 0.5);
}

// `technique_color(id)` and the `TECHNIQUE_<NAME>` ids are generated from the technique
// registry and prepended to this file (`registry::wgsl_prelude`).

fn cascade_color(cascade: u32) -> vec3<f32> {
    switch cascade {
        case 0u: { return vec3<f32>(1.0, 0.15, 0.15); }
        case 1u: { return vec3<f32>(0.15, 1.0, 0.15); }
        case 2u: { return vec3<f32>(0.2, 0.4, 1.0); }
        case 3u: { return vec3<f32>(1.0, 0.9, 0.1); }
        default: { return vec3<f32>(1.0, 1.0, 1.0); }
    }
}

// ACES filmic fit (Narkowicz 2015), the same curve as Sylvan's resolve.
fn tone_curve(x: vec3<f32>) -> vec3<f32> {
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), vec3<f32>(0.0), vec3<f32>(1.0));
}

// A shaded linear radiance as the main target takes it (`frame.main_target.x`): as is for
// Sylvan's own HDR target (its resolve exposes and tone-maps), exposed for a caller's HDR
// target, exposed and tone-mapped for a caller's LDR target.
fn target_output(color: vec3<f32>) -> vec3<f32> {
    let mode = u32(frame.main_target.x + 0.5);
    if (mode == 0u) {
        return color;
    }
    let exposed = color * frame.sun_color.w;
    if (mode == 1u) {
        return exposed;
    }
    return tone_curve(exposed);
}

// Applies the frame's debug view to a shaded colour at `world`, then the target's output
// mapping (`target_output`): every main-pass shader ends its colour here. `technique` is the drawing
// technique's id (`TECHNIQUE_<NAME>`, from the registry), or -1 for terrain (drawn grey in the technique view).
fn debug_tint(color: vec3<f32>, world: vec3<f32>, technique: i32) -> vec3<f32> {
    return target_output(debug_colour(color, world, technique));
}

fn debug_colour(color: vec3<f32>, world: vec3<f32>, technique: i32) -> vec3<f32> {
    let mode = debug_mode();
    let luma = dot(color, vec3<f32>(0.2126, 0.7152, 0.0722));
    if (mode == DEBUG_TECHNIQUE) {
        if (technique < 0) {
            return vec3<f32>(luma * 0.6);
        }
        return technique_color(technique) * (0.15 + 1.5 * luma);
    }
    if (mode == DEBUG_CASCADES) {
        let c = cascade_index(world);
        if (c == CASCADES) {
            return color;
        }
        return mix(color, cascade_color(c) * (0.2 + 1.5 * luma), 0.6);
    }
    if (mode == DEBUG_COVERAGE) {
        return vec3<f32>(select(1.0, 0.0, technique < 0));
    }
    return color;
}

// `debug_tint` for a level-of-detail technique: in the "technique" view, level 0 (coarsest)
// is the technique's colour and each finer level is paler.
fn debug_tint_lod(color: vec3<f32>, world: vec3<f32>, technique: i32, level: u32) -> vec3<f32> {
    let mode = debug_mode();
    if (mode == DEBUG_TECHNIQUE) {
        let luma = dot(color, vec3<f32>(0.2126, 0.7152, 0.0722));
        let c = mix(technique_color(technique), vec3<f32>(1.0), min(f32(level) * 0.3, 0.75));
        return target_output(c * (0.15 + 1.5 * luma));
    }
    return debug_tint(color, world, technique);
}
