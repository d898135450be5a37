//! Single leaves (`leaves: chestnut`, `beech`): the outline of each kind, and the leaf mesh
//! (`blade: ROWS FOLD CURL`) built around it — a point at the petiole's base, one or two rows of
//! three vertices across the blade (left edge, midrib, right edge), a point at the tip; 4 or 8
//! triangles, the petiole included. The texture (`texture::single_leaf`) draws the leaf inside
//! the same outline, so the polygon only has to enclose it: its row widths are found by
//! [`LeafShape::new`] so that every edge lies outside the outline.
//!
//! Leaf coordinates: x across (along the turtle's L, in leaf lengths), y along the midrib from
//! the petiole's base (0) to the tip (1), z along the front-face normal (the turtle's U).

use crate::lsystem::{Blade, LeafKind};

/// Outline parameters of a single-leaf kind.
#[derive(Debug, Clone, Copy)]
pub struct Outline {
    /// Fraction of the length taken by the petiole.
    pub petiole: f32,
    /// Half-width of the petiole, leaf lengths.
    pub petiole_half: f32,
    /// Greatest half-width of the blade, leaf lengths.
    pub half: f32,
    /// Exponents of the blade profile `s^a (1 − s)^b` (s from blade base to tip).
    pub a: f32,
    /// See `a`.
    pub b: f32,
    /// Marginal teeth per side.
    pub teeth: f32,
    /// Depth of the teeth, fraction of the local half-width.
    pub tooth_depth: f32,
    /// Pairs of lateral veins.
    pub veins: f32,
}

impl Outline {
    /// The outline of a single-leaf kind (`None` for the card kinds).
    pub fn of(kind: LeafKind) -> Option<Outline> {
        match kind {
            // Castanea sativa: 15–25 cm, oblong-lanceolate (≈ 1:3.8), acuminate, coarse
            // bristle-tipped teeth, 15–20 straight parallel veins each ending in a tooth.
            LeafKind::Chestnut => Some(Outline {
                petiole: 0.1,
                petiole_half: 0.006,
                half: 0.118,
                a: 0.95,
                b: 1.2,
                teeth: 17.0,
                tooth_depth: 0.14,
                veins: 17.0,
            }),
            // Fagus sylvatica: 5–10 cm, ovate-elliptic (≈ 1:1.6), wavy margin, 6–8 veins.
            LeafKind::Beech => Some(Outline {
                petiole: 0.1,
                petiole_half: 0.008,
                half: 0.29,
                a: 0.75,
                b: 1.1,
                teeth: 7.0,
                tooth_depth: 0.05,
                veins: 7.0,
            }),
            _ => None,
        }
    }

    /// Where the blade is widest, as s (blade base 0 .. tip 1).
    fn widest(&self) -> f32 {
        self.a / (self.a + self.b)
    }

    /// Blade half-width without teeth at `y` (leaf lengths), 0 outside the blade; the petiole
    /// is not included.
    pub fn blade_half(&self, y: f32) -> f32 {
        let s = (y - self.petiole) / (1.0 - self.petiole);
        if !(0.0..=1.0).contains(&s) {
            return 0.0;
        }
        let m = self.widest();
        let peak = m.powf(self.a) * (1.0 - m).powf(self.b);
        self.half * s.powf(self.a) * (1.0 - s).powf(self.b) / peak
    }

    /// Half-width of the petiole at `y` (0 beyond it); it tapers to a point over the first
    /// 3 % of the length, where it joins the twig (the mesh starts with a point there).
    pub fn petiole_width(&self, y: f32) -> f32 {
        if (0.0..=self.petiole + 0.02).contains(&y) {
            self.petiole_half * (y / 0.03).min(1.0)
        } else {
            0.0
        }
    }

    /// Half-width of the leaf at `y` with teeth and petiole (what the texture draws).
    pub fn half_width(&self, y: f32) -> f32 {
        let s = (y - self.petiole) / (1.0 - self.petiole);
        let pet = self.petiole_width(y);
        if !(0.0..=1.0).contains(&s) {
            return pet;
        }
        // Teeth: each rises slowly towards the tip and drops at its point (serrate).
        let f = (s * self.teeth).fract();
        let tooth = 1.0 - self.tooth_depth * (1.0 - f.powf(1.5));
        (self.blade_half(y) * tooth).max(pet)
    }

