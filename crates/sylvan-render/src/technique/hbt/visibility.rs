//! MNP01 §3.3, §4.2, §6.2: **visibility cube-maps**. For an object instance, one small cube-map
//! at each of the 8 corners of its bounding box stores, per direction, the opacity of the rest
//! of its level seen from that corner: the other branches of the same tree at the branch level,
//! the other trees and the terrain at the top level. At draw time the sun's direction is looked
//! up in the 8 maps, the levels are combined as `1 − Π(1 − opacity)` (§4.2), and the result is
//! interpolated trilinearly across the billboard; the cosine-weighted mean transmittance of the
//! upper hemisphere of each map scales the sky term.
//!
//! Building a map (§6.2 renders the level's objects into it; here it is evaluated per texel on
//! the CPU, which needs no GPU round trips for thousands of small maps): each texel's ray from
//! the corner is tested against the bounding sphere and box of every occluder near the corner;
//! where it crosses one, the occluder's **own baked coverage** (the alpha of its BTF, seen along
//! the ray: the 3 view samples around it, at the mip whose texel matches the cube texel's
//! footprint) gives that occluder's opacity, and occluders combine as `1 − Π(1 − α)`, so the
//! cube-maps agree with what is drawn. Where the corner is inside an occluder's box, only the
//! part of the crossing in front of it counts (opacity `1 − (1 − α)^f`). Terrain is opaque below
//! a horizon traced per corner in 16 azimuths up to 600 m.

use crate::bake::views::PlaneFrame;
use crate::directions::DirectionLut;
use glam::{Affine3A, Vec3};
use sylvan_scene::Terrain;

/// Faces of a cube-map, in the order +X, −X, +Y, −Y, +Z, −Z.
pub const FACES: usize = 6;
/// Corners of a bounding box; corner `k` takes `max` on axis `a` when bit `a` of `k` is set.
pub const CORNERS: usize = 8;
/// Terrain horizon: azimuth bins.
const HORIZON_AZIMUTHS: usize = 16;
/// Terrain horizon: march distances from 1 m, growing geometrically to about this far.
const HORIZON_REACH_M: f32 = 600.0;
const HORIZON_STEPS: usize = 24;

/// Corner `k` of the box `min..max`.
pub fn corner(min: Vec3, max: Vec3, k: usize) -> Vec3 {
    Vec3::new(
        if k & 1 != 0 { max.x } else { min.x },
        if k & 2 != 0 { max.y } else { min.y },
        if k & 4 != 0 { max.z } else { min.z },
    )
}

/// The direction through the centre of texel (`i`, `j`) of face `face` of a cube-map of side
/// `res` (unit).
pub fn texel_direction(face: usize, i: usize, j: usize, res: usize) -> Vec3 {
    let a = (i as f32 + 0.5) / res as f32 * 2.0 - 1.0;
    let b = (j as f32 + 0.5) / res as f32 * 2.0 - 1.0;
    face_direction(face, a, b).normalize()
}

fn face_direction(face: usize, a: f32, b: f32) -> Vec3 {
    match face {
        0 => Vec3::new(1.0, -b, -a),
        1 => Vec3::new(-1.0, -b, a),
        2 => Vec3::new(a, 1.0, b),
        3 => Vec3::new(a, -1.0, -b),
        4 => Vec3::new(a, -b, 1.0),
        _ => Vec3::new(-a, -b, -1.0),
    }
}

/// Face and face coordinates in [-1, 1]² of a direction (the inverse of `face_direction`).
fn face_coords(d: Vec3) -> (usize, f32, f32) {
    let a = d.abs();
    if a.x >= a.y && a.x >= a.z {
        let m = a.x.max(1e-12);
        if d.x > 0.0 {
            (0, -d.z / m, -d.y / m)
        } else {
            (1, d.z / m, -d.y / m)
        }
    } else if a.y >= a.z {
        let m = a.y.max(1e-12);
        if d.y > 0.0 {
            (2, d.x / m, d.z / m)
        } else {
            (3, d.x / m, -d.z / m)
        }
    } else {
        let m = a.z.max(1e-12);
        if d.z > 0.0 {
            (4, d.x / m, -d.y / m)
        } else {
            (5, -d.x / m, -d.y / m)
        }
    }
}

