//! GPSS07 §4.1: the leaves of a plant clustered into a user-set number of planes, each plane
//! a rectangle bounding the projection of its leaves (so the cloud bounds the shape, fig. 1).
//!
//! The clustering is the plane-space k-means of \[GSSK05\] with the error of \[BCF05\] folded in:
//! a leaf's cost on a plane is its squared distance from the plane (weighted [`NORMAL_WEIGHT`]
//! times more than spread along it, so clusters come out thin and flat), its squared distance
//! from the cluster's centre along the plane (so a plane's rectangle stays small: billboards
//! are not infinite planes) and a term for the leaf standing edge-on to the plane
//! ([`EDGE_ON_WEIGHT`]: leaves turned like their plane keep its slab thin). A cluster's plane is the
//! least-squares plane of its leaves' vertices (smallest principal axis), or the mean leaf
//! normal where the leaves do not span a plane. Seeds are farthest-point samples (deterministic); an emptied cluster is
//! re-seeded at the worst-fitting leaf. Every leaf belongs to exactly one plane.

use glam::{Vec2, Vec3};
use sylvan_plant::Plant;

/// Plane distance counts this many times more than spread along the plane: clusters are thin
/// slabs, so leaves drawn on their billboard are seen where they are from any side (parallax
/// error ∝ thickness). Measured on one chestnut at 400 px (ꟻLIP vs 16-spp geometry, 260
/// planes, 640×480): 16 → 0.153, 256 → 0.145, 1000 → 0.138; at 900×900 with the half turn:
/// 1000 → 0.150, 4000 → 0.144, 16000 → 0.142, 10⁵ → 0.140 (thinner slabs span more of the
/// crown, so their rectangles — the fill — grow: 4000 kept).
pub const NORMAL_WEIGHT: f32 = 4000.0;
/// Weight of a leaf standing edge-on to its plane (× the leaf's squared size × (1 − |cos|) of
/// the angle between their normals). Measured on one chestnut (ꟻLIP vs 16-spp geometry,
/// 900×900, at 800 / 400 px) when planes were drawn flat (a leaf face-on to the eye on a plane
/// seen edge-on then shrank to a sliver): 0 → 0.131 / 0.113, 1000 → 0.127 / 0.107, 5000 →
/// 0.122 / 0.101, 20000 → 0.124 / 0.100 (5000 kept; planes are now drawn as slabs, which
/// removed the slivers, and it was not measured again).
pub const EDGE_ON_WEIGHT: f32 = 5000.0;

/// One leaf of the plant: its triangles and their summary.
#[derive(Debug, Clone)]
pub struct Leaf {
    /// Its triangles (vertex numbers in `Plant::leaves`).
    pub triangles: Vec<[u32; 3]>,
    /// Its distinct vertices.
    pub vertices: Vec<u32>,
    /// Area-weighted centre.
    pub centre: Vec3,
    /// Unit front normal (area-weighted mean of its triangles').
    pub normal: Vec3,
    /// Area (m²).
    pub area: f32,
    /// Largest distance of a vertex from the centre.
    pub size: f32,
    /// The part of the leaf image this leaf shows (min, max): the whole image, or, for a
    /// part of a bent leaf ([`parts`]), its side of the lines it was cut along.
    pub uv_clip: [Vec2; 2],
}

/// The plant's leaves, one per `hierarchy.leaf_first_index` range (or per 6 indices when the
/// plant has no hierarchy) — with `cut`, each bent one as its flat [`parts`]; leaves without
/// area are kept (they belong to a plane too).
pub fn leaves(plant: &Plant, cut: bool) -> Vec<Leaf> {
    let m = &plant.leaves;
    let firsts: Vec<u32> = if plant.hierarchy.leaf_first_index.len() >= 2 {
        plant.hierarchy.leaf_first_index.clone()
    } else {
        (0..=(m.indices.len() as u32).div_ceil(6))
            .map(|i| (i * 6).min(m.indices.len() as u32))
            .collect()
    };
    let mut out = Vec::with_capacity(firsts.len().saturating_sub(1));
    for w in firsts.windows(2) {
        let r = w[0]..w[1].min(m.indices.len() as u32);
        let tris: Vec<[u32; 3]> = m.indices[r.start as usize..r.end.max(r.start) as usize]
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect();
        let whole = [Vec2::splat(f32::MIN), Vec2::splat(f32::MAX)];
        let depth = if cut { MAX_SPLITS } else { 0 };
        for (p, clip) in parts(m, tris, whole, depth) {
            if let Some(l) = summarize(plant, p, clip) {
                out.push(l);
            }
        }
    }
    out
}

