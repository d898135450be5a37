//! Procedural leaf textures (pure CPU): a broad serrated leaf with a green gradient, midrib and
//! lateral veins (prunus, bush), and a needle-covered shoot (pine). RGBA8, sRGB colour,
//! straight alpha used as a cut-out mask; transparent texels carry the nearby leaf colour so
//! that filtering does not darken edges. The leaf base (petiole) is at the bottom edge (v = 1)
//! and the tip at the top (v = 0), matching the leaf quads of `skeleton::mesh_leaves`.

use crate::lsystem::LeafKind;
use crate::mesh::LeafTexture;

/// Side of the generated square textures, pixels.
pub const LEAF_TEXTURE_SIZE: u32 = 256;

/// The texture for a leaf kind.
pub fn leaf_texture(kind: LeafKind) -> LeafTexture {
    match kind {
        LeafKind::Broadleaf => broadleaf(LEAF_TEXTURE_SIZE),
        LeafKind::Needles => needles(LEAF_TEXTURE_SIZE),
    }
}

fn lerp3(a: [f32; 3], b: [f32; 3], t: f32) -> [f32; 3] {
    let t = t.clamp(0.0, 1.0);
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

fn put(rgba: &mut [u8], i: usize, c: [f32; 3], a: f32) {
    rgba[i * 4] = (c[0].clamp(0.0, 1.0) * 255.0).round() as u8;
    rgba[i * 4 + 1] = (c[1].clamp(0.0, 1.0) * 255.0).round() as u8;
    rgba[i * 4 + 2] = (c[2].clamp(0.0, 1.0) * 255.0).round() as u8;
    rgba[i * 4 + 3] = (a.clamp(0.0, 1.0) * 255.0).round() as u8;
}

/// A broad, serrated, elliptic-acuminate leaf (prunus-like), petiole at the bottom.
fn broadleaf(n: u32) -> LeafTexture {
    let mut rgba = vec![0u8; (n * n * 4) as usize];
    let dark = [0.20, 0.36, 0.10]; // sRGB
    let light = [0.42, 0.60, 0.20];
    let vein = [0.60, 0.72, 0.36];
    for y in 0..n {
        for x in 0..n {
            let t = 1.0 - (y as f32 + 0.5) / n as f32; // 0 base .. 1 tip
            let dx = ((x as f32 + 0.5) / n as f32 - 0.5).abs();
            let px = 1.0 / n as f32;
            let (inside, col) = if t < 0.1 {
                // Petiole.
                (0.012 - dx, lerp3(vein, dark, 0.3))
            } else {
                let s = (t - 0.1) / 0.88;
                let w = if s >= 1.0 {
                    0.0
                } else {
                    0.44 * (std::f32::consts::PI * s.powf(0.8)).sin().powf(0.9)
                };
                // Teeth pointing to the tip.
                let tooth = 1.0 - 0.09 * (s * 22.0).fract();
                let edge = w * tooth;
                let g = 1.0 - (dx / w.max(1e-3)).min(1.0);
                let mut c = lerp3(dark, light, 0.25 + 0.55 * g + 0.2 * s);
                // Midrib and lateral veins running up and out.
                let lateral = ((s * 9.0 - dx * 7.0).fract() - 0.5).abs() < 0.05 && dx < edge * 0.85;
                if dx < 0.006 + 0.006 * (1.0 - s) {
                    c = vein;
                } else if lateral {
                    c = lerp3(c, vein, 0.45);
                }
                (edge - dx, c)
            };
            let a = (inside / px + 0.5).clamp(0.0, 1.0);
            put(&mut rgba, (y * n + x) as usize, col, a);
        }
    }
    LeafTexture {
        width: n,
        height: n,
        rgba,
    }
}

/// Distance from point p to segment ab.
fn seg_dist(p: [f32; 2], a: [f32; 2], b: [f32; 2]) -> (f32, f32) {
    let (vx, vy) = (b[0] - a[0], b[1] - a[1]);
    let (wx, wy) = (p[0] - a[0], p[1] - a[1]);
    let t = ((wx * vx + wy * vy) / (vx * vx + vy * vy).max(1e-12)).clamp(0.0, 1.0);
    let (dx, dy) = (wx - vx * t, wy - vy * t);
    ((dx * dx + dy * dy).sqrt(), t)
}

/// A pine shoot: a twig up the middle with needles along it, angled up and out.
fn needles(n: u32) -> LeafTexture {
    let mut rgba = vec![0u8; (n * n * 4) as usize];
    let base = [0.16, 0.30, 0.12]; // sRGB, dark pine green
    let tip = [0.30, 0.46, 0.20];
    let twig = [0.40, 0.30, 0.18];
    // Needle segments in texture units (x right, t up from the base).
    let mut segs: Vec<([f32; 2], [f32; 2], u32)> = Vec::new();
    segs.push(([0.5, 0.0], [0.5, 0.94], 0));
    let count = 20;
    for k in 0..count {
        let t = 0.04 + 0.9 * k as f32 / count as f32;
        let side = if k % 2 == 0 { 1.0 } else { -1.0 };
        let jitter = crate::rng::hash01(k as u64 + 11) as f32;
        let ang = (38.0 + 22.0 * jitter).to_radians();
        let len = 0.40 * (1.0 - 0.55 * t) + 0.05 * jitter;
        let a = [0.5, t];
        let b = [0.5 + side * ang.sin() * len, t + ang.cos() * len];
        segs.push((a, b, 1));
        // A second needle of the fascicle, slightly off.
        let ang2 = ang - 0.25;
        let b2 = [
            0.5 + side * ang2.sin() * len * 0.9,
            t + ang2.cos() * len * 0.9,
        ];
        segs.push((a, b2, 1));
    }
    let px = 1.0 / n as f32;
    for y in 0..n {
        for x in 0..n {
            let p = [
                (x as f32 + 0.5) / n as f32,
                1.0 - (y as f32 + 0.5) / n as f32,
            ];
            let mut best_a = 0.0f32;
            let mut col = base;
            for (a, b, kind) in &segs {
                let (d, t) = seg_dist(p, *a, *b);
                let half = if *kind == 0 {
                    0.010 * (1.0 - 0.6 * p[1])
                } else {
                    0.0055 * (1.0 - 0.5 * t)
                };
                let cov = ((half - d) / px + 0.5).clamp(0.0, 1.0);
                if cov > best_a {
                    best_a = cov;
                    col = if *kind == 0 {
                        twig
                    } else {
                        lerp3(base, tip, t * 0.8 + 0.2 * p[1])
                    };
                }
            }
            put(&mut rgba, (y * n + x) as usize, col, best_a);
        }
    }
    LeafTexture {
        width: n,
        height: n,
        rgba,
    }
}