/// The texel directions of a cube-map of side `res`, face-major then row-major.
pub fn directions(res: usize) -> Vec<Vec3> {
    let mut out = Vec::with_capacity(FACES * res * res);
    for face in 0..FACES {
        for j in 0..res {
            for i in 0..res {
                out.push(texel_direction(face, i, j, res));
            }
        }
    }
    out
}

/// Opacity (0 open … 1 occluded) looked up bilinearly inside the face `dir` falls on, in one
/// cube-map (`6·res²` bytes, 255 = opaque).
pub fn lookup(map: &[u8], res: usize, dir: Vec3) -> f32 {
    let (face, a, b) = face_coords(dir);
    let x = ((a * 0.5 + 0.5) * res as f32 - 0.5).clamp(0.0, res as f32 - 1.0);
    let y = ((b * 0.5 + 0.5) * res as f32 - 0.5).clamp(0.0, res as f32 - 1.0);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(res - 1), (y0 + 1).min(res - 1));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let at = |i: usize, j: usize| map[face * res * res + j * res + i] as f32 / 255.0;
    let top = at(x0, y0) * (1.0 - fx) + at(x1, y0) * fx;
    let bottom = at(x0, y1) * (1.0 - fx) + at(x1, y1) * fx;
    top * (1.0 - fy) + bottom * fy
}

/// Cosine-weighted mean transmittance of the upper hemisphere of one cube-map: the sky term
/// (MNP01 §4.2 uses the map's mean).
pub fn sky_transmittance(map: &[u8], dirs: &[Vec3]) -> f32 {
    let (mut open, mut total) = (0.0f32, 0.0f32);
    for (d, &o) in dirs.iter().zip(map) {
        if d.y > 0.0 {
            open += d.y * (1.0 - o as f32 / 255.0);
            total += d.y;
        }
    }
    if total > 0.0 { open / total } else { 1.0 }
}

/// An object's coverage (the alpha of its BTF images) as a function of view direction: what an
/// occluder contributes to a cube-map.
pub struct Coverage<'a> {
    /// The view samples' look-up table.
    pub lut: &'a DirectionLut,
    /// The frame each view sample's images were baked in (object space).
    pub frames: Vec<PlaneFrame>,
    /// Per view sample, the mip chain of one image (RGBA8, alpha = coverage).
    pub images: Vec<&'a [Vec<u8>]>,
    /// Image side (texels) at mip 0.
    pub tile: u32,
    /// Object bounding box.
    pub min: Vec3,
    /// Object bounding box maximum.
    pub max: Vec3,
}

impl Coverage<'_> {
    /// Coverage of the object seen along `-view` (unit, object space) at object-space point
    /// `p`, averaged over `footprint` (object-space metres).
    fn alpha(&self, view: Vec3, p: Vec3, footprint: f32) -> f32 {
        let (ids, w) = self.lut.lookup(view);
        let mut a = 0.0;
        for (&id, &wk) in ids.iter().zip(&w) {
            if wk <= 0.0 {
                continue;
            }
            let f = &self.frames[id as usize];
            let q = p - f.centre;
            let s = q.dot(f.u) / f.half.x * 0.5 + 0.5;
            let t = 0.5 - q.dot(f.v) / f.half.y * 0.5;
            if !(0.0..=1.0).contains(&s) || !(0.0..=1.0).contains(&t) {
                continue;
            }
            let texel = 2.0 * f.half.x.max(f.half.y) / self.tile as f32;
            let mips = self.images[id as usize];
            let mip = ((footprint / texel).max(1.0).log2().round() as usize).min(mips.len() - 1);
            a += wk * bilinear_alpha(&mips[mip], (self.tile >> mip).max(1) as usize, s, t);
        }
        a.clamp(0.0, 1.0)
    }
}