    /// Width of the texture's footprint across, leaf lengths (the leaf is centred in it).
    pub fn texture_width(&self) -> f32 {
        2.0 * (self.half + 0.01)
    }
}

/// A unit leaf mesh in leaf coordinates (see the module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct LeafShape {
    /// Vertex positions (x across, y along, z normal), leaf lengths.
    pub positions: Vec<[f32; 3]>,
    /// Unit normals of the front face, leaf coordinates.
    pub normals: Vec<[f32; 3]>,
    /// Texture coordinates (v = 1 at the petiole's base, 0 at the tip).
    pub uvs: Vec<[f32; 2]>,
    /// Triangles (front face counter-clockwise about its normal in a right-handed frame;
    /// the mesher checks the winding per triangle in the world frame anyway).
    pub indices: Vec<u32>,
}

impl LeafShape {
    /// A card: the quad of width `aspect` × length 1 (2 triangles).
    pub fn card(aspect: f32) -> LeafShape {
        let h = aspect * 0.5;
        LeafShape {
            positions: vec![[-h, 0.0, 0.0], [h, 0.0, 0.0], [h, 1.0, 0.0], [-h, 1.0, 0.0]],
            normals: vec![[0.0, 0.0, 1.0]; 4],
            uvs: vec![[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]],
            indices: vec![0, 1, 2, 0, 2, 3],
        }
    }

    /// The leaf mesh of a kind: a card for the card kinds, else the blade enclosing the
    /// kind's outline, folded and curled as `blade` says.
    pub fn new(kind: LeafKind, blade: Blade) -> LeafShape {
        let Some(o) = Outline::of(kind) else {
            return LeafShape::card(crate::skeleton::leaf_aspect(kind));
        };
        if blade.rows == 0 {
            return LeafShape::card(o.texture_width());
        }
        // Rows along y: the base point, 1–2 rows, the tip point.
        let ys: Vec<f32> = match blade.rows {
            1 => vec![0.0, o.petiole + 0.48 * (1.0 - o.petiole), 1.0],
            _ => vec![
                0.0,
                o.petiole + 0.12 * (1.0 - o.petiole),
                o.petiole + 0.6 * (1.0 - o.petiole),
                1.0,
            ],
        };
        let widths = enclosing_widths(&o, &ys);
        let (fold, curl) = (
            (blade.fold as f32).to_radians(),
            (blade.curl as f32).to_radians(),
        );
        // The midrib: a polyline bending by `curl` in total (towards −z), arc length = y.
        let mut mid = vec![[0.0f32, 0.0]; ys.len()]; // (y, z) per row
        for k in 1..ys.len() {
            let ym = 0.5 * (ys[k] + ys[k - 1]);
            let a = curl * ym;
            let d = ys[k] - ys[k - 1];
            mid[k] = [mid[k - 1][0] + d * a.cos(), mid[k - 1][1] - d * a.sin()];
        }
        let mut sh = LeafShape {
            positions: Vec::new(),
            normals: Vec::new(),
            uvs: Vec::new(),
            indices: Vec::new(),
        };
        let u_of = |x: f32| 0.5 + x / o.texture_width();
        let mut rows: Vec<Vec<u32>> = Vec::new();
        for (k, &y) in ys.iter().enumerate() {
            let a = curl * y;
            // Frame at this row: along (0, cos a, −sin a), normal (0, sin a, cos a).
            let n = [0.0, a.sin(), a.cos()];
            let [my, mz] = mid[k];
            let mut row = Vec::new();
            let w = widths[k];
            let xs: &[f32] = if w == 0.0 { &[0.0] } else { &[-1.0, 0.0, 1.0] };
            for &side in xs {
                let x = side * w;
                // The half rises by `fold` about the midrib.
                let up = x.abs() * fold.sin();
                let pos = [x * fold.cos(), my + n[1] * up, mz + n[2] * up];
                let nrm = if side == 0.0 {
                    n
                } else {
                    // Normal of the half: the row normal tilted towards the midrib.
                    let (s, c) = (fold.sin(), fold.cos());
                    [-side * s, n[1] * c, n[2] * c]
                };
                row.push(sh.positions.len() as u32);
                sh.positions.push(pos);
                sh.normals.push(nrm);
                sh.uvs.push([u_of(x), 1.0 - y]);
            }
            rows.push(row);
        }
        for k in 0..rows.len() - 1 {
            let (r0, r1) = (&rows[k], &rows[k + 1]);
            match (r0.len(), r1.len()) {
                (1, 3) => sh
                    .indices
                    .extend_from_slice(&[r0[0], r1[1], r1[0], r0[0], r1[2], r1[1]]),
                (3, 1) => sh
                    .indices
                    .extend_from_slice(&[r0[0], r0[1], r1[0], r0[1], r0[2], r1[0]]),
                _ => {
                    for j in 0..2 {
                        let (a, b, c, d) = (r0[j], r0[j + 1], r1[j], r1[j + 1]);
                        sh.indices.extend_from_slice(&[a, b, d, a, d, c]);
                    }
                }
            }
        }
        sh
    }

