// The leaf material shared by `geometry` (and every technique drawing plant meshes with it)
// and the baker: the back image where a two-sided leaf is seen from behind, and the
// tangent-space normal map (x along +u, y along +v, z out of the front face) with a tangent
// frame from screen-space derivatives (no per-vertex tangents), after Schüler, "Normal
// mapping without precomputed tangents" (ShaderX5, 2006).
// Callers take the derivatives in uniform control flow (before any `discard`) and pass them.

// The front-face normal `n` (unit) bent by the normal-map sample `m` (rgb = n · 0.5 + 0.5) at a
// point whose position and texture coordinates change by `dp_dx`, `dp_dy`, `duv_dx`, `duv_dy`
// per pixel. Seen from behind, use the negated result: the same thin surface, outward normal
// flipped (the front's sunken veins are the back's ridges).
fn leaf_bumped_normal(n: vec3<f32>, dp_dx: vec3<f32>, dp_dy: vec3<f32>, duv_dx: vec2<f32>, duv_dy: vec2<f32>, m: vec3<f32>) -> vec3<f32> {
    let dp2perp = cross(dp_dy, n);
    let dp1perp = cross(n, dp_dx);
    var t = dp2perp * duv_dx.x + dp1perp * duv_dy.x;
    var b = dp2perp * duv_dx.y + dp1perp * duv_dy.y;
    let s = max(dot(t, t), dot(b, b));
    if (s < 1e-30) {
        return n;
    }
    // The cotangent frame comes out multiplied by the sign of the screen's orientation
    // relative to n (window y runs down in WebGPU); undo it so t follows +u whatever the side.
    let orient = select(1.0, -1.0, dot(cross(dp_dx, dp_dy), n) < 0.0);
    let k = inverseSqrt(s) * orient;
    let tn = m * 2.0 - vec3<f32>(1.0);
    let bent = t * k * tn.x + b * k * tn.y + n * tn.z;
    return select(n, normalize(bent), dot(bent, bent) > 1e-12);
}