fn bilinear_alpha(image: &[u8], n: usize, s: f32, t: f32) -> f32 {
    let x = (s * n as f32 - 0.5).clamp(0.0, n as f32 - 1.0);
    let y = (t * n as f32 - 0.5).clamp(0.0, n as f32 - 1.0);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(n - 1), (y0 + 1).min(n - 1));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let at = |i: usize, j: usize| image[(j * n + i) * 4 + 3] as f32 / 255.0;
    (at(x0, y0) * (1.0 - fx) + at(x1, y0) * fx) * (1.0 - fy)
        + (at(x0, y1) * (1.0 - fx) + at(x1, y1) * fx) * fy
}

/// One placed occluder: an object's coverage and where it stands in the level's frame.
pub struct Occluder<'a> {
    /// The object's coverage.
    pub coverage: &'a Coverage<'a>,
    /// Object space → the level's frame (a similarity: rotation, uniform scale, translation).
    pub to_frame: Affine3A,
    /// The inverse.
    pub from_frame: Affine3A,
    /// Bounding-sphere centre in the level's frame.
    pub centre: Vec3,
    /// Bounding-sphere radius in the level's frame.
    pub radius: f32,
    /// Uniform scale object → frame.
    pub scale: f32,
}

impl<'a> Occluder<'a> {
    /// `coverage` placed by `to_frame` (a similarity).
    pub fn new(coverage: &'a Coverage<'a>, to_frame: Affine3A) -> Self {
        let scale = to_frame.matrix3.x_axis.length();
        let centre = to_frame.transform_point3((coverage.min + coverage.max) * 0.5);
        let radius = (coverage.max - coverage.min).length() * 0.5 * scale;
        Self {
            coverage,
            to_frame,
            from_frame: to_frame.inverse(),
            centre,
            radius,
            scale,
        }
    }

    /// Opacity along the ray `origin + t·dir` (`dir` unit, frame space), or 0 when it misses;
    /// `near` is [`Occluder::near`] for this origin. `texel_angle`: the cube texel's angular
    /// size (radians).
    fn opacity(&self, near: &Near, origin: Vec3, dir: Vec3, texel_angle: f32) -> f32 {
        let along = near.to_centre.dot(dir);
        if !near.inside && (along < 0.0 || near.dist2 - along * along > self.radius * self.radius) {
            return 0.0;
        }
        let o = self.from_frame.transform_point3(origin);
        let d = self.from_frame.transform_vector3(dir).normalize();
        let (min, max) = (self.coverage.min, self.coverage.max);
        let (mut t0, mut t1) = (f32::NEG_INFINITY, f32::INFINITY);
        for a in 0..3 {
            if d[a].abs() < 1e-9 {
                if o[a] < min[a] || o[a] > max[a] {
                    return 0.0;
                }
                continue;
            }
            let (ta, tb) = ((min[a] - o[a]) / d[a], (max[a] - o[a]) / d[a]);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        if t1 <= t0.max(0.0) {
            return 0.0;
        }
        let start = t0.max(0.0);
        let mid = 0.5 * (start + t1);
        let footprint = mid * texel_angle;
        let alpha = self.coverage.alpha(-d, o + d * mid, footprint);
        if t0 >= 0.0 {
            alpha
        } else {
            // The corner is inside the box: only the part of the crossing ahead occludes.
            let f = (t1 - start) / (t1 - t0);
            1.0 - (1.0 - alpha.min(0.999)).powf(f)
        }
    }

    /// What the sphere test needs, for rays from `origin`.
    fn near(&self, origin: Vec3) -> Near {
        let to_centre = self.centre - origin;
        let dist2 = to_centre.length_squared();
        Near {
            to_centre,
            dist2,
            inside: dist2 < self.radius * self.radius,
        }
    }
}

/// An occluder's bounding sphere relative to a cube-map's origin.
struct Near {
    to_centre: Vec3,
    dist2: f32,
    inside: bool,
}

/// Terrain horizon around one point: the tangent of the highest terrain elevation angle per
/// azimuth bin (azimuth from +Z towards +X).
pub struct Horizon {
    tan: [f32; HORIZON_AZIMUTHS],
}

impl Horizon {
    /// Traces the terrain around `p` (heights outside the terrain are not counted). The point
    /// is lifted to at least 0.25 m above the ground under it, so a box corner sitting on (or,
    /// on a slope, in) the ground sees the open terrain, not the inside of the hill.
    pub fn trace(terrain: &Terrain, p: Vec3) -> Self {
        let ground = if terrain.contains(p.x, p.z) {
            terrain.height_at(p.x, p.z)
        } else {
            f32::NEG_INFINITY
        };
        let y = p.y.max(ground + 0.25);
        let growth = HORIZON_REACH_M.powf(1.0 / HORIZON_STEPS as f32);
        let mut tan = [f32::NEG_INFINITY; HORIZON_AZIMUTHS];
        for (k, out) in tan.iter_mut().enumerate() {
            let az = k as f32 / HORIZON_AZIMUTHS as f32 * std::f32::consts::TAU;
            let (s, c) = az.sin_cos();
            let mut r = 1.0;
            for _ in 0..HORIZON_STEPS {
                let (x, z) = (p.x + s * r, p.z + c * r);
                if terrain.contains(x, z) {
                    *out = out.max((terrain.height_at(x, z) - y) / r);
                }
                r *= growth;
            }
        }
        Self { tan }
    }

