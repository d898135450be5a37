// `shadermap`'s table measurement (BN12 §6, "precomputations"): a periodic z-field forest
// patch drawn along one direction d (towards the eye or the sun) with a sheared, ground-aligned
// orthographic projection, so pixel (i, j) is the same ground texel in every direction. A
// pixel is written where a tree hides the ground point's ray: the z-field's opacity α along d
// against a threshold hashed from (ground texel, tree), the same threshold in every direction,
// so two directions see the same trees the way two nearby rays do (v = l gives G = Gd exactly)
// and n trees of opacity α over one ray leave (1 − α)ⁿ of the ground visible on average.
// Appended to `zfield`'s shader (its bindings, the grid lookup and `zfield.wgsl`).
// frame.view_proj: the sheared projection; frame.sun_dir.xyz: d; frame.shadow_params.x:
// 1 / pixels of the patch (the casters' mip choice); frame.camera.w: pixels per metre of ground.

@vertex
fn vs_measure(in: ZIn, inst: TreeInstance) -> ZOut {
    return z_vertex(in, inst, frame.sun_dir.xyz, true);
}

@fragment
fn fs_measure_mask(in: ZOut) -> @location(0) vec4<f32> {
    let sp = z_species[in.views.w];
    let p = instance_to_model(in.world, in.base_scale, in.rot);
    let z = zfield3(sp, in.views.xyz, in.weights, p, in.lod);
    let d = frame.sun_dir.xyz;
    let ground = in.world.xz - d.xz * (in.world.y / d.y);
    let texel = floor(ground * frame.camera.w);
    let key = 1.0 + fract(in.rot.z * 7.31 + in.base_scale.x * 0.137 + in.base_scale.z * 0.291) * 4093.0;
    if (z.w <= hash13(vec3<f32>(texel, key))) {
        discard;
    }
    return vec4<f32>(1.0, 1.0, 1.0, 1.0);
}
