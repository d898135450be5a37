//! Procedural leaf-card textures (pure CPU). Each card carries many leaves or needles, so that a
//! crown is made of few, large cards instead of one quad per leaf:
//!
//! * `broadleaf` (prunus, bush): a leaf cluster — a short twig up the middle with nine
//!   serrated, elliptic-acuminate leaves on petioles, each with its own shade of green;
//! * `needles` (pine): a needle-covered shoot spray — a twig with side shoots, every shoot
//!   densely set with dark blue-green needles, the outline tapering to the tip like a
//!   spruce or pine branchlet seen from above.
//!
//! RGBA8, sRGB colour, straight alpha used as a cut-out mask (the renderer tests α ≥ 0.5);
//! the cards are 50–60 % opaque so that a crown of them reads as a mostly closed mass.
//! Transparent texels carry the mean leaf colour so that filtering does not darken edges. The
//! card base (twig end) is at the bottom edge (v = 1) and the tip at the top (v = 0), matching
//! the leaf quads of `skeleton::mesh_leaves`; [`crate::skeleton::leaf_aspect`] gives the
//! card's width/length ratio, which the textures are drawn for.

use crate::lsystem::LeafKind;
use crate::mesh::LeafTexture;
use crate::rng::hash01;

/// Side of the generated square textures, pixels.
pub const LEAF_TEXTURE_SIZE: u32 = 256;

/// The (front) texture for a leaf kind.
pub fn leaf_texture(kind: LeafKind) -> LeafTexture {
    leaf_maps(kind).front
}

/// A leaf kind's images: front colour with the cut-out alpha, back colour (same alpha; empty
/// for the cards, which look the same from both sides) and a tangent-space normal map (empty
/// for the cards: flat).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LeafMaps {
    /// Front side, sRGB + alpha mask.
    pub front: LeafTexture,
    /// Back side, sRGB + the same alpha; empty: the front.
    pub back: LeafTexture,
    /// Normal map, linear RGB = n · 0.5 + 0.5 (x along +u, y along +v, z out of the front).
    pub normal: LeafTexture,
}

/// Every image of a leaf kind.
pub fn leaf_maps(kind: LeafKind) -> LeafMaps {
    match kind {
        LeafKind::Broadleaf => LeafMaps {
            front: broadleaf(LEAF_TEXTURE_SIZE),
            ..Default::default()
        },
        LeafKind::Needles => LeafMaps {
            front: needles(LEAF_TEXTURE_SIZE),
            ..Default::default()
        },
        LeafKind::Chestnut | LeafKind::Beech => single_leaf(kind, LEAF_TEXTURE_SIZE),
    }
}

/// Colours of a single-leaf kind (sRGB): front blade, front veins, back blade, back veins,
/// petiole.
fn leaf_colours(kind: LeafKind) -> [[f32; 3]; 5] {
    match kind {
        // Chestnut: dark glossy green above, paler grey-green below with raised yellowish veins.
        LeafKind::Chestnut => [
            [0.17, 0.30, 0.09],
            [0.32, 0.42, 0.16],
            [0.36, 0.45, 0.25],
            [0.55, 0.58, 0.36],
            [0.42, 0.40, 0.18],
        ],
        // Beech: fresh mid green above, lighter and slightly silvery below.
        _ => [
            [0.20, 0.35, 0.10],
            [0.30, 0.43, 0.15],
            [0.38, 0.50, 0.26],
            [0.50, 0.58, 0.34],
            [0.40, 0.36, 0.20],
        ],
    }
}

