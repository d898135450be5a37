// `boxtree`'s bind group 1, declared once: the Rust layout in this folder uses the same
// binding indices. Prepended to `boxtree.wgsl` (after the frame's group 0).

const MAX_PLANES: u32 = 6u;

struct Plane {
    // xyz: plane centre (model space); w: half extent along f.
    centre: vec4<f32>,
    // xyz: image right axis; w: half extent along u.
    u: vec4<f32>,
    // xyz: image up axis; w: half extent along v.
    v: vec4<f32>,
    // xyz: plane normal (the front image is seen from +f).
    f: vec4<f32>,
};

struct Box {
    planes: array<Plane, 6>,
    // The plant's bounding box (for the crown occlusion term, as in the geometry).
    plant_min: vec4<f32>,
    plant_max: vec4<f32>,
    // x: first tile; y: images per plane (1 or 2); z: planes; w: bit 0 set for a billboard
    // (one plane turned about the vertical axis towards the viewer), bits 1…: the box's depth
    // in the box tree (for the debug view).
    info: vec4<u32>,
};

struct Atlas {
    // x: tile texels; y: tiles per row; z: tiles per layer; w: unused.
    tiles: vec4<u32>,
    // x: leaf translucency; y: 1 / tiles per row; z: 1 / rows of tiles per layer.
    params: vec4<f32>,
};

@group(1) @binding(0) var<storage, read> boxes: array<Box>;
@group(1) @binding(1) var atlas_color: texture_2d_array<f32>;
@group(1) @binding(2) var atlas_normal: texture_2d_array<f32>;
@group(1) @binding(3) var atlas_sampler: sampler;
@group(1) @binding(4) var<uniform> atlas: Atlas;
