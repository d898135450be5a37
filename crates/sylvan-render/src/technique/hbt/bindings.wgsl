// `hbt`'s bind group 1, declared once: the Rust layout in this folder uses the same binding
// indices. Prepended to `hbt.wgsl` (after the frame's group 0).

struct HbtSet {
    // xyz: plant bounding box minimum (model space); w: bounding-sphere radius.
    min: vec4<f32>,
    // xyz: maximum.
    max: vec4<f32>,
    // x: first direct tile; y: light samples; z: first ambient tile; w: first sample frame.
    info: vec4<u32>,
    // x: view samples.
    counts: vec4<u32>,
};

// The orthographic frame a view sample was baked in (see `bake::view_frame`).
struct SampleFrame {
    // xyz: image right axis; w: half extent along it.
    u: vec4<f32>,
    // xyz: image up axis; w: half extent.
    v: vec4<f32>,
    // xyz: towards the eye; w: half depth.
    f: vec4<f32>,
};

struct HbtAtlas {
    // x: tile texels; y: tiles per row; z: tiles per layer; w: 1 for cross projection.
    tiles: vec4<u32>,
    // x: 1 / tiles per row; y: 1 / rows of tiles; z: 1 when received shadows come from the
    // cascades instead of the cube-maps; w: the camera pass's mip bias.
    params: vec4<f32>,
    // x: how far past its own caster's plane a billboard point takes its received shadow,
    // in bounding radii; yzw: unused.
    shading: vec4<f32>,
};

@group(1) @binding(0) var<storage, read> species_info: array<HbtSet>;
@group(1) @binding(1) var<storage, read> frames: array<SampleFrame>;
@group(1) @binding(2) var atlas_color: texture_2d_array<f32>;
@group(1) @binding(3) var atlas_sampler: sampler;
@group(1) @binding(4) var<uniform> atlas: HbtAtlas;
