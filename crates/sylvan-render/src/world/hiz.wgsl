// The depth pyramid of the occlusion cull (world/hiz.rs). Level 0 is half the main target's
// size, each texel the farthest depth (reversed Z: the smallest value) of the 2×2 depth
// samples it covers; each further level the farthest of the 2×2 texels of the level below
// (sizes halve rounding down; the last texel of a row or column also covers the odd one left
// below it). A texel at level L thus bounds the depth of the 2^(L+1)-pixel square it covers.
//
// The levels lie side by side in two single-level textures — level L at x offset
// (the widths of levels 0..L) in texture L mod 2 — so that each pass reads one texture and
// writes the other, and no backend needs per-mip views (GL's do not keep their mip range
// when the whole texture is bound again).

struct Level {
    // x: this level's x offset in its texture, zw: its size
    here: vec4<u32>,
    // the same of the level below (level 0: offset 0 and the depth target's size)
    below: vec4<u32>,
}

@group(0) @binding(0) var<uniform> lv: Level;
// Level 0: the depth target bound as an unfilterable float texture (a depth texture's
// `textureLoad` has no GLSL form); else the texture holding the level below.
@group(0) @binding(1) var source: texture_2d<f32>;
@group(0) @binding(2) var dest: texture_storage_2d<r32float, write>;

@compute @workgroup_size(8, 8)
fn reduce(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<i32>(lv.here.zw);
    let here = vec2<i32>(id.xy);
    if (any(here >= size)) {
        return;
    }
    let below_offset = vec2<i32>(i32(lv.below.x), 0);
    let last_below = vec2<i32>(lv.below.zw) - 1;
    let lo = here * 2;
    let hi = select(lo + 1, last_below, here == size - 1);
    var m = 1.0;
    for (var y = lo.y; y <= min(hi.y, last_below.y); y++) {
        for (var x = lo.x; x <= min(hi.x, last_below.x); x++) {
            m = min(m, textureLoad(source, below_offset + vec2<i32>(x, y), 0).r);
        }
    }
    textureStore(dest, vec2<i32>(i32(lv.here.x), 0) + here, vec4<f32>(m, 0.0, 0.0, 1.0));
}
