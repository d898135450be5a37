// `zfield` without a forest field (alone, or in a chain that does not end in one): its own
// lighting everywhere and no fade (`shadermap/field_zfield.wgsl` is the other side).

fn field_tree_light(sun: vec3<f32>, sky: vec3<f32>, albedo: vec3<f32>, world: vec3<f32>, v: vec3<f32>, l: vec3<f32>, vis: f32, height: f32) -> vec3<f32> {
    return sun + sky;
}

fn field_fade(base: vec3<f32>, height: f32) -> f32 {
    return 1.0;
}
