// `zfield`'s bind group 1, declared once: the Rust layout in `draw.rs` uses the same binding
// indices. Prepended to the direction grid's lookup and `zfield.wgsl` (after group 0).

struct ZSpecies {
    // xyz: model-space centre o of the frames; w: their half side (bounding sphere radius).
    centre_radius: vec4<f32>,
    bbox_min: vec4<f32>,
    bbox_max: vec4<f32>,
    // x: first tile in the atlases.
    info: vec4<u32>,
};

// One grid view's image axes (model space); the view looks along -f.
struct ZViewFrame {
    u: vec4<f32>,
    v: vec4<f32>,
    f: vec4<f32>,
};

struct ZParams {
    // x: tile texels; y: tiles per row; z: tiles per layer; w: grid order n.
    tiles: vec4<u32>,
    // x: 1 / tiles per row; y: 1 / rows of tiles per layer; z: leaf translucency;
    // w: opacity-scaled τ (1/0).
    atlas: vec4<f32>,
    // x: tau (1/m); y: sun scale; z: a1; w: a2 (eq. 7–8).
    sun: vec4<f32>,
    // x: sky scale; y: tree density Λ_h (trees/m²); z: normal weight; w: per-tree masks (1/0).
    sky: vec4<f32>,
    // x: camera mip bias; y: 1 when `density_per_ha` is set (it overrides the cover's
    // density map); z: 1 when shadows store the crowns' opacity (else opaque where α > ½);
    // w: 1 when casters cover only what their views can show (`caster_extent`).
    extra: vec4<f32>,
    // x: the sky's normal weight (eq. 9's sky blended towards what the baked normal sees).
    more: vec4<f32>,
};

@group(1) @binding(0) var<storage, read> z_species: array<ZSpecies>;
@group(1) @binding(1) var<storage, read> z_views: array<ZViewFrame>;
@group(1) @binding(2) var atlas_color: texture_2d_array<f32>;
@group(1) @binding(3) var atlas_normal: texture_2d_array<f32>;
@group(1) @binding(4) var atlas_zfield: texture_2d_array<f32>;
@group(1) @binding(5) var atlas_sampler: sampler;
@group(1) @binding(6) var<uniform> zp: ZParams;