/// A leaf is cut when its triangles' normals spread more than this (area-weighted RMS of
/// `|n − n̄|`, about the angle in radians: 0.1 ≈ a 6° spread, a fold of about 12°) — the
/// shading of an affine normal field over the leaf cannot follow a fold, and one plane
/// cannot hold both its halves.
pub const BENT: f32 = 0.1;
/// A cut is made only where it leaves at most this share of the spread.
pub const CUT_GAIN: f32 = 0.75;
/// A leaf is cut at most this many times deep (at most 2^`MAX_SPLITS` parts). Measured on one
/// chestnut at 800 / 400 px (ꟻLIP ratio to 1-spp geometry): uncut 1.56 / 1.14, one cut
/// 1.26 / 1.07, two cuts 1.43 / 1.12 (four parts per leaf: four times the list entries, so
/// the shader's entry budget per pixel falls back to the low-resolution tiles sooner).
pub const MAX_SPLITS: u32 = 1;

/// How far a set of triangles is from flat: the area-weighted RMS of `|n − n̄|` over their
/// unit normals `n` about the mean `n̄` (0 for a flat leaf, about the fold angle / 2 in
/// radians for one folded in two halves), and their area.
fn bend(m: &sylvan_plant::Mesh, tris: &[[u32; 3]]) -> (f32, f32) {
    let normals: Vec<(Vec3, f32)> = tris
        .iter()
        .filter_map(|t| {
            let [a, b, c] = t.map(|i| Vec3::from(m.positions[i as usize]));
            let cr = (b - a).cross(c - a);
            let area = cr.length() * 0.5;
            (area > 0.0).then(|| (cr.normalize(), area))
        })
        .collect();
    let total: f32 = normals.iter().map(|x| x.1).sum();
    if total <= 0.0 {
        return (0.0, 0.0);
    }
    let mean = normals
        .iter()
        .map(|(n, a)| *n * *a)
        .sum::<Vec3>()
        .normalize_or(Vec3::Y);
    let ss: f32 = normals
        .iter()
        .map(|(n, a)| (*n - mean).length_squared() * a)
        .sum();
    ((ss / total).sqrt(), total)
}

