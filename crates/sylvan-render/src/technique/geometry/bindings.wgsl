// `geometry`'s bind group 1, declared once: the Rust layout in this folder uses the same
// binding indices. Prepended to `geometry.wgsl` (after the frame's group 0).

struct Species {
    // xyz: bbox min; w: vertices per leaf (4 for a card; the leaf hash of LOD transitions).
    bbox_min: vec4<f32>,
    // xyz: bbox max; w: leaf translucency.
    bbox_max: vec4<f32>,
};

@group(1) @binding(0) var leaf_texture: texture_2d<f32>;
@group(1) @binding(1) var leaf_sampler: sampler;
@group(1) @binding(2) var<uniform> species: Species;
// The back side of the leaves (the front's alpha is the cut-out) and their tangent-space
// normal map (linear; `shaders/leaf.wgsl`).
@group(1) @binding(3) var leaf_back: texture_2d<f32>;
@group(1) @binding(4) var leaf_normal_map: texture_2d<f32>;
