// `octahedral`'s bind group 1, declared once: the Rust layout in this folder uses the same
// binding indices. Prepended to `octahedral.wgsl` (after the frame's group 0).

struct OctSpecies {
    // xyz: model-space centre of the frames; w: their half side (the bounding sphere radius).
    centre_radius: vec4<f32>,
    bbox_min: vec4<f32>,
    bbox_max: vec4<f32>,
    // x: first tile in the atlas.
    info: vec4<u32>,
};

// One grid view's image axes (model space); the view looks along -f.
struct OctView {
    u: vec4<f32>,
    v: vec4<f32>,
    f: vec4<f32>,
};

struct OctAtlas {
    // x: tile texels; y: tiles per row; z: tiles per layer; w: views per grid side.
    tiles: vec4<u32>,
    // x: leaf translucency; y: 1 / tiles per row; z: 1 / rows of tiles per layer.
    params: vec4<f32>,
    // x: parallax steps; y: views blended (1 or 3); z: shadow depth offset (fraction of radius);
    // w: 1 when casters cover only what their view can show (`tight_casters`).
    draw: vec4<f32>,
};

@group(1) @binding(0) var<storage, read> oct_species: array<OctSpecies>;
@group(1) @binding(1) var<storage, read> oct_views: array<OctView>;
@group(1) @binding(2) var atlas_color: texture_2d_array<f32>;
@group(1) @binding(3) var atlas_normal: texture_2d_array<f32>;
@group(1) @binding(4) var atlas_sampler: sampler;
@group(1) @binding(5) var<uniform> atlas: OctAtlas;
