// `shadermap`'s tables as the far field samples them (`gpu.rs`): (𝔾, 𝕋) on ridge-aligned axes
// (θ̄ = (θv + θl)/2, δ = θv − θl on nodes crowding δ = 0, φ, λ) in a 3D texture, one slab of
// θ̄ per density node; (𝔼, 𝔻, 𝔼ₙ) per (θv, λ) in a 2D texture. Angles are BN12's transformed
// zeniths (radians); λ in trees per m². `RidgeTables::sample` is the CPU twin of `table_gt`.
// Composed with `@group(FIELD)` and `@binding(T0..T3)` substituted.

struct TableInfo {
    // θ̄ nodes, δ nodes, φ nodes, λ nodes.
    dims: vec4<f32>,
    // x: the crown shape h of S = diag(1, 2/h, 1).
    shape: vec4<f32>,
    // The density nodes, 4 per row.
    lambdas: array<vec4<f32>, 4>,
};

@group(FIELD) @binding(T0) var<uniform> table_info: TableInfo;
@group(FIELD) @binding(T1) var table_gt_tex: texture_3d<f32>;
@group(FIELD) @binding(T2) var table_dec_tex: texture_2d<f32>;
@group(FIELD) @binding(T3) var table_sampler: sampler;

const TABLE_HALF_PI: f32 = 1.5707964;
const TABLE_PI: f32 = 3.1415927;

fn table_lambda(i: u32) -> f32 {
    return table_info.lambdas[i / 4u][i % 4u];
}

// The density slab below `lambda` and the fraction towards the next, clamped to the nodes.
fn table_lambda_coord(lambda: f32) -> vec2<f32> {
    let n = u32(table_info.dims.w);
    var l = 0u;
    for (var i = 1u; i + 1u < n; i = i + 1u) {
        if (table_lambda(i) <= lambda) {
            l = i;
        }
    }
    let lo = table_lambda(l);
    let hi = table_lambda(l + 1u);
    return vec2<f32>(f32(l), clamp((lambda - lo) / max(hi - lo, 1e-12), 0.0, 1.0));
}

// The fractional δ node of δ (radians): δ_j = 90° · sgn(j − c) · ((j − c)/c)².
fn table_delta_index(delta: f32) -> f32 {
    let c = (table_info.dims.y - 1.0) * 0.5;
    return c + c * sign(delta) * sqrt(min(abs(delta) / TABLE_HALF_PI, 1.0));
}

// (𝔾, 𝕋) at transformed zeniths `tv`, `tl`, azimuth `phi` between them (in [0, π]; larger
// values are clamped, not folded) and density `lambda`.
fn table_gt(tv: f32, tl: f32, phi: f32, lambda: f32) -> vec2<f32> {
    let nt = table_info.dims.x;
    let nd = table_info.dims.y;
    let np = table_info.dims.z;
    let nl = table_info.dims.w;
    let a = clamp((tv + tl) * 0.5 / TABLE_HALF_PI * (nt - 1.0), 0.0, nt - 1.0);
    let j = clamp(table_delta_index(tv - tl), 0.0, nd - 1.0);
    let m = clamp(min(abs(phi), TABLE_PI) / TABLE_PI * (np - 1.0), 0.0, np - 1.0);
    let lc = table_lambda_coord(lambda);
    let xy = vec2<f32>((m + 0.5) / np, (j + 0.5) / nd);
    // z stays inside the slab's texel centres: no filtering across density nodes.
    let z0 = (lc.x * nt + a + 0.5) / (nl * nt);
    let z1 = ((lc.x + 1.0) * nt + a + 0.5) / (nl * nt);
    let s0 = textureSampleLevel(table_gt_tex, table_sampler, vec3<f32>(xy, z0), 0.0).xy;
    let s1 = textureSampleLevel(table_gt_tex, table_sampler, vec3<f32>(xy, z1), 0.0).xy;
    return mix(s0, s1, lc.y);
}

// 𝔾's diagonal, the ground seen at all (`k_g + k_ḡ`) at transformed zenith `theta`.
fn table_g_diag(theta: f32, lambda: f32) -> f32 {
    return table_gt(theta, theta, 0.0, lambda).x;
}

// (𝔼, 𝔻, 𝔼ₙ) at transformed view zenith `tv` and density `lambda`.
fn table_dec(tv: f32, lambda: f32) -> vec3<f32> {
    let nt = table_info.dims.x;
    let nl = table_info.dims.w;
    let lc = table_lambda_coord(lambda);
    let x = (clamp(tv / TABLE_HALF_PI, 0.0, 1.0) * (nt - 1.0) + 0.5) / nt;
    let y = (lc.x + lc.y + 0.5) / nl;
    return textureSampleLevel(table_dec_tex, table_sampler, vec2<f32>(x, y), 0.0).xyz;
}