/// One leaf in the kind's outline ([`crate::blade::Outline`]), petiole at the bottom edge,
/// tip at the top: front and back colour with the same alpha, and a normal map of the midrib,
/// the lateral veins and the round petiole (sunken veins on the front, which the back sees as
/// ridges when the shader flips the normal).
fn single_leaf(kind: LeafKind, n: u32) -> LeafMaps {
    let o = crate::blade::Outline::of(kind).expect("a single-leaf kind");
    let aspect = o.texture_width();
    // Square texels: as many across as the footprint is wide (so that mip levels follow the
    // leaf's size on screen in both directions), rounded to a multiple of 8.
    let w = ((n as f32 * aspect / 8.0).round() as u32).max(1) * 8;
    let mut front = Canvas::with_size(w, n, aspect);
    let mut back = Canvas::with_size(w, n, aspect);
    let [fc, fv, bc, bv, pc] = leaf_colours(kind);
    let tx = front.texel();
    let span = 1.0 - o.petiole;
    // Lateral veins leave the midrib at about 50° (chestnut) to 45° (beech) towards the tip.
    let slope = if kind == LeafKind::Chestnut { 0.8 } else { 1.1 };
    let mut height = vec![0.0f32; (w * n) as usize];
    for y in 0..n {
        for x in 0..w {
            let [px, py] = front.pos(x, y);
            let hw = o.half_width(py);
            let cov = ((hw - px.abs()) / tx + 0.5).clamp(0.0, 1.0);
            if cov <= 0.0 || !(0.0..=1.0).contains(&py) {
                continue;
            }
            let bh = o.blade_half(py);
            let i = (y * w + x) as usize;
            let ph = o.petiole_width(py);
            if bh <= ph {
                // The petiole: a round stalk.
                let q = (px / ph.max(1e-6)).clamp(-1.0, 1.0);
                height[i] = ph * (1.0 - q * q).max(0.0).sqrt();
                let shade = 0.85 + 0.15 * (1.0 - q * q).sqrt();
                front.over(x, y, scale3(pc, shade), cov);
                back.over(x, y, scale3(pc, shade), cov);
                continue;
            }
            let s = (py - o.petiole) / span;
            let g = (px.abs() / bh).min(1.0);
            // Midrib and lateral veins (distances in leaf lengths).
            let mw = 0.005 * (1.0 - 0.6 * s) + 0.0025;
            let dm = px.abs();
            let s0 = s - slope * px.abs() / span;
            let dv = ((s0 * o.veins + 0.5).fract() - 0.5).abs() / o.veins * span * 0.62;
            let vw = 0.0035 * (1.0 - 0.4 * g);
            let mid = (-(dm / mw).powi(2)).exp();
            let vein = if s0 > 0.02 && g < 0.96 {
                (-(dv / vw).powi(2)).exp() * (1.0 - 0.6 * g)
            } else {
                0.0
            };
            // Between the veins the blade bulges a little (slightly puckered).
            let pucker = 0.5 - 0.5 * (dv / (span * 0.62 / o.veins) * std::f32::consts::PI).cos();
            height[i] = -0.0025 * mid - 0.0013 * vein + 0.0005 * pucker * (1.0 - g);
            let j = hash01(i as u64 * 2_654_435_761) as f32 - 0.5;
            let k = 1.0 + 0.05 * j - 0.12 * g * g;
            let veins = mid.max(vein);
            let f = scale3(lerp3(fc, fv, veins * 0.8), k);
            let b = scale3(lerp3(bc, bv, veins), k * (1.0 + 0.04 * (1.0 - g)));
            front.over(x, y, f, cov);
            back.over(x, y, b, cov);
        }
    }
    // Normal map from the height field: x along +u (across to the right), y along +v (down the
    // image, towards the petiole).
    let (du, dv) = (aspect / w as f32, 1.0 / n as f32);
    let h = |x: i64, y: i64| -> f32 {
        let (x, y) = (x.clamp(0, w as i64 - 1), y.clamp(0, n as i64 - 1));
        height[(y as u32 * w + x as u32) as usize]
    };
    let mut normal = Vec::with_capacity((w * n * 4) as usize);
    for y in 0..n as i64 {
        for x in 0..w as i64 {
            let gx = (h(x + 1, y) - h(x - 1, y)) / (2.0 * du);
            let gy = (h(x, y + 1) - h(x, y - 1)) / (2.0 * dv);
            let len = (gx * gx + gy * gy + 1.0).sqrt();
            for c in [-gx / len, -gy / len, 1.0 / len] {
                normal.push(((c * 0.5 + 0.5) * 255.0).round() as u8);
            }
            normal.push(255);
        }
    }
    LeafMaps {
        front: front.finish(),
        back: back.finish(),
        normal: LeafTexture {
            width: w,
            height: n,
            rgba: normal,
        },
    }
}

/// Fraction of texels with alpha ≥ 0.5 (what the renderer's alpha test keeps).
pub fn coverage(t: &LeafTexture) -> f32 {
    let n = t.rgba.chunks_exact(4).filter(|p| p[3] >= 128).count();
    n as f32 / (t.width * t.height).max(1) as f32
}

