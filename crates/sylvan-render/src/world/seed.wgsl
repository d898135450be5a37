// BN12 §4 on the GPU: a `wang` forest's trees of a terrain tile, produced where they are drawn.
// One workgroup per tile job walks the job's candidate runs (the Wang tile copies overlapping
// the tile, as `SeededForest::candidate_runs` lists them on the CPU) 256 candidates at a time;
// each invocation thins one candidate with the CPU's arithmetic (`SeededForest::produce`:
// SplitMix64 hashes in two 32-bit halves, three draws, f32 thinning), and a workgroup scan
// writes the kept trees in the CPU's order into the job's pool pages. Per job it counts trees,
// per species, and the bounds of their spheres (for the tile cull).

const WG: u32 = 256u;
const PAGE: u32 = 256u;
const MAX_LAYOUTS: u32 = 64u;

struct Layout {
    // x: species, y: first sample in `data` (map) , z: map columns (0: constant density), w: rows
    info: vec4<u32>,
    // x: trees per m² where the map is 1 (or the constant density), y, z: height range,
    // w: 1 / plant height (scale of a tree of height 1)
    density_height: vec4<f32>,
}

struct Params {
    // x, y: placement seed (low, high); z: layouts; w: results stride (u32s per job)
    seed_info: vec4<u32>,
    // x: ρ (pattern points per m²), y: 0, zw: the forest's extent (density maps span it)
    rho_size: vec4<f32>,
    // xy: terrain extent, zw: unused
    terrain: vec4<f32>,
    // x, y: heightmap columns and rows, z: first height in `data`, w: unused
    terrain_info: vec4<u32>,
    // Wang tile t's points are `points[tile_start[t] .. tile_start[t + 1]]` (17 used).
    tile_start: array<vec4<u32>, 5>,
    layouts: array<Layout, MAX_LAYOUTS>,
    // Per layout: its species' model bounds centre (xyz) and radius (w) for a tree of scale 1.
    spheres: array<vec4<f32>, MAX_LAYOUTS>,
}

// A job: x: first run, y: runs, z: first page-table entry, w: result slot;
// rect: the tile's [min.x, max.x) (candidates outside along x are skipped; z is the runs').
struct Job {
    info: vec4<u32>,
    rect: vec4<f32>,
}

// A run of a Wang tile copy: x: pattern tile, y: first point, z: one past the last, w: 0;
// hash: the copy's hash term (tx·C1 ^ ty·C2, low, high) and origin (x, z) as bits.
struct Run {
    info: vec4<u32>,
    hash_origin: vec4<u32>,
}

@group(0) @binding(0) var<uniform> params: Params;
// Wang tiles' points (x, z), tile t's at [tile_start[t], tile_start[t + 1]).
@group(0) @binding(1) var<storage, read> points: array<vec2<f32>>;
// Density maps and the heightmap.
@group(0) @binding(2) var<storage, read> data: array<f32>;
@group(0) @binding(3) var<storage, read> jobs: array<Job>;
@group(0) @binding(4) var<storage, read> runs: array<Run>;
@group(0) @binding(5) var<storage, read> page_table: array<u32>;
@group(0) @binding(6) var<storage, read_write> pool: array<vec4<f32>>;
// Per job (stride params.seed_info.w): count, min.xyz, max.xyz (order-preserving bits), then
// one count per layout's species slot.
@group(0) @binding(7) var<storage, read_write> results: array<atomic<u32>>;

var<workgroup> scan: array<u32, WG>;

// ---- 64-bit integers as (low, high) -------------------------------------------------------

fn mul32(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xFFFFu;
    let a1 = a >> 16u;
    let b0 = b & 0xFFFFu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    let mid = (p00 >> 16u) + (p01 & 0xFFFFu) + (p10 & 0xFFFFu);
    return vec2<u32>((p00 & 0xFFFFu) | (mid << 16u), p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u));
}

fn mul64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let p = mul32(a.x, b.x);
    return vec2<u32>(p.x, p.y + a.x * b.y + a.y * b.x);
}

fn add64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    return vec2<u32>(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}

// a >> n for 0 < n < 32.
fn shr64(a: vec2<u32>, n: u32) -> vec2<u32> {
    return vec2<u32>((a.x >> n) | (a.y << (32u - n)), a.y >> n);
}

// SplitMix64's finaliser (`sylvan_scene::rng::mix`).
fn mix64(z0: vec2<u32>) -> vec2<u32> {
    var z = mul64(z0 ^ shr64(z0, 30u), vec2<u32>(0x1CE4E5B9u, 0xBF58476Du));
    z = mul64(z ^ shr64(z, 27u), vec2<u32>(0x133111EBu, 0x94D049BBu));
    return z ^ shr64(z, 31u);
}

const GOLDEN: vec2<u32> = vec2<u32>(0x7F4A7C15u, 0x9E3779B9u);

// `Rng::f32` of the generator whose state is `s` after the draw (state already advanced).
fn draw(s: vec2<u32>) -> f32 {
    return f32(mix64(s).y >> 8u) * (1.0 / 16777216.0);
}

// ---- terrain and densities (`sylvan_scene::terrain::bilinear`) -----------------------------