    /// Whether the terrain hides direction `d` (unit).
    pub fn hides(&self, d: Vec3) -> bool {
        let flat = (d.x * d.x + d.z * d.z).sqrt();
        if flat < 1e-6 {
            return false;
        }
        let az = d.x.atan2(d.z).rem_euclid(std::f32::consts::TAU) / std::f32::consts::TAU
            * HORIZON_AZIMUTHS as f32;
        let k0 = az.floor() as usize % HORIZON_AZIMUTHS;
        let k1 = (k0 + 1) % HORIZON_AZIMUTHS;
        let f = az - az.floor();
        let (a, b) = (self.tan[k0], self.tan[k1]);
        let limit = if a.is_finite() && b.is_finite() {
            a * (1.0 - f) + b * f
        } else if a.is_finite() {
            a
        } else {
            b
        };
        limit.is_finite() && d.y / flat < limit
    }
}

/// Side of the texel blocks a cube-map face is cut into for culling.
const BLOCK: usize = 4;

/// The texel directions of a cube-map of side `res` and the blocks of up to `BLOCK²` texels
/// that occluders are culled against (cone against block, then texel by texel).
pub struct CubeLayout {
    /// Face side.
    pub res: usize,
    /// Texel directions, face-major then row-major ([`directions`]).
    pub dirs: Vec<Vec3>,
    /// Per block: its mean direction, the sine and cosine of the largest angle from it to one
    /// of its texels, and its texel indices.
    blocks: Vec<(Vec3, f32, f32, Vec<u32>)>,
}

impl CubeLayout {
    /// The layout of side `res`.
    pub fn new(res: usize) -> Self {
        let dirs = directions(res);
        let per_side = res.div_ceil(BLOCK);
        let mut blocks = Vec::new();
        for face in 0..FACES {
            for bj in 0..per_side {
                for bi in 0..per_side {
                    let mut texels = Vec::new();
                    let mut mean = Vec3::ZERO;
                    for j in bj * BLOCK..((bj + 1) * BLOCK).min(res) {
                        for i in bi * BLOCK..((bi + 1) * BLOCK).min(res) {
                            let k = face * res * res + j * res + i;
                            texels.push(k as u32);
                            mean += dirs[k];
                        }
                    }
                    let centre = mean.normalize();
                    // Half a texel's angle beyond the farthest texel centre.
                    let cos = texels
                        .iter()
                        .map(|&k| dirs[k as usize].dot(centre))
                        .fold(1.0f32, f32::min);
                    let angle =
                        cos.clamp(-1.0, 1.0).acos() + std::f32::consts::FRAC_PI_2 / res as f32;
                    blocks.push((centre, angle.sin(), angle.cos(), texels));
                }
            }
        }
        Self { res, dirs, blocks }
    }
}

/// Renders one cube-map: the opacity seen from `origin` through `occluders` (and the terrain
/// under `horizon`), into `out` (`layout.dirs.len()` bytes). `open` is scratch space.
pub fn render(
    origin: Vec3,
    occluders: &[&Occluder<'_>],
    horizon: Option<&Horizon>,
    layout: &CubeLayout,
    open: &mut Vec<f32>,
    out: &mut [u8],
) {
    let texel_angle = std::f32::consts::FRAC_PI_2 / layout.res as f32;
    open.clear();
    open.extend(layout.dirs.iter().map(|d| {
        if horizon.is_some_and(|h| h.hides(*d)) {
            0.0
        } else {
            1.0
        }
    }));
    for occ in occluders {
        let near = occ.near(origin);
        let dist = near.dist2.sqrt();
        // The occluder's bounding cone from the origin (everything when inside its sphere).
        let (axis, sin_r, cos_r) = if near.inside {
            (Vec3::Y, 1.0, -1.0)
        } else {
            let s = (occ.radius / dist).min(1.0);
            (near.to_centre / dist, s, (1.0 - s * s).sqrt())
        };
        for (centre, sin_b, cos_b, texels) in &layout.blocks {
            // Cone meets block when the angle between their axes is below the sum of their
            // half-angles: cos(a) > cos(r + b).
            if !near.inside && axis.dot(*centre) < cos_r * cos_b - sin_r * sin_b {
                continue;
            }
            for &k in texels {
                let k = k as usize;
                if open[k] <= 1e-3 {
                    continue;
                }
                let a = occ.opacity(&near, origin, layout.dirs[k], texel_angle);
                if a > 0.0 {
                    open[k] *= 1.0 - a;
                }
            }
        }
    }
    for (o, t) in out.iter_mut().zip(open.iter()) {
        *o = ((1.0 - t) * 255.0).round() as u8;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::directions::DirectionSet;

    #[test]
    fn faces_round_trip() {
        let res = 8;
        for (k, d) in directions(res).iter().enumerate() {
            let (face, a, b) = face_coords(*d);
            let i = ((a * 0.5 + 0.5) * res as f32) as usize;
            let j = ((b * 0.5 + 0.5) * res as f32) as usize;
            assert_eq!(face * res * res + j * res + i, k, "{d}");
        }
    }

    /// A solid cube of coverage 1 in every view.
    fn solid<'a>(lut: &'a DirectionLut, image: &'a [Vec<u8>]) -> Coverage<'a> {
        let (min, max) = (Vec3::splat(-1.0), Vec3::splat(1.0));
        let n = lut.set().len();
        Coverage {
            lut,
            frames: lut
                .set()
                .directions()
                .iter()
                .map(|&d| PlaneFrame::for_box(d, min, max))
                .collect(),
            images: vec![image; n],
            tile: 4,
            min,
            max,
        }
    }

    #[test]
    fn an_opaque_occluder_hides_the_sun_behind_it_only() {
        let set = DirectionSet::new(0).unwrap();
        let lut = DirectionLut::new(&set, 16).unwrap();
        let image: Vec<Vec<u8>> = vec![vec![255; 4 * 16], vec![255; 4 * 4], vec![255; 4]];
        let cov = solid(&lut, &image);
        // A 2 m opaque cube 5 m above the corner.
        let occ = Occluder::new(&cov, Affine3A::from_translation(Vec3::new(0.0, 5.0, 0.0)));
        let res = 16;
        let layout = CubeLayout::new(res);
        let dirs = &layout.dirs;
        let mut map = vec![0u8; dirs.len()];
        render(
            Vec3::ZERO,
            &[&occ],
            None,
            &layout,
            &mut Vec::new(),
            &mut map,
        );
        assert!(
            lookup(&map, res, Vec3::Y) > 0.99,
            "{}",
            lookup(&map, res, Vec3::Y)
        );
        assert_eq!(lookup(&map, res, Vec3::new(1.0, 0.2, 0.0).normalize()), 0.0);
        let sky = sky_transmittance(&map, dirs);
        assert!(sky > 0.5 && sky < 0.99, "{sky}");
    }

    #[test]
    fn a_corner_boxed_in_by_occluders_gets_no_sun_from_anywhere() {
        let set = DirectionSet::new(0).unwrap();
        let lut = DirectionLut::new(&set, 16).unwrap();
        let image: Vec<Vec<u8>> = vec![vec![255; 4 * 16], vec![255; 4 * 4], vec![255; 4]];
        let cov = solid(&lut, &image);
        // Six cubes around the origin, one on each axis, scaled to close every gap.
        let offsets = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        let occ: Vec<Occluder> = offsets
            .iter()
            .map(|&o| {
                Occluder::new(
                    &cov,
                    Affine3A::from_scale_rotation_translation(
                        Vec3::splat(1.5),
                        glam::Quat::IDENTITY,
                        o * 2.0,
                    ),
                )
            })
            .collect();
        let refs: Vec<&Occluder> = occ.iter().collect();
        let layout = CubeLayout::new(8);
        let mut map = vec![0u8; layout.dirs.len()];
        render(Vec3::ZERO, &refs, None, &layout, &mut Vec::new(), &mut map);
        assert!(map.iter().all(|&o| o == 255));
        assert_eq!(sky_transmittance(&map, &layout.dirs), 0.0);
        // And so no sun, wherever it is.
        for d in [Vec3::Y, Vec3::new(0.3, 0.1, -0.9).normalize()] {
            assert_eq!(lookup(&map, 8, d), 1.0);
        }
    }

    #[test]
    fn block_culling_changes_nothing() {
        let set = DirectionSet::new(0).unwrap();
        let lut = DirectionLut::new(&set, 16).unwrap();
        let image: Vec<Vec<u8>> = vec![vec![200; 4 * 16], vec![200; 4 * 4], vec![200; 4]];
        let cov = solid(&lut, &image);
        let occ: Vec<Occluder> = (0..20)
            .map(|k| {
                let a = k as f32 * 0.9;
                let p = Vec3::new(
                    a.cos() * (3.0 + k as f32),
                    (k % 5) as f32 - 1.0,
                    a.sin() * 4.0,
                );
                Occluder::new(&cov, Affine3A::from_translation(p))
            })
            .collect();
        let refs: Vec<&Occluder> = occ.iter().collect();
        let layout = CubeLayout::new(12);
        let mut map = vec![0u8; layout.dirs.len()];
        render(Vec3::ZERO, &refs, None, &layout, &mut Vec::new(), &mut map);
        // Brute force: every texel against every occluder.
        for (k, d) in layout.dirs.iter().enumerate() {
            let mut open = 1.0f32;
            for o in &occ {
                open *= 1.0
                    - o.opacity(
                        &o.near(Vec3::ZERO),
                        Vec3::ZERO,
                        *d,
                        std::f32::consts::FRAC_PI_2 / 12.0,
                    );
            }
            let want = ((1.0 - open) * 255.0).round() as u8;
            assert!(
                map[k].abs_diff(want) <= 1,
                "texel {k}: {} vs {want}",
                map[k]
            );
        }
        assert!(map.iter().any(|&o| o > 0));
    }

    #[test]
    fn terrain_hides_what_is_below_its_horizon() {
        let terrain = Terrain::flat([100.0, 100.0], 0.0);
        let h = Horizon::trace(&terrain, Vec3::new(50.0, 1.0, 50.0));
        assert!(h.hides(Vec3::new(1.0, -0.2, 0.0).normalize()));
        assert!(!h.hides(Vec3::new(1.0, 0.2, 0.0).normalize()));
        assert!(!h.hides(Vec3::Y));
    }
}