fn lerp3(a: [f32; 3], b: [f32; 3], t: f32) -> [f32; 3] {
    let t = t.clamp(0.0, 1.0);
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

fn scale3(a: [f32; 3], k: f32) -> [f32; 3] {
    [a[0] * k, a[1] * k, a[2] * k]
}

/// A float RGBA canvas in card units: x ∈ [0, 1] across (scaled by the card aspect so that
/// shapes are not stretched), t ∈ [0, 1] from the base (bottom row) to the tip (top row).
struct Canvas {
    /// Width in texels.
    n: u32,
    /// Height in texels.
    h: u32,
    aspect: f32,
    buf: Vec<[f32; 4]>,
}

impl Canvas {
    fn new(n: u32, aspect: f32) -> Self {
        Self::with_size(n, n, aspect)
    }

    /// A `w` × `h` canvas (texels as square as the card: w ≈ h · aspect for single leaves).
    fn with_size(w: u32, h: u32, aspect: f32) -> Self {
        Canvas {
            n: w,
            h,
            aspect,
            buf: vec![[0.0; 4]; (w * h) as usize],
        }
    }

    /// Metric position of texel (x, y): (across in card lengths, up in card lengths).
    fn pos(&self, x: u32, y: u32) -> [f32; 2] {
        [
            ((x as f32 + 0.5) / self.n as f32 - 0.5) * self.aspect,
            1.0 - (y as f32 + 0.5) / self.h as f32,
        ]
    }

    /// Texel range covering metric box [lo, hi] (with a margin of one texel).
    fn range(&self, lo: [f32; 2], hi: [f32; 2]) -> (u32, u32, u32, u32) {
        let (n, h) = (self.n as f32, self.h as f32);
        let fx = |u: f32| ((u / self.aspect + 0.5) * n).floor();
        let fy = |t: f32| ((1.0 - t) * h).floor();
        let cx = |v: f32| v.clamp(0.0, n - 1.0) as u32;
        let cy = |v: f32| v.clamp(0.0, h - 1.0) as u32;
        (
            cx(fx(lo[0]) - 1.0),
            cx(fx(hi[0]) + 1.0),
            cy(fy(hi[1]) - 1.0),
            cy(fy(lo[1]) + 1.0),
        )
    }

    /// One texel's size in card lengths (along the card).
    fn texel(&self) -> f32 {
        1.0 / self.h as f32
    }

    /// Composites colour `c` with coverage `a` over texel (x, y).
    fn over(&mut self, x: u32, y: u32, c: [f32; 3], a: f32) {
        if a <= 0.0 {
            return;
        }
        let p = &mut self.buf[(y * self.n + x) as usize];
        let na = a + p[3] * (1.0 - a);
        for k in 0..3 {
            p[k] = (c[k] * a + p[k] * p[3] * (1.0 - a)) / na.max(1e-6);
        }
        p[3] = na;
    }

    /// A line from a to b with half-width tapering from `h0` to `h1`, colour from `c0` to `c1`.
    fn stroke(&mut self, a: [f32; 2], b: [f32; 2], h0: f32, h1: f32, c0: [f32; 3], c1: [f32; 3]) {
        let hmax = h0.max(h1);
        let lo = [a[0].min(b[0]) - hmax, a[1].min(b[1]) - hmax];
        let hi = [a[0].max(b[0]) + hmax, a[1].max(b[1]) + hmax];
        let (x0, x1, y0, y1) = self.range(lo, hi);
        let tx = self.texel();
        let (vx, vy) = (b[0] - a[0], b[1] - a[1]);
        let len2 = (vx * vx + vy * vy).max(1e-12);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let p = self.pos(x, y);
                let (wx, wy) = (p[0] - a[0], p[1] - a[1]);
                let s = ((wx * vx + wy * vy) / len2).clamp(0.0, 1.0);
                let (dx, dy) = (wx - vx * s, wy - vy * s);
                let d = (dx * dx + dy * dy).sqrt();
                let h = h0 + (h1 - h0) * s;
                // Thin lines keep at least ~0.7 texel of coverage so that they survive.
                let cov = ((h.max(0.35 * tx) - d) / tx + 0.5).clamp(0.0, 1.0);
                self.over(x, y, lerp3(c0, c1, s), cov);
            }
        }
    }

    /// A leaf blade from `base` towards `dir` (unit), of length `len` and greatest half-width
    /// `half`, serrated, with a midrib and lateral veins; `col` is the blade's mean colour.
    fn leaf(&mut self, base: [f32; 2], dir: [f32; 2], len: f32, half: f32, col: [f32; 3]) {
        let side = [-dir[1], dir[0]];
        let tip = [base[0] + dir[0] * len, base[1] + dir[1] * len];
        let r = half + 0.01;
        let lo = [base[0].min(tip[0]) - r, base[1].min(tip[1]) - r];
        let hi = [base[0].max(tip[0]) + r, base[1].max(tip[1]) + r];
        let (x0, x1, y0, y1) = self.range(lo, hi);
        let tx = self.texel();
        let dark = scale3(col, 0.72);
        let light = lerp3(col, [0.46, 0.58, 0.30], 0.25);
        let vein = lerp3(col, [0.70, 0.78, 0.45], 0.45);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let p = self.pos(x, y);
                let (wx, wy) = (p[0] - base[0], p[1] - base[1]);
                let u = (wx * dir[0] + wy * dir[1]) / len; // 0 base .. 1 tip
                let v = wx * side[0] + wy * side[1];
                if !(0.0..=1.0).contains(&u) {
                    continue;
                }
                let w = half
                    * (std::f32::consts::PI * u.powf(0.75))
                        .sin()
                        .max(0.0)
                        .powf(0.8);
                let tooth = 1.0 - 0.08 * (u * 14.0).fract();
                let edge = w * tooth;
                let cov = ((edge - v.abs()) / tx + 0.5).clamp(0.0, 1.0);
                if cov <= 0.0 {
                    continue;
                }
                let g = 1.0 - (v.abs() / w.max(1e-4)).min(1.0);
                // Lit along one half of the blade (a slight fold), darker towards the edges.
                let mut c = lerp3(
                    dark,
                    light,
                    0.3 + 0.45 * g + if v > 0.0 { 0.2 } else { 0.0 },
                );
                let lateral =
                    ((u * 7.0 - v.abs() / half.max(1e-4) * 1.6).fract() - 0.5).abs() < 0.06;
                if v.abs() < 0.004 + 0.004 * (1.0 - u) {
                    c = vein;
                } else if lateral && g > 0.15 {
                    c = lerp3(c, vein, 0.35);
                }
                self.over(x, y, c, cov);
            }
        }
    }

    /// RGBA8 texture; transparent texels take the mean opaque colour.
    fn finish(self) -> LeafTexture {
        let mut sum = [0.0f64; 3];
        let mut wsum = 0.0f64;
        for p in &self.buf {
            for k in 0..3 {
                sum[k] += (p[k] * p[3]) as f64;
            }
            wsum += p[3] as f64;
        }
        let mean = if wsum > 0.0 {
            [
                (sum[0] / wsum) as f32,
                (sum[1] / wsum) as f32,
                (sum[2] / wsum) as f32,
            ]
        } else {
            [0.0; 3]
        };
        let mut rgba = Vec::with_capacity(self.buf.len() * 4);
        for p in &self.buf {
            let c = if p[3] > 0.0 {
                lerp3(mean, [p[0], p[1], p[2]], (p[3] * 4.0).min(1.0))
            } else {
                mean
            };
            for k in c {
                rgba.push((k.clamp(0.0, 1.0) * 255.0).round() as u8);
            }
            rgba.push((p[3].clamp(0.0, 1.0) * 255.0).round() as u8);
        }
        LeafTexture {
            width: self.n,
            height: self.h,
            rgba,
        }
    }
}