/// A leaf bent out of one plane (folded about its midrib, curled to its tip) cut into parts
/// that each are nearly flat: while a part's normals spread more than [`BENT`], it is cut in
/// two at the middle of its `uv` box (on the nearest line of vertices, when one is within a
/// quarter of the box: a midrib) across `u` or across `v` — whichever leaves the smaller
/// spread, and only if that leaves at most [`CUT_GAIN`] of it. Each side keeps the triangles
/// reaching into it (one across the cut goes to both, so a side's triangles cover its part of
/// the image, which its cell lists are made from) and shows only the image on its side
/// (`uv_clip`): the parts show the leaf image exactly once between them. Axis-aligned cuts in
/// the leaf image suit the way leaf textures are laid out (midrib along `v`: a fold is cut
/// along it); the spread, not the position residual, picks the cut (measured on the chestnut:
/// the smallest affine position residual cut across the midrib's droop instead of along its
/// fold, 1.43× against 1.26× at 800 px). Returns the parts with their image clips.
pub fn parts(
    m: &sylvan_plant::Mesh,
    tris: Vec<[u32; 3]>,
    clip: [Vec2; 2],
    depth: u32,
) -> Vec<(Vec<[u32; 3]>, [Vec2; 2])> {
    let (r0, _) = bend(m, &tris);
    if depth == 0 || tris.len() < 2 || r0 <= BENT {
        return vec![(tris, clip)];
    }
    let mut lo = Vec2::splat(f32::MAX);
    let mut hi = Vec2::splat(f32::MIN);
    for &i in tris.iter().flatten() {
        lo = lo.min(Vec2::from(m.uvs[i as usize]));
        hi = hi.max(Vec2::from(m.uvs[i as usize]));
    }
    let lo = lo.max(clip[0]);
    let hi = hi.min(clip[1]);
    // A vertex within 10⁻⁴ of the box of the cut is on it (touches both sides, reaches into
    // neither).
    let eps = 1e-4 * (hi - lo).max_element().max(1e-6);
    let sides = |axis: usize, c: f32| {
        let below = |t: &&[u32; 3]| t.iter().any(|&i| m.uvs[i as usize][axis] < c - eps);
        let above = |t: &&[u32; 3]| t.iter().any(|&i| m.uvs[i as usize][axis] > c + eps);
        let a: Vec<[u32; 3]> = tris.iter().filter(below).copied().collect();
        let b: Vec<[u32; 3]> = tris.iter().filter(above).copied().collect();
        (a, b)
    };
    // (spread left, axis, cut, the two sides)
    type Cut = (f32, usize, f32, Vec<[u32; 3]>, Vec<[u32; 3]>);
    let mut best: Option<Cut> = None;
    for axis in 0..2 {
        // At the middle of the box, moved onto the nearest vertex line within a quarter of
        // the box (a midrib), so no triangle reaches across the cut.
        let mid = (lo[axis] + hi[axis]) * 0.5;
        let c = tris
            .iter()
            .flatten()
            .map(|&i| m.uvs[i as usize][axis])
            .filter(|x| (x - mid).abs() <= 0.25 * (hi[axis] - lo[axis]))
            .min_by(|a, b| (a - mid).abs().total_cmp(&(b - mid).abs()))
            .unwrap_or(mid);
        let (a, b) = sides(axis, c);
        if a.is_empty() || b.is_empty() {
            continue;
        }
        let ((ra, wa), (rb, wb)) = (bend(m, &a), bend(m, &b));
        let r = ((ra * ra * wa + rb * rb * wb) / (wa + wb).max(1e-30)).sqrt();
        if best.as_ref().is_none_or(|x| r < x.0) {
            best = Some((r, axis, c, a, b));
        }
    }
    let Some((_, axis, c, a, b)) = best.filter(|b| b.0 <= CUT_GAIN * r0) else {
        return vec![(tris, clip)];
    };
    let (mut clip_a, mut clip_b) = (clip, clip);
    clip_a[1][axis] = c;
    clip_b[0][axis] = c;
    let mut out = parts(m, a, clip_a, depth - 1);
    out.extend(parts(m, b, clip_b, depth - 1));
    out
}

/// A leaf's summary from its triangles (`None` without any vertex).
fn summarize(plant: &Plant, triangles: Vec<[u32; 3]>, uv_clip: [Vec2; 2]) -> Option<Leaf> {
    let m = &plant.leaves;
    let (mut centre, mut normal, mut area) = (Vec3::ZERO, Vec3::ZERO, 0.0f32);
    let mut vertices: Vec<u32> = Vec::with_capacity(triangles.len() * 3);
    for t in &triangles {
        let [a, b, c] = t.map(|i| Vec3::from(m.positions[i as usize]));
        let cr = (b - a).cross(c - a);
        let ar = cr.length() * 0.5;
        centre += (a + b + c) / 3.0 * ar;
        normal += cr * 0.5;
        area += ar;
        for &i in t {
            if !vertices.contains(&i) {
                vertices.push(i);
            }
        }
    }
    if vertices.is_empty() {
        return None;
    }
    let mean = vertices
        .iter()
        .map(|&i| Vec3::from(m.positions[i as usize]))
        .sum::<Vec3>()
        / vertices.len() as f32;
    let centre = if area > 0.0 { centre / area } else { mean };
    let normal = if normal.length_squared() > 0.0 {
        normal.normalize()
    } else {
        // Degenerate leaf: the mesh's own normal.
        Vec3::from(m.normals[vertices[0] as usize]).normalize_or(Vec3::Y)
    };
    let size = vertices
        .iter()
        .map(|&i| Vec3::from(m.positions[i as usize]).distance(centre))
        .fold(0.0, f32::max);
    Some(Leaf {
        triangles,
        vertices,
        centre,
        normal,
        area,
        size,
        uv_clip,
    })
}