fn bilinear(first: u32, res: vec2<u32>, size: vec2<f32>, p: vec2<f32>) -> f32 {
    let fx = max(clamp(p.x / size.x, 0.0, 1.0) * f32(res.x - 1u), 0.0);
    let fz = max(clamp(p.y / size.y, 0.0, 1.0) * f32(res.y - 1u), 0.0);
    let c0 = u32(floor(fx));
    let r0 = u32(floor(fz));
    let c1 = min(c0 + 1u, res.x - 1u);
    let r1 = min(r0 + 1u, res.y - 1u);
    let tx = fx - f32(c0);
    let tz = fz - f32(r0);
    let w = res.x;
    let a = data[first + r0 * w + c0];
    let b = data[first + r0 * w + c1];
    let c = data[first + r1 * w + c0];
    let d = data[first + r1 * w + c1];
    let top = a + (b - a) * tx;
    let bottom = c + (d - c) * tx;
    return top + (bottom - top) * tz;
}

fn density(l: u32, p: vec2<f32>) -> f32 {
    let lay = params.layouts[l];
    let cols = lay.info.z;
    if cols == 0u {
        return lay.density_height.x;
    }
    var v: f32;
    if cols == 1u || lay.info.w == 1u {
        v = data[lay.info.y];
    } else {
        v = bilinear(lay.info.y, lay.info.zw, params.rho_size.zw, p);
    }
    return v * lay.density_height.x;
}

// Float bits whose unsigned order is the floats' order (for atomicMin / atomicMax).
fn ordered(f: f32) -> u32 {
    let b = bitcast<u32>(f);
    return select(b | 0x80000000u, ~b, (b & 0x80000000u) != 0u);
}

struct Tree {
    kept: bool,
    slot: u32,
    base_scale: vec4<f32>,
    rot: vec4<f32>,
}

// `Thinning::consider` for candidate `j` of run `r` at `q`.
fn consider(r: Run, j: u32, q: vec2<f32>) -> Tree {
    var t: Tree;
    t.kept = false;
    let size = params.terrain.xy;
    if q.x < 0.0 || q.x > size.x || q.y < 0.0 || q.y > size.y {
        return t;
    }
    let seed = params.seed_info.xy;
    let v = vec2<u32>((r.info.x << 16u) + j + 1u, 0u);
    let key = mix64(seed ^ mix64(v) ^ r.hash_origin.xy);
    var s = key ^ vec2<u32>(0x4C957F2Du, 0x5851F42Du);
    s = add64(s, GOLDEN);
    let u = draw(s) * params.rho_size.x;
    s = add64(s, GOLDEN);
    let hr = draw(s);
    s = add64(s, GOLDEN);
    let rot = draw(s);
    var cum = 0.0;
    var chosen = MAX_LAYOUTS;
    for (var l = 0u; l < params.seed_info.z; l += 1u) {
        cum = cum + density(l, q);
        if u < cum {
            chosen = l;
            break;
        }
    }
    if chosen == MAX_LAYOUTS {
        return t;
    }
    let lay = params.layouts[chosen];
    let h = lay.density_height.y + (lay.density_height.z - lay.density_height.y) * hr;
    let y = bilinear(params.terrain_info.z, params.terrain_info.xy, size, q);
    let a = rot * 6.2831855;
    let tint = f32((key.y * 2654435761u) >> 8u) * (1.0 / 16777216.0);
    t.kept = true;
    t.slot = chosen;
    t.base_scale = vec4<f32>(q.x, y, q.y, h * lay.density_height.w);
    t.rot = vec4<f32>(cos(a), sin(a), tint, bitcast<f32>(lay.info.x));
    return t;
}

@compute @workgroup_size(256)
fn produce(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) i: u32) {
    let job = jobs[wg.x];
    let out = job.info.w * params.seed_info.w;
    var written = 0u;
    for (var k = 0u; k < job.info.y; k += 1u) {
        let r = runs[job.info.x + k];
        let origin = bitcast<vec2<f32>>(r.hash_origin.zw);
        let tile_first = params.tile_start[r.info.x / 4u][r.info.x % 4u];
        for (var base = r.info.y; base < r.info.z; base += WG) {
            let j = base + i;
            var t: Tree;
            t.kept = false;
            if j < r.info.z {
                let q = origin + points[tile_first + j];
                if q.x >= job.rect.x && q.x < job.rect.y {
                    t = consider(r, j, q);
                }
            }
            // Inclusive scan of the kept flags: the tree's place among this chunk's.
            scan[i] = select(0u, 1u, t.kept);
            workgroupBarrier();
            for (var d = 1u; d < WG; d <<= 1u) {
                var add = 0u;
                if i >= d {
                    add = scan[i - d];
                }
                workgroupBarrier();
                scan[i] += add;
                workgroupBarrier();
            }
            let total = scan[WG - 1u];
            if t.kept {
                let n = written + scan[i] - 1u;
                let slot = page_table[job.info.z + n / PAGE] * PAGE + n % PAGE;
                pool[slot * 2u] = t.base_scale;
                pool[slot * 2u + 1u] = t.rot;
                let sp = params.spheres[t.slot];
                let scale = t.base_scale.w;
                let lc = sp.xyz * scale;
                let c = t.base_scale.xyz
                    + vec3<f32>(t.rot.x * lc.x + t.rot.y * lc.z, lc.y, -t.rot.y * lc.x + t.rot.x * lc.z);
                let rad = sp.w * scale;
                atomicMin(&results[out + 1u], ordered(c.x - rad));
                atomicMin(&results[out + 2u], ordered(c.y - rad));
                atomicMin(&results[out + 3u], ordered(c.z - rad));
                atomicMax(&results[out + 4u], ordered(c.x + rad));
                atomicMax(&results[out + 5u], ordered(c.y + rad));
                atomicMax(&results[out + 6u], ordered(c.z + rad));
                atomicAdd(&results[out + 7u + t.slot], 1u);
            }
            written += total;
            workgroupBarrier();
        }
    }
    if i == 0u {
        atomicStore(&results[out], written);
    }
}