fn rotate2(d: [f32; 2], deg: f32) -> [f32; 2] {
    let (s, c) = deg.to_radians().sin_cos();
    [d[0] * c - d[1] * s, d[0] * s + d[1] * c]
}

/// A cluster of nine prunus-like leaves on a twig (card aspect 1).
fn broadleaf(n: u32) -> LeafTexture {
    let aspect = crate::skeleton::leaf_aspect(LeafKind::Broadleaf);
    let mut cv = Canvas::new(n, aspect);
    let twig = [0.30, 0.24, 0.17]; // sRGB
    let greens = [
        [0.21, 0.35, 0.13],
        [0.25, 0.39, 0.15],
        [0.18, 0.31, 0.12],
        [0.27, 0.41, 0.17],
        [0.22, 0.37, 0.15],
    ];
    // The twig: up the middle, slightly curved.
    let axis = |t: f32| [0.03 * (t * 3.0).sin(), t];
    for k in 0..8 {
        let (t0, t1) = (k as f32 * 0.07, (k + 1) as f32 * 0.07);
        cv.stroke(
            axis(t0),
            axis(t1),
            0.009 - 0.0008 * k as f32,
            0.009 - 0.0008 * (k + 1) as f32,
            twig,
            twig,
        );
    }
    // Leaves: (position along the twig, side, angle from the twig in degrees, length).
    // Lower leaves are drawn first, so upper ones overlap them as on a real shoot.
    let leaves: [(f32, f32, f32, f32); 9] = [
        (0.06, -1.0, 62.0, 0.40),
        (0.10, 1.0, 58.0, 0.42),
        (0.20, -1.0, 48.0, 0.44),
        (0.26, 1.0, 44.0, 0.44),
        (0.36, -1.0, 36.0, 0.42),
        (0.42, 1.0, 30.0, 0.40),
        (0.50, -1.0, 18.0, 0.38),
        (0.54, 1.0, 12.0, 0.37),
        (0.56, 0.0, 0.0, 0.42),
    ];
    for (i, &(t, side, ang, len)) in leaves.iter().enumerate() {
        let j = hash01(i as u64 * 7 + 3) as f32;
        let a = axis(t);
        let dir = rotate2([0.0, 1.0], -side * (ang + 8.0 * (j - 0.5)));
        // A short petiole, then the blade.
        let pet = 0.035;
        let b = [a[0] + dir[0] * pet, a[1] + dir[1] * pet];
        cv.stroke(a, b, 0.004, 0.003, twig, lerp3(twig, greens[0], 0.5));
        let col = scale3(greens[i % greens.len()], 0.92 + 0.16 * j);
        let len = len * (1.0 + 0.12 * j);
        // Keep the blade inside the card.
        let len = len.min((0.98 - b[1]) / dir[1].max(0.3)).min(0.5);
        cv.leaf(b, dir, len, len * 0.3, col);
    }
    cv.finish()
}