/// One billboard: a rectangle on a plane, holding some leaves.
#[derive(Debug, Clone, PartialEq)]
pub struct Plane {
    /// Unit normal (the "front" side: list order is front to back from this side).
    pub normal: Vec3,
    /// First in-plane axis (unit).
    pub u: Vec3,
    /// Second in-plane axis (unit, `normal × u`).
    pub v: Vec3,
    /// The plane's origin (a point on it; plane coordinates are measured from here).
    pub origin: Vec3,
    /// Rectangle in plane coordinates (metres along `u`, `v`).
    pub min: Vec2,
    /// Rectangle maximum.
    pub max: Vec2,
    /// Leaf numbers (into [`leaves`]'s list).
    pub leaves: Vec<u32>,
}

impl Plane {
    /// Plane coordinates of a point (its orthogonal projection).
    pub fn project(&self, p: Vec3) -> Vec2 {
        let d = p - self.origin;
        Vec2::new(d.dot(self.u), d.dot(self.v))
    }

    /// Signed distance of a point in front of the plane.
    pub fn height(&self, p: Vec3) -> f32 {
        (p - self.origin).dot(self.normal)
    }

    /// The rectangle's corner `(s, t)` in model space.
    pub fn point(&self, st: Vec2) -> Vec3 {
        self.origin + self.u * st.x + self.v * st.y
    }
}

/// A cluster while iterating: centre and plane.
#[derive(Clone, Copy)]
struct Fit {
    centre: Vec3,
    normal: Vec3,
}

fn cost(fit: &Fit, leaf: &Leaf) -> f32 {
    let d = leaf.centre - fit.centre;
    let h = d.dot(fit.normal);
    let along = d.length_squared() - h * h;
    let edge = 1.0 - leaf.normal.dot(fit.normal).abs();
    NORMAL_WEIGHT * h * h + along + EDGE_ON_WEIGHT * edge * leaf.size * leaf.size
}

