// `billboard-cloud`'s bind groups 1 (the clouds of every species) and 2 (one species' leaf
// material, `geometry`'s layout). The Rust layouts in `draw.rs` use the same indices.

// A plane (`PlaneRecord` in `layers.rs`).
struct CloudPlane {
    // xyz: origin (model space); w: cell size (plant units).
    origin_cell: vec4<f32>,
    // xyz: u axis; w: rectangle min along u.
    u: vec4<f32>,
    // xyz: v axis; w: rectangle min along v.
    v: vec4<f32>,
    // xyz: normal (the front side); w: rectangle size along u.
    n: vec4<f32>,
    // x, y: cells along u, v; z: first cell; w: rectangle size along v (f32 bits).
    grid: vec4<u32>,
    // x, y: the lowest and highest height of the plane's leaves above it (its slab).
    slab: vec4<f32>,
};

// A leaf (`LeafRecord` in `layers.rs`, 80 bytes): in plane space (s, t, height) the leaf
// image's uv = 0 lies at `origin`, and uv = (to_u · x, to_v · x) for an offset x from it on
// the leaf's plane.
struct LeafRecord {
    origin: vec3<f32>,
    uv_min: u32,
    to_u: vec3<f32>,
    uv_max: u32,
    to_v: vec3<f32>,
    normal: u32,
    tangent: u32,
    color: u32,
    ao: u32,
    pad: u32,
    // The shading normal at the uv box corners (octahedral, in `ao`'s order).
    corner_normals: vec4<u32>,
};

struct CloudParams {
    // First plane of the near, mid and far cloud, and the plane count.
    level_first: vec4<u32>,
    // Per cloud the distance window of its presence: rises over [x, y], falls over [z, w].
    windows: array<vec4<f32>, 3>,
    // x: entries per pixel of a cell's diagonal; y: leaf translucency; z: 1 / near tile;
    // w: 1 / mid-far tile.
    draw: vec4<f32>,
    // Near atlas: tiles per row, tiles per layer, rows, unused.
    atlas_near: vec4<u32>,
    // Mid and far atlas.
    atlas_far: vec4<u32>,
};

@group(1) @binding(0) var<storage, read> planes: array<CloudPlane>;
@group(1) @binding(1) var<storage, read> cells: array<u32>;
@group(1) @binding(2) var<storage, read> lists: array<u32>;
@group(1) @binding(3) var<storage, read> records: array<LeafRecord>;
@group(1) @binding(4) var near_color: texture_2d_array<f32>;
@group(1) @binding(5) var near_normal: texture_2d_array<f32>;
@group(1) @binding(6) var far_color: texture_2d_array<f32>;
@group(1) @binding(7) var far_normal: texture_2d_array<f32>;
@group(1) @binding(8) var atlas_sampler: sampler;
@group(1) @binding(9) var<uniform> cloud: CloudParams;

struct Species {
    // xyz: bbox min; w: vertices per leaf.
    bbox_min: vec4<f32>,
    // xyz: bbox max; w: leaf translucency.
    bbox_max: vec4<f32>,
};

@group(2) @binding(0) var leaf_texture: texture_2d<f32>;
@group(2) @binding(1) var leaf_sampler: sampler;
@group(2) @binding(2) var<uniform> species: Species;
@group(2) @binding(3) var leaf_back: texture_2d<f32>;
@group(2) @binding(4) var leaf_normal_map: texture_2d<f32>;