    /// Triangles per leaf.
    pub fn triangles(&self) -> usize {
        self.indices.len() / 3
    }
}

/// Half-widths at rows `ys` (0 at the first and last) such that the polygon through them
/// encloses the outline (with a margin of 1.5 % of the greatest half-width).
fn enclosing_widths(o: &Outline, ys: &[f32]) -> Vec<f32> {
    let margin = 0.015 * o.half;
    let need = |y: f32| o.blade_half(y).max(o.petiole_width(y)) + margin * (y / 0.05).min(1.0);
    let last = ys.len() - 1;
    let mut w: Vec<f32> = ys.iter().map(|&y| need(y)).collect();
    w[0] = 0.0;
    w[last] = 0.0;
    for _ in 0..200 {
        let mut moved = false;
        for k in 0..last {
            for i in 1..32 {
                let f = i as f32 / 32.0;
                let y = ys[k] + (ys[k + 1] - ys[k]) * f;
                let have = w[k] * (1.0 - f) + w[k + 1] * f;
                let d = need(y) - have;
                if d > 1e-5 {
                    moved = true;
                    // Raise the interior ends of this edge in proportion to their weight.
                    let (wa, wb) = (
                        if k > 0 { 1.0 - f } else { 0.0 },
                        if k + 1 < last { f } else { 0.0 },
                    );
                    let s = wa * wa + wb * wb;
                    if s > 0.0 {
                        w[k] += d * wa / s * 0.5;
                        w[k + 1] += d * wb / s * 0.5;
                    }
                }
            }
        }
        if !moved {
            break;
        }
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blades_enclose_their_outline() {
        for kind in [LeafKind::Chestnut, LeafKind::Beech] {
            let o = Outline::of(kind).unwrap();
            for rows in [1, 2] {
                let sh = LeafShape::new(
                    kind,
                    Blade {
                        rows,
                        fold: 0.0,
                        curl: 0.0,
                    },
                );
                assert_eq!(sh.triangles(), 4 * rows as usize, "{kind:?}");
                // Flat: the polygon's half-width at y is the largest |x| of the edge there.
                let (mut leaf_area, mut poly_area) = (0.0, 0.0);
                for i in 0..200 {
                    let y = (i as f32 + 0.5) / 200.0;
                    let mut wmax: f32 = 0.0;
                    for t in sh.indices.chunks_exact(3) {
                        for e in 0..3 {
                            let (p, q) = (
                                sh.positions[t[e] as usize],
                                sh.positions[t[(e + 1) % 3] as usize],
                            );
                            if (p[1] - y) * (q[1] - y) <= 0.0 && (p[1] - q[1]).abs() > 1e-6 {
                                let f = (y - p[1]) / (q[1] - p[1]);
                                wmax = wmax.max((p[0] + (q[0] - p[0]) * f).abs());
                            }
                        }
                    }
                    assert!(
                        wmax + 1e-4 >= o.half_width(y),
                        "{kind:?} rows {rows} at y {y}"
                    );
                    leaf_area += o.half_width(y);
                    poly_area += wmax;
                }
                eprintln!(
                    "{kind:?} rows {rows}: polygon / leaf area {}",
                    poly_area / leaf_area
                );
            }
        }
    }
}