/// Symmetric 3×3 eigenvectors by Jacobi rotations: (values ascending, vectors).
fn eigen3(mut a: [[f32; 3]; 3]) -> ([f32; 3], [Vec3; 3]) {
    let mut v = [[1.0f32, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..32 {
        let (mut p, mut q, mut big) = (0, 1, 0.0f32);
        for (i, j) in [(0, 1), (0, 2), (1, 2)] {
            if a[i][j].abs() > big {
                (p, q, big) = (i, j, a[i][j].abs());
            }
        }
        if big < 1e-12 {
            break;
        }
        let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
        let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
        let t = if theta == 0.0 { 1.0 } else { t };
        let c = 1.0 / (t * t + 1.0).sqrt();
        let s = t * c;
        for row in &mut a {
            let (akp, akq) = (row[p], row[q]);
            row[p] = c * akp - s * akq;
            row[q] = s * akp + c * akq;
        }
        #[allow(clippy::needless_range_loop)] // rows p and q at once
        for k in 0..3 {
            let (apk, aqk) = (a[p][k], a[q][k]);
            a[p][k] = c * apk - s * aqk;
            a[q][k] = s * apk + c * aqk;
        }
        for row in &mut v {
            let (vp, vq) = (row[p], row[q]);
            row[p] = c * vp - s * vq;
            row[q] = s * vp + c * vq;
        }
    }
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| a[i][i].total_cmp(&a[j][j]));
    let vals = order.map(|i| a[i][i]);
    let vecs = order.map(|i| Vec3::new(v[0][i], v[1][i], v[2][i]).normalize_or(Vec3::Y));
    (vals, vecs)
}

/// The least-squares plane of the members' vertices; the mean leaf normal when they do not
/// span a plane (a round or linear cluster).
fn refit(plant: &Plant, leaves: &[Leaf], members: &[u32], old: Fit) -> Fit {
    let pos = &plant.leaves.positions;
    let (mut sum, mut w) = (Vec3::ZERO, 0.0f32);
    for &l in members {
        let leaf = &leaves[l as usize];
        let a = leaf.area.max(1e-8);
        sum += leaf.centre * a;
        w += a;
    }
    if w == 0.0 {
        return old;
    }
    let centre = sum / w;
    let mut cov = [[0.0f32; 3]; 3];
    let mut mean_n = Vec3::ZERO;
    for &l in members {
        let leaf = &leaves[l as usize];
        let a = leaf.area.max(1e-8) / leaf.vertices.len() as f32;
        for &i in &leaf.vertices {
            let d = (Vec3::from(pos[i as usize]) - centre).to_array();
            for r in 0..3 {
                for c in 0..3 {
                    cov[r][c] += a * d[r] * d[c];
                }
            }
        }
        // Sign-align the normals with the current plane's before averaging.
        let n = leaf.normal * leaf.normal.dot(old.normal).signum();
        mean_n += n * leaf.area.max(1e-8);
    }
    let (vals, vecs) = eigen3(cov);
    let normal = if vals[1] > 0.0 && vals[0] < 0.25 * vals[1] {
        vecs[0]
    } else {
        mean_n.normalize_or(old.normal)
    };
    // Keep the side: a flipped normal would reverse the lists' order for no reason.
    let normal = if normal.dot(old.normal) < 0.0 {
        -normal
    } else {
        normal
    };
    Fit { centre, normal }
}

/// Clusters `leaves` into at most `k` planes (fewer when there are fewer leaves), refining
/// `iterations` times. Deterministic.
pub fn cluster(plant: &Plant, leaves: &[Leaf], k: usize, iterations: u32) -> Vec<Plane> {
    let n = leaves.len();
    let k = k.min(n).max(1);
    if n == 0 {
        return Vec::new();
    }
    // Farthest-point seeds from the leaf nearest the crown's centre.
    let mid = leaves.iter().map(|l| l.centre).sum::<Vec3>() / n as f32;
    let first = (0..n)
        .min_by(|&a, &b| {
            leaves[a]
                .centre
                .distance_squared(mid)
                .total_cmp(&leaves[b].centre.distance_squared(mid))
        })
        .unwrap_or(0);
    let mut fits = vec![Fit {
        centre: leaves[first].centre,
        normal: leaves[first].normal,
    }];
    let mut nearest: Vec<f32> = leaves
        .iter()
        .map(|l| l.centre.distance_squared(fits[0].centre))
        .collect();
    while fits.len() < k {
        let (far, _) = nearest
            .iter()
            .enumerate()
            .fold((0, -1.0f32), |b, (i, &d)| if d > b.1 { (i, d) } else { b });
        let f = Fit {
            centre: leaves[far].centre,
            normal: leaves[far].normal,
        };
        for (d, l) in nearest.iter_mut().zip(leaves) {
            *d = d.min(l.centre.distance_squared(f.centre));
        }
        fits.push(f);
    }
    let mut assign = vec![0u32; n];
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); k];
    for it in 0..=iterations {
        let mut worst = (0usize, -1.0f32);
        for m in &mut members {
            m.clear();
        }
        for (i, leaf) in leaves.iter().enumerate() {
            let (best, c) = fits
                .iter()
                .enumerate()
                .map(|(j, f)| (j, cost(f, leaf)))
                .fold((0, f32::MAX), |b, x| if x.1 < b.1 { x } else { b });
            assign[i] = best as u32;
            members[best].push(i as u32);
            if c > worst.1 {
                worst = (i, c);
            }
        }
        if it == iterations {
            break;
        }
        for j in 0..k {
            if members[j].is_empty() {
                fits[j] = Fit {
                    centre: leaves[worst.0].centre,
                    normal: leaves[worst.0].normal,
                };
                continue;
            }
            fits[j] = refit(plant, leaves, &members[j], fits[j]);
        }
    }
    let pos = &plant.leaves.positions;
    members
        .into_iter()
        .zip(fits)
        .filter(|(m, _)| !m.is_empty())
        .map(|(m, f)| {
            // In-plane axes: the principal direction of the projected vertices.
            let helper = if f.normal.y.abs() < 0.9 {
                Vec3::Y
            } else {
                Vec3::X
            };
            let a = f.normal.cross(helper).normalize();
            let b = f.normal.cross(a);
            let (mut sxx, mut sxy, mut syy) = (0.0f32, 0.0f32, 0.0f32);
            for &l in &m {
                for &i in &leaves[l as usize].vertices {
                    let d = Vec3::from(pos[i as usize]) - f.centre;
                    let (x, y) = (d.dot(a), d.dot(b));
                    sxx += x * x;
                    sxy += x * y;
                    syy += y * y;
                }
            }
            let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
            let u = a * angle.cos() + b * angle.sin();
            let v = f.normal.cross(u);
            let mut plane = Plane {
                normal: f.normal,
                u,
                v,
                origin: f.centre,
                min: Vec2::splat(f32::MAX),
                max: Vec2::splat(f32::MIN),
                leaves: m,
            };
            for &l in &plane.leaves {
                let leaf = &leaves[l as usize];
                for &i in &leaf.vertices {
                    let st = plane.project(Vec3::from(pos[i as usize]));
                    plane.min = plane.min.min(st);
                    plane.max = plane.max.max(st);
                }
            }
            // A rectangle of some width even for a single edge-on leaf.
            let pad = Vec2::splat(1e-3);
            plane.min -= pad;
            plane.max += pad;
            plane
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigen_of_a_flat_cloud_is_its_normal() {
        // Covariance of points spread in x and z, thin in y.
        let (vals, vecs) = eigen3([[4.0, 0.0, 0.5], [0.0, 0.01, 0.0], [0.5, 0.0, 2.0]]);
        assert!(vals[0] < vals[1] && vals[1] < vals[2]);
        assert!(vecs[0].y.abs() > 0.999, "{:?}", vecs[0]);
    }

    /// A 1 m × 1 m leaf of four triangles on a 3 × 2 grid of vertices, uv over [0, 1]², the
    /// midrib at u = 0.5; each half turned `fold` radians about the midrib (out of y = 0).
    fn leaf(fold: f32) -> sylvan_plant::Mesh {
        let mut m = sylvan_plant::Mesh::default();
        for v in [0.0f32, 1.0] {
            for u in [0.0f32, 0.5, 1.0] {
                let x = u - 0.5;
                let p = Vec3::new(x * fold.cos(), x.abs() * fold.sin(), v);
                m.positions.push(p.to_array());
                m.normals.push([0.0, 1.0, 0.0]);
                m.uvs.push([u, v]);
                m.colors.push([1.0; 3]);
            }
        }
        m.indices = vec![0, 3, 1, 1, 3, 4, 1, 4, 2, 2, 4, 5];
        m
    }

    fn tris(m: &sylvan_plant::Mesh) -> Vec<[u32; 3]> {
        m.indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect()
    }

    const WHOLE: [Vec2; 2] = [Vec2::splat(f32::MIN), Vec2::splat(f32::MAX)];

    #[test]
    fn a_flat_leaf_stays_whole() {
        let m = leaf(0.0);
        let p = parts(&m, tris(&m), WHOLE, MAX_SPLITS);
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].1, WHOLE);
    }

    #[test]
    fn a_folded_leaf_is_cut_along_its_fold_and_shows_its_image_once() {
        // 30° each side: the halves are flat, the whole is not.
        let m = leaf(30f32.to_radians());
        assert!(bend(&m, &tris(&m)).0 > BENT);
        let p = parts(&m, tris(&m), WHOLE, MAX_SPLITS);
        assert_eq!(p.len(), 2, "{p:?}");
        for (t, _) in &p {
            assert_eq!(t.len(), 2);
            assert!(bend(&m, t).0 < 1e-5, "a part is not flat");
        }
        // The cut is the midrib: the clips meet at u = 0.5 and split nothing else.
        assert_eq!(p[0].1[1].x, 0.5);
        assert_eq!(p[1].1[0].x, 0.5);
        // Every image point inside the leaf lies in exactly one part's clip (off the cut).
        for i in 0..20 {
            for j in 0..20 {
                let q = Vec2::new((i as f32 + 0.25) / 20.0, (j as f32 + 0.5) / 20.0);
                let n = p
                    .iter()
                    .filter(|(_, c)| q.cmpge(c[0]).all() && q.cmple(c[1]).all())
                    .count();
                assert_eq!(n, 1, "{q}");
            }
        }
    }
}