/// A needle-covered shoot spray with side shoots (card aspect [`leaf_aspect`]).
///
/// [`leaf_aspect`]: crate::skeleton::leaf_aspect
fn needles(n: u32) -> LeafTexture {
    let aspect = crate::skeleton::leaf_aspect(LeafKind::Needles);
    let mut cv = Canvas::new(n, aspect);
    let twig = [0.30, 0.22, 0.15]; // sRGB
    let deep = [0.09, 0.18, 0.11]; // dark blue-green, inside the shoot
    let tip = [0.19, 0.30, 0.17]; // lighter at needle tips
    let half_w = aspect * 0.5 - 0.01;
    // Shoots: the leader up the middle, then side shoots in opposite pairs, shorter to the tip.
    let mut shoots: Vec<([f32; 2], [f32; 2], f32)> = vec![([0.0, 0.0], [0.0, 0.9], 1.0)];
    for k in 0..7 {
        let t = 0.05 + 0.115 * k as f32;
        for side in [-1.0f32, 1.0] {
            let j = hash01(k as u64 * 2 + (side > 0.0) as u64 + 40) as f32;
            let ang = (56.0 + 10.0 * j - 3.0 * k as f32).to_radians();
            let reach = (half_w - 0.05) * (1.0 - 0.62 * t) * (0.9 + 0.1 * j);
            let len = (reach / ang.sin()).min(0.95 - t);
            let start = [0.0, t];
            let end = [side * ang.sin() * len, t + ang.cos() * len];
            shoots.push((start, end, 0.8));
        }
    }
    // Twigs first, needles over them.
    for (a, b, w) in &shoots {
        cv.stroke(*a, *b, 0.006 * w, 0.002, twig, twig);
    }
    let mut seed = 0u64;
    for (a, b, w) in &shoots {
        let (vx, vy) = (b[0] - a[0], b[1] - a[1]);
        let len = (vx * vx + vy * vy).sqrt();
        let dir = [vx / len, vy / len];
        let steps = (len / 0.0065) as u32;
        for s in 0..steps {
            let f = (s as f32 + 0.5) / steps as f32;
            let p = [a[0] + vx * f, a[1] + vy * f];
            for side in [-1.0f32, 1.0] {
                seed += 1;
                let j = hash01(seed * 31 + 7) as f32;
                // Needles point forward and out; shorter towards each shoot's tip.
                let ang = side * (35.0 + 30.0 * j);
                let nl = (0.055 + 0.04 * w) * (1.0 - 0.4 * f) * (0.8 + 0.4 * j);
                let d = rotate2(dir, ang);
                let e = [p[0] + d[0] * nl, p[1] + d[1] * nl];
                let k = 0.85 + 0.3 * hash01(seed * 13 + 1) as f32;
                cv.stroke(
                    p,
                    e,
                    0.0048,
                    0.0022,
                    scale3(deep, k),
                    scale3(lerp3(deep, tip, 0.8), k),
                );
            }
        }
    }
    cv.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_leaves_have_two_sides_and_a_normal_map() {
        for kind in [LeafKind::Chestnut, LeafKind::Beech] {
            let m = leaf_maps(kind);
            assert_eq!(m.front.width, m.back.width);
            // Same cut-out on both sides.
            let alpha = |t: &LeafTexture| t.rgba.chunks_exact(4).map(|p| p[3]).collect::<Vec<_>>();
            assert_eq!(alpha(&m.front), alpha(&m.back), "{kind:?}");
            let c = coverage(&m.front);
            assert!((0.3..0.8).contains(&c), "{kind:?}: coverage {c}");
            // The back is paler than the front.
            let mean = |t: &LeafTexture| {
                let v: Vec<&[u8]> = t.rgba.chunks_exact(4).filter(|p| p[3] >= 128).collect();
                v.iter()
                    .map(|p| p[0] as f64 + p[1] as f64 + p[2] as f64)
                    .sum::<f64>()
                    / v.len() as f64
            };
            assert!(
                mean(&m.back) > 1.3 * mean(&m.front),
                "{kind:?}: back not paler"
            );
            // The normal map bends somewhere (veins) and is unit length everywhere.
            let mut bent = 0;
            for p in m.normal.rgba.chunks_exact(4) {
                let v = [p[0], p[1], p[2]].map(|c| c as f32 / 127.5 - 1.0);
                let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                assert!((l - 1.0).abs() < 0.03 && v[2] > 0.0, "{kind:?}: {v:?}");
                bent += (v[2] < 0.97) as usize;
            }
            assert!(bent > 500, "{kind:?}: only {bent} texels off flat");
        }
    }

    #[test]
    fn cards_are_mostly_opaque() {
        for kind in [LeafKind::Broadleaf, LeafKind::Needles] {
            let t = leaf_texture(kind);
            assert_eq!(t.rgba.len(), (t.width * t.height * 4) as usize);
            let c = coverage(&t);
            eprintln!("{kind:?}: coverage {c}");
            assert!((0.45..0.85).contains(&c), "{kind:?}: coverage {c}");
            // The edge rows stay transparent (no clamped texels smeared over the card edge).
            let n = t.width as usize;
            for x in 0..n {
                assert!(t.rgba[x * 4 + 3] < 128, "{kind:?}: top row opaque at {x}");
            }
        }
    }

    #[test]
    fn colours_are_green_not_brown() {
        for kind in [LeafKind::Broadleaf, LeafKind::Needles] {
            let t = leaf_texture(kind);
            let (mut r, mut g, mut b, mut w) = (0.0, 0.0, 0.0, 0.0);
            for p in t.rgba.chunks_exact(4).filter(|p| p[3] >= 128) {
                r += p[0] as f64;
                g += p[1] as f64;
                b += p[2] as f64;
                w += 1.0;
            }
            let (r, g, b) = (r / w, g / w, b / w);
            assert!(g > r * 1.2 && g > b * 1.1, "{kind:?}: mean {r} {g} {b}");
            if kind == LeafKind::Needles {
                // Dark blue-green: darker than the broadleaf, blue close to red.
                assert!(g < 90.0 && b > 0.6 * r, "needles mean {r} {g} {b}");
            }
        }
    }
}
