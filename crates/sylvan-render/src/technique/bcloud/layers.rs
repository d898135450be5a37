//! GPSS07 §4.2 and §5.2 on the CPU: per plane the hash texture (a grid of cells, each the
//! start and length of a list), the lists of overlapping leaf fragments sorted front to back by
//! an exact sort, one record per leaf (where its image lies on the plane, which image, its
//! normal frame, colour and ambient occlusion at the four corners of its image's box) and the
//! low-resolution images the shader level of detail falls back to (§5.1), evaluated from the
//! very lists the shader walks.
//!
//! Deviations, each for a stated reason:
//! - **Records per leaf, lists of record numbers.** GPSS07 stores a full record per (cell,
//!   leaf) fragment; here a list entry is a 4-byte record number and the 64-byte record is
//!   stored once per leaf: the same walk with one more indirection and several times less
//!   memory (a leaf overlaps several cells).
//! - **The leaf where the view ray meets it, in a slab.** GPSS07 draws each leaf as an image
//!   placed on the billboard (picked by an orientation index), so a leaf off its plane or
//!   turned away from it is displaced and re-shaped with the view, which no texture resolution
//!   recovers (measured: 3.3× 1-spp geometry's ꟻLIP at 800 px). Here each record holds the
//!   leaf's own plane — the affine image of its texture that fits its vertices best (least
//!   squares, exact for a flat leaf) — and each plane is drawn as the box of its leaves (its
//!   rectangle × the heights they span, [`PlaneRecord::slab`]): a pixel's ray is followed
//!   through the box cell by cell of the hash grid ([`walk`]), and in each cell meets the
//!   leaves of its list where they lie ([`leaf_hit`]). Leaves keep their positions, sizes,
//!   orientations and overlaps from every side, a plane seen edge-on still covers the screen
//!   its leaves cover, and one leaf image serves every leaf. A ray crossing more than
//!   [`MAX_CELLS`] cells (a plane seen almost edge-on) stops there.
//! - **Fragments from the leaves' triangles.** GPSS07 splats each leaf as a point sprite of its
//!   bounding square and depth-peels the sprites; a cell here lists the leaves whose fitted
//!   triangles, projected onto the plane, overlap it (exact 2D separating-axis test,
//!   [`leaf_cells`]): a ray meets a leaf only in a cell that lists it. The order is the height
//!   of the leaf's centre above the plane, descending (ties by leaf number); the walk takes the
//!   nearest opaque hit of the cell, so the order only decides which leaves the 255-entry cap
//!   drops.
//! - **Ambient occlusion per vertex is the reference's** (`crown_occlusion` of
//!   `shaders/frame.wgsl`, the term `geometry` shades every leaf vertex with), extrapolated to
//!   the leaf's box corners by least squares (fig. 11), so the technique matches the ground
//!   truth it is measured against.
//! - **The blade's shading normal** (not in GPSS07, whose leaf images carry their normals):
//!   the leaf's vertex normals fitted by an affine field over its `uv` box and stored at the
//!   box corners, interpolated like the occlusion ([`LeafRecord::normal_at`]), so a curled
//!   blade shades like the reference's (measured on the 800 / 400 px chestnut: ꟻLIP 0.1009 →
//!   0.0975 / 0.0906 → 0.0903; a bilinear fit extrapolates to the corners and was worse, 0.1201).
//! - **Low-resolution images** are one square tile per plane and side (front side, back side),
//!   stretched over the rectangle, holding premultiplied albedo + coverage and the normal
//!   facing that side with the occlusion in alpha (the shared baker's tile format and mips).

use super::cluster::{Leaf, Plane};
use crate::bake::image::{TileImage, TileLevel};
use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};
use sylvan_plant::{LeafTexture, Plant};

/// Most entries in one cell's list (the hash texel stores the length in 8 bits).
pub const MAX_LIST: usize = 255;
/// Most list entries of one level (the hash texel stores the start in 24 bits).
pub const MAX_ENTRIES: usize = 1 << 24;
/// Most cells along one side of a plane's hash grid.
pub const MAX_CELLS_PER_SIDE: u32 = 1024;

/// One leaf as the shader reads it (80 bytes).
///
/// The leaf is the affine image of its texture that fits its vertices best: in plane space
/// (`s`, `t` along the plane's axes, `h` the height above it) the point of leaf image
/// coordinate `uv` is `origin + A uv`; the record holds `origin` and the two rows of `A`'s
/// pseudo-inverse (`uv = [to_u; to_v] (x − origin)` for any point `x` of the leaf's plane), so
/// a ray through the billboard is intersected with the leaf where it lies ([`leaf_hit`]).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct LeafRecord {
    /// Plane-space point (`s`, `t`, `h`) where the leaf image's `uv = 0` lies.
    pub origin: [f32; 3],
    /// The leaf's `uv` box minimum, `pack2x16unorm` (a box with min > max: the leaf has no
    /// area and is never hit).
    pub uv_min: u32,
    /// Row of the map from plane-space offsets to leaf `u`.
    pub to_u: [f32; 3],
    /// The `uv` box maximum, `pack2x16unorm`.
    pub uv_max: u32,
    /// Row of the map from plane-space offsets to leaf `v`.
    pub to_v: [f32; 3],
    /// Front normal (model space), octahedral `pack2x16snorm`.
    pub normal: u32,
    /// Direction of `+u` on the leaf (model space), octahedral `pack2x16snorm`.
    pub tangent: u32,
    /// Linear RGB colour (RGBA8; bit 0 of alpha: `+v` runs along `−(n × t)`).
    pub color: u32,
    /// Ambient occlusion at the `uv` box corners (min,min), (max,min), (min,max), (max,max).
    pub ao: u32,
    /// Zero.
    pub pad: u32,
    /// The blade's shading normal (its vertex normals fitted by an affine field over the `uv`
    /// box, by least squares) at the same four corners, octahedral `pack2x16snorm`, facing `normal`'s side.
    pub corner_normals: [u32; 4],
}

impl LeafRecord {
    /// The leaf's `uv` box.
    pub fn uv_box(&self) -> (Vec2, Vec2) {
        (unpack_unorm2(self.uv_min), unpack_unorm2(self.uv_max))
    }

    /// The shading normal at `q` in the `uv` box (`[0, 1]²`): the corner normals interpolated
    /// bilinearly, as the shader does.
    pub fn normal_at(&self, q: Vec2) -> Vec3 {
        let c = self.corner_normals.map(oct_decode);
        let n = (c[0] * (1.0 - q.x) + c[1] * q.x) * (1.0 - q.y)
            + (c[2] * (1.0 - q.x) + c[3] * q.x) * q.y;
        n.normalize_or(oct_decode(self.normal))
    }

    /// The lowest and highest height above the plane of the fitted leaf over its `uv` box (its
    /// corners bound the affine leaf); `None` for a leaf without area.
    pub fn heights(&self) -> Option<(f32, f32)> {
        let (lo, hi) = self.uv_box();
        if lo.cmpgt(hi).any() {
            return None;
        }
        let z =
            [lo, Vec2::new(hi.x, lo.y), hi, Vec2::new(lo.x, hi.y)].map(|uv| leaf_point(self, uv).z);
        Some((
            z.iter().copied().fold(f32::MAX, f32::min),
            z.iter().copied().fold(f32::MIN, f32::max),
        ))
    }
}

/// A plane as the shader reads it (96 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct PlaneRecord {
    /// Origin (xyz) and cell size in metres (w).
    pub origin_cell: [f32; 4],
    /// `u` axis (xyz), rectangle `min.s` (w).
    pub u: [f32; 4],
    /// `v` axis (xyz), rectangle `min.t` (w).
    pub v: [f32; 4],
    /// Normal (xyz), rectangle size along `u` (w).
    pub n: [f32; 4],
    /// Cells along `u`, along `v`, first cell, rectangle size along `v` (bits of an f32).
    pub grid: [u32; 4],
    /// The slab the plane's leaves lie in: lowest and highest height above the plane (x, y;
    /// both 0 for a cloud drawn from its low-resolution tiles only), zeros.
    pub slab: [f32; 4],
}

impl PlaneRecord {
    /// Rectangle minimum (plane coordinates).
    pub fn min(&self) -> Vec2 {
        Vec2::new(self.u[3], self.v[3])
    }
    /// Rectangle size.
    pub fn size(&self) -> Vec2 {
        Vec2::new(self.n[3], f32::from_bits(self.grid[3]))
    }
    /// Cells along `u` and `v`.
    pub fn cells(&self) -> (u32, u32) {
        (self.grid[0], self.grid[1])
    }
    /// The cell holding plane point `st` (clamped into the grid).
    pub fn cell_of(&self, st: Vec2) -> (u32, u32) {
        let c = ((st - self.min()) / self.origin_cell[3]).floor();
        let (nx, ny) = self.cells();
        (
            (c.x.max(0.0) as u32).min(nx - 1),
            (c.y.max(0.0) as u32).min(ny - 1),
        )
    }
    /// The slab's lowest and highest height above the plane.
    pub fn heights(&self) -> (f32, f32) {
        (self.slab[0], self.slab[1])
    }
    /// Plane coordinates of a model-space point.
    pub fn project(&self, p: Vec3) -> Vec2 {
        let d = p - Vec3::from_slice(&self.origin_cell[..3]);
        Vec2::new(
            d.dot(Vec3::from_slice(&self.u[..3])),
            d.dot(Vec3::from_slice(&self.v[..3])),
        )
    }
}

/// One cloud (one geometric level): its planes, hash cells, lists, leaf records and
/// low-resolution tiles.
#[derive(Debug, Clone, PartialEq)]
pub struct Cloud {
    /// The planes.
    pub planes: Vec<PlaneRecord>,
    /// Each plane's leaves (leaf numbers), as clustered.
    pub members: Vec<Vec<u32>>,
    /// Hash cells of every plane in turn: `start << 8 | length` (0: empty).
    pub cells: Vec<u32>,
    /// List entries: record numbers.
    pub lists: Vec<u32>,
    /// One record per leaf, by leaf number.
    pub records: Vec<LeafRecord>,
    /// Low-resolution tile size.
    pub tile: u32,
    /// Per plane two mip chains: seen from the front side, then from the back side.
    pub lowres: Vec<Vec<TileLevel>>,
    /// Whether the shader walks this cloud's lists (the farthest cloud keeps only its
    /// low-resolution tiles: `cells`, `lists` and `records` are empty).
    pub layered: bool,
}

impl Cloud {
    /// GPU bytes of this cloud's buffers and tiles (all mips).
    pub fn bytes(&self) -> u64 {
        let tiles: u64 = self
            .lowres
            .iter()
            .flat_map(|c| c.iter())
            .map(|l| (l.color.len() + l.normal.len()) as u64)
            .sum();
        (self.planes.len() * std::mem::size_of::<PlaneRecord>()
            + self.cells.len() * 4
            + self.lists.len() * 4
            + self.records.len() * std::mem::size_of::<LeafRecord>()) as u64
            + tiles
    }

    /// The cell list of `(plane, cx, cy)`: record numbers, front to back.
    pub fn list(&self, plane: usize, cx: u32, cy: u32) -> &[u32] {
        let p = &self.planes[plane];
        let (nx, _) = p.cells();
        let c = self.cells[(p.grid[2] + cy * nx + cx) as usize];
        let (start, len) = ((c >> 8) as usize, (c & 255) as usize);
        &self.lists[start..start + len]
    }
}

/// Octahedral encoding of a unit vector into `pack2x16snorm`.
pub fn oct_encode(n: Vec3) -> u32 {
    let n = n / (n.x.abs() + n.y.abs() + n.z.abs()).max(1e-20);
    let p = if n.z >= 0.0 {
        Vec2::new(n.x, n.y)
    } else {
        let s = Vec2::new(n.x.signum(), n.y.signum());
        (Vec2::ONE - Vec2::new(n.y.abs(), n.x.abs())) * s
    };
    let q = |x: f32| ((x.clamp(-1.0, 1.0) * 32767.0).round() as i16) as u16 as u32;
    q(p.x) | (q(p.y) << 16)
}

/// The inverse of [`oct_encode`].
pub fn oct_decode(v: u32) -> Vec3 {
    let f = |b: u32| ((b & 0xffff) as u16 as i16) as f32 / 32767.0;
    let (x, y) = (f(v).max(-1.0), f(v >> 16).max(-1.0));
    let z = 1.0 - x.abs() - y.abs();
    let t = (-z).max(0.0);
    Vec3::new(
        x + if x >= 0.0 { -t } else { t },
        y + if y >= 0.0 { -t } else { t },
        z,
    )
    .normalize_or(Vec3::Z)
}

fn pack_unorm2(v: Vec2) -> u32 {
    let q = |x: f32| (x.clamp(0.0, 1.0) * 65535.0).round() as u32;
    q(v.x) | (q(v.y) << 16)
}

/// `pack2x16unorm`'s inverse.
pub fn unpack_unorm2(v: u32) -> Vec2 {
    Vec2::new((v & 0xffff) as f32, (v >> 16) as f32) / 65535.0
}

/// The reference's crown occlusion (`crown_occlusion` in `shaders/frame.wgsl`).
pub fn crown_occlusion(p: Vec3, min: Vec3, max: Vec3) -> f32 {
    let centre = (min + max) * 0.5;
    let half = ((max - min) * 0.5).max(Vec3::splat(1e-3));
    let q = (p - centre) / half;
    let radial = Vec2::new(q.x, q.z).length().clamp(0.0, 1.0);
    let height = ((p.y - min.y) / (2.0 * half.y)).clamp(0.0, 1.0);
    (0.35 + 0.45 * radial + 0.3 * height).clamp(0.0, 1.0)
}

/// Solves the 3×3 system `a x = b` (Cramer); `None` when singular.
fn solve3(a: [[f32; 3]; 3], b: [f32; 3]) -> Option<[f32; 3]> {
    let m = glam::Mat3::from_cols_array_2d(&a).transpose();
    let det = m.determinant();
    if det.abs() < 1e-20 {
        return None;
    }
    Some((m.inverse() * Vec3::from(b)).to_array())
}

/// Least-squares `f(x, y) = a x + b y + c` through the samples (with a tiny ridge so a line of
/// samples still solves, flat across it).
fn fit_affine(samples: &[(Vec2, f32)]) -> [f32; 3] {
    let mut a = [[0.0f32; 3]; 3];
    let mut b = [0.0f32; 3];
    for &(p, f) in samples {
        let r = [p.x, p.y, 1.0];
        for i in 0..3 {
            for j in 0..3 {
                a[i][j] += r[i] * r[j];
            }
            b[i] += r[i] * f;
        }
    }
    let ridge = 1e-9 * (a[0][0] + a[1][1] + a[2][2]).max(1e-12);
    for (i, row) in a.iter_mut().enumerate() {
        row[i] += ridge;
    }
    solve3(a, b).unwrap_or([0.0, 0.0, b[2] / samples.len().max(1) as f32])
}

/// Least-squares bilinear corner values through samples at box coordinates in `[0, 1]²`
/// (fig. 11), ridge-regularised towards the samples' mean so 1–3 vertices still solve.
fn fit_bilinear(samples: &[(Vec2, f32)]) -> [f32; 4] {
    let mean = samples.iter().map(|s| s.1).sum::<f32>() / samples.len().max(1) as f32;
    let mut a = glam::Mat4::ZERO;
    let mut b = glam::Vec4::ZERO;
    for &(p, f) in samples {
        let r = glam::Vec4::new(
            (1.0 - p.x) * (1.0 - p.y),
            p.x * (1.0 - p.y),
            (1.0 - p.x) * p.y,
            p.x * p.y,
        );
        for i in 0..4 {
            *a.col_mut(i) += r * r[i];
        }
        b += r * f;
    }
    let ridge = 1e-3;
    for i in 0..4 {
        a.col_mut(i)[i] += ridge;
        b[i] += ridge * mean;
    }
    if a.determinant().abs() < 1e-12 {
        return [mean; 4];
    }
    (a.inverse() * b).to_array().map(|x| x.clamp(0.0, 1.0))
}

/// The record of `leaf` on `plane`.
fn record(plant: &Plant, leaf: &Leaf, plane: &Plane) -> LeafRecord {
    let m = &plant.leaves;
    let (bmin, bmax) = (Vec3::from(plant.bbox_min), Vec3::from(plant.bbox_max));
    let mut uv_min = Vec2::splat(f32::MAX);
    let mut uv_max = Vec2::splat(f32::MIN);
    // Per plane-space coordinate (s, t, h), then per model-space one: samples over uv.
    let mut fits: [Vec<(Vec2, f32)>; 6] = Default::default();
    let mut color = Vec3::ZERO;
    for &i in &leaf.vertices {
        let uv = Vec2::from(m.uvs[i as usize]);
        let p = Vec3::from(m.positions[i as usize]);
        let st = plane.project(p);
        uv_min = uv_min.min(uv);
        uv_max = uv_max.max(uv);
        for (k, x) in [st.x, st.y, plane.height(p), p.x, p.y, p.z]
            .into_iter()
            .enumerate()
        {
            fits[k].push((uv, x));
        }
        color += Vec3::from(m.colors[i as usize]);
    }
    color /= leaf.vertices.len() as f32;
    // A part of a bent leaf shows its side of the cuts only.
    let uv_min = uv_min.max(leaf.uv_clip[0]);
    let uv_max = uv_max.min(leaf.uv_clip[1]);
    let f: Vec<[f32; 3]> = fits.iter().map(|l| fit_affine(l)).collect();
    // Plane space: x = a uv + origin, least squares; the record holds origin and the rows of
    // a's pseudo-inverse (aᵀa)⁻¹aᵀ.
    let (du, dv) = (
        Vec3::new(f[0][0], f[1][0], f[2][0]),
        Vec3::new(f[0][1], f[1][1], f[2][1]),
    );
    let origin = Vec3::new(f[0][2], f[1][2], f[2][2]);
    let g = glam::Mat2::from_cols(
        Vec2::new(du.dot(du), du.dot(dv)),
        Vec2::new(du.dot(dv), dv.dot(dv)),
    );
    let (to_u, to_v, area) = if g.determinant() > 1e-12 * (g.x_axis.x * g.y_axis.y).max(1e-30) {
        let gi = g.inverse();
        (
            du * gi.x_axis.x + dv * gi.y_axis.x,
            du * gi.x_axis.y + dv * gi.y_axis.y,
            true,
        )
    } else {
        // A leaf without area (its vertices on a line): never hit.
        (Vec3::ZERO, Vec3::ZERO, false)
    };
    // The leaf's frame in model space: +u and +v directions.
    let t = Vec3::new(f[3][0], f[4][0], f[5][0]);
    let bv = Vec3::new(f[3][1], f[4][1], f[5][1]);
    let n = leaf.normal;
    let t = (t - n * t.dot(n)).normalize_or(n.any_orthonormal_vector());
    let flip = n.cross(t).dot(bv) < 0.0;
    let ao_samples: Vec<(Vec2, f32)> = leaf
        .vertices
        .iter()
        .map(|&i| {
            let pos = Vec3::from(m.positions[i as usize]);
            (
                box_q(m, i, uv_min, uv_max),
                crown_occlusion(pos, bmin, bmax),
            )
        })
        .collect();
    let ao = fit_bilinear(&ao_samples);
    // The blade's vertex normals (a bent blade shades unlike its flat fit), on `n`'s side.
    let normal_fit: Vec<[f32; 4]> = (0..3)
        .map(|k| {
            let samples: Vec<(Vec2, f32)> = leaf
                .vertices
                .iter()
                .map(|&i| {
                    let vn = Vec3::from(m.normals[i as usize]);
                    let vn = if vn.dot(n) < 0.0 { -vn } else { vn };
                    (box_q(m, i, uv_min, uv_max), vn[k])
                })
                .collect();
            // Affine, not bilinear: a blade's vertices do not reach its box's corners, and the
            // bilinear fit extrapolates wildly there.
            let [a, b, c] = fit_affine(&samples);
            [c, a + c, b + c, a + b + c]
        })
        .collect();
    let corner_normals = [0, 1, 2, 3].map(|c| {
        oct_encode(Vec3::new(normal_fit[0][c], normal_fit[1][c], normal_fit[2][c]).normalize_or(n))
    });
    let c8 = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u32;
    let (uv_min, uv_max) = if area {
        (pack_unorm2(uv_min), pack_unorm2(uv_max))
    } else {
        (pack_unorm2(Vec2::ONE), pack_unorm2(Vec2::ZERO))
    };
    LeafRecord {
        origin: origin.to_array(),
        uv_min,
        to_u: to_u.to_array(),
        uv_max,
        to_v: to_v.to_array(),
        normal: oct_encode(n),
        tangent: oct_encode(t),
        color: c8(color.x) | (c8(color.y) << 8) | (c8(color.z) << 16) | ((flip as u32) << 24),
        ao: c8(ao[0]) | (c8(ao[1]) << 8) | (c8(ao[2]) << 16) | (c8(ao[3]) << 24),
        pad: 0,
        corner_normals,
    }
}

/// Vertex `i`'s position in the leaf's `uv` box `[uv_min, uv_max]`, in `[0, 1]²`.
fn box_q(m: &sylvan_plant::Mesh, i: u32, uv_min: Vec2, uv_max: Vec2) -> Vec2 {
    (Vec2::from(m.uvs[i as usize]) - uv_min) / (uv_max - uv_min).max(Vec2::splat(1e-6))
}

/// Where the record's fitted leaf lies at image coordinate `uv` (plane space `s`, `t`, `h`):
/// the inverse of [`LeafRecord::to_u`]/`to_v` on the leaf's plane.
pub fn leaf_point(rec: &LeafRecord, uv: Vec2) -> Vec3 {
    let (tu, tv) = (Vec3::from(rec.to_u), Vec3::from(rec.to_v));
    // The rows span the leaf's plane; A = rows (row rowᵀ)⁻¹ maps uv back into it.
    let g = glam::Mat2::from_cols(
        Vec2::new(tu.dot(tu), tu.dot(tv)),
        Vec2::new(tu.dot(tv), tv.dot(tv)),
    );
    let c = g.inverse() * uv;
    Vec3::from(rec.origin) + tu * c.x + tv * c.y
}

/// Whether triangle `t` (2D) overlaps the box `[lo, hi]` (separating axes: the box's two and
/// the triangle's three edge normals). Touching counts as overlapping.
pub fn triangle_overlaps_box(t: [Vec2; 3], lo: Vec2, hi: Vec2) -> bool {
    let tmin = t[0].min(t[1]).min(t[2]);
    let tmax = t[0].max(t[1]).max(t[2]);
    if tmax.x < lo.x || tmin.x > hi.x || tmax.y < lo.y || tmin.y > hi.y {
        return false;
    }
    let corners = [lo, Vec2::new(hi.x, lo.y), hi, Vec2::new(lo.x, hi.y)];
    for i in 0..3 {
        let e = t[(i + 1) % 3] - t[i];
        let axis = Vec2::new(-e.y, e.x);
        let tri: [f32; 3] = t.map(|p| p.dot(axis));
        let (a0, a1) = (
            tri.iter().copied().fold(f32::MAX, f32::min),
            tri.iter().copied().fold(f32::MIN, f32::max),
        );
        let bx = corners.map(|p| p.dot(axis));
        let (b0, b1) = (
            bx.iter().copied().fold(f32::MAX, f32::min),
            bx.iter().copied().fold(f32::MIN, f32::max),
        );
        if a1 < b0 || b1 < a0 {
            return false;
        }
    }
    true
}

/// Bilinear RGBA of an RGBA8 image at `uv` (clamped; rows top to bottom), channels in [0, 1].
fn sample(tex: &LeafTexture, uv: Vec2) -> [f32; 4] {
    if tex.width == 0 || tex.height == 0 {
        return [1.0; 4];
    }
    let (w, h) = (tex.width as i64, tex.height as i64);
    let x = uv.x * w as f32 - 0.5;
    let y = uv.y * h as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let at = |xi: i64, yi: i64| {
        let (xi, yi) = (xi.clamp(0, w - 1), yi.clamp(0, h - 1));
        let i = ((yi * w + xi) * 4) as usize;
        [0, 1, 2, 3].map(|k| tex.rgba[i + k] as f32 / 255.0)
    };
    let (x0, y0) = (x0 as i64, y0 as i64);
    let (a, b, c, d) = (
        at(x0, y0),
        at(x0 + 1, y0),
        at(x0, y0 + 1),
        at(x0 + 1, y0 + 1),
    );
    [0, 1, 2, 3].map(|k| {
        (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy
    })
}

/// What one plane point shows from one side: the first opaque leaf of its cell's list.
pub struct Hit {
    /// Record number.
    pub record: u32,
    /// The leaf image coordinates there.
    pub uv: Vec2,
}

/// Where the ray `o + λ d` (plane space) meets the fitted leaf of `rec`: `λ` and the leaf
/// image coordinates, if inside its box.
pub fn leaf_hit(rec: &LeafRecord, o: Vec3, d: Vec3) -> Option<(f32, Vec2)> {
    let (tu, tv) = (Vec3::from(rec.to_u), Vec3::from(rec.to_v));
    let m = tu.cross(tv);
    let md = m.dot(d);
    if md.abs() <= 1e-6 * m.length() * d.length() || md == 0.0 {
        return None;
    }
    let w = o - Vec3::from(rec.origin);
    let lambda = -m.dot(w) / md;
    let x = w + d * lambda;
    let uv = Vec2::new(tu.dot(x), tv.dot(x));
    let (lo, hi) = rec.uv_box();
    (uv.cmpge(lo).all() && uv.cmple(hi).all()).then_some((lambda, uv))
}

/// Most cells one ray walks through a plane's slab (the shader's `MAX_CELLS`): a ray that
/// would cross more (a plane seen almost edge-on) stops there.
pub const MAX_CELLS: u32 = 64;

/// The span `[λ0, λ1]` of the ray `o + λ d` (plane space) inside the box `[lo, hi]` (3D), if
/// it meets it.
pub fn ray_box(o: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
    let (mut t0, mut t1) = (f32::MIN, f32::MAX);
    for k in 0..3 {
        if d[k].abs() < 1e-12 {
            if o[k] < lo[k] || o[k] > hi[k] {
                return None;
            }
            continue;
        }
        let (a, b) = ((lo[k] - o[k]) / d[k], (hi[k] - o[k]) / d[k]);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    (t0 <= t1).then_some((t0, t1))
}

/// The CPU twin of the fragment shader's walk (§5, fig. 7, through a slab): along the line
/// `o + λ d` (plane space, `d` away from the viewer) inside the plane's slab, cell after cell of
/// the hash grid it crosses, nearest first (at most [`MAX_CELLS`]), the nearest leaf of the
/// cell's list whose image is opaque (alpha ≥ 0.5) where the line meets it inside that cell.
pub fn walk(cloud: &Cloud, plant: &Plant, plane: usize, o: Vec3, d: Vec3) -> Option<Hit> {
    let p = &cloud.planes[plane];
    let (min, size) = (p.min(), p.size());
    let (h0, h1) = p.heights();
    let (t0, t1) = ray_box(o, d, min.extend(h0), (min + size).extend(h1))?;
    let cm = p.origin_cell[3];
    let (nx, ny) = p.cells();
    let start = (o + d * t0).truncate();
    let mut c = ((start - min) / cm).floor();
    c = c.clamp(Vec2::ZERO, Vec2::new(nx as f32 - 1.0, ny as f32 - 1.0));
    let step = Vec2::new(d.x.signum(), d.y.signum());
    // λ at which the ray crosses the cell's next x and y boundaries.
    let next = |c: Vec2| {
        let edge = min + (c + step.max(Vec2::ZERO)) * cm;
        Vec2::new(
            if d.x == 0.0 {
                f32::MAX
            } else {
                (edge.x - o.x) / d.x
            },
            if d.y == 0.0 {
                f32::MAX
            } else {
                (edge.y - o.y) / d.y
            },
        )
    };
    let mut enter = t0;
    for _ in 0..MAX_CELLS {
        let tn = next(c);
        let exit = tn.x.min(tn.y).min(t1);
        let list = cloud.list(plane, c.x as u32, c.y as u32);
        let eps = 1e-4 * cm;
        let mut best: Option<(f32, Hit)> = None;
        for &r in list {
            let rec = &cloud.records[r as usize];
            let Some((lambda, uv)) = leaf_hit(rec, o, d) else {
                continue;
            };
            if lambda < enter - eps
                || lambda > exit + eps
                || best.as_ref().is_some_and(|b| b.0 <= lambda)
            {
                continue;
            }
            if sample(&plant.leaf_texture, uv)[3] >= 0.5 {
                best = Some((lambda, Hit { record: r, uv }));
            }
        }
        if let Some((_, hit)) = best {
            return Some(hit);
        }
        if exit >= t1 {
            return None;
        }
        if tn.x <= tn.y {
            c.x += step.x;
        } else {
            c.y += step.y;
        }
        if c.x < 0.0 || c.y < 0.0 || c.x >= nx as f32 || c.y >= ny as f32 {
            return None;
        }
        enter = exit;
    }
    None
}

/// The cells of a `nx` × `ny` grid of `cell` metres from `min` that the fitted leaf of `rec`
/// covers seen along the plane's normal: its triangles `tris` (image coordinates) placed by the
/// fit and projected onto the plane (a ray through the slab meets the leaf at a point of that
/// projection, so the cell holding the point lists it). Appends cell numbers (with repeats) to
/// `out`.
pub fn leaf_cells(
    rec: &LeafRecord,
    tris: &[[Vec2; 3]],
    min: Vec2,
    cell: f32,
    (nx, ny): (u32, u32),
    out: &mut Vec<u32>,
) {
    let (lo_uv, hi_uv) = rec.uv_box();
    if lo_uv.cmpgt(hi_uv).any() {
        return;
    }
    for t in tris {
        let tri = t.map(|uv| leaf_point(rec, uv).truncate());
        let lo = (tri[0].min(tri[1]).min(tri[2]) - min) / cell;
        let hi = (tri[0].max(tri[1]).max(tri[2]) - min) / cell;
        if hi.x < 0.0 || hi.y < 0.0 {
            continue;
        }
        let (x0, y0) = (lo.x.floor().max(0.0) as u32, lo.y.floor().max(0.0) as u32);
        let x1 = (hi.x.floor().max(0.0) as u32).min(nx - 1);
        let y1 = (hi.y.floor().max(0.0) as u32).min(ny - 1);
        for cy in y0..=y1 {
            for cx in x0..=x1 {
                let clo = min + Vec2::new(cx as f32, cy as f32) * cell;
                if triangle_overlaps_box(tri, clo, clo + Vec2::splat(cell)) {
                    out.push(cy * nx + cx);
                }
            }
        }
    }
}

/// How one cloud is laid out.
#[derive(Debug, Clone, Copy)]
pub struct CloudSpec {
    /// Hash cells over all planes (the cell size follows).
    pub cells: u32,
    /// Low-resolution tile size (a power of two).
    pub tile: u32,
    /// Low-resolution samples per texel per axis.
    pub supersample: u32,
    /// Keep the lists for the shader (else only the low-resolution tiles).
    pub layered: bool,
}

/// Builds one cloud from clustered planes.
pub fn build(
    plant: &Plant,
    leaves: &[Leaf],
    planes: &[Plane],
    spec: CloudSpec,
) -> Result<Cloud, String> {
    let m = &plant.leaves;
    let mut records = vec![LeafRecord::zeroed(); leaves.len()];
    // Each leaf's triangles in image coordinates.
    let uv_tris = |leaf: &Leaf| -> Vec<[Vec2; 3]> {
        leaf.triangles
            .iter()
            .map(|t| t.map(|i| Vec2::from(m.uvs[i as usize])))
            .collect()
    };
    // The slabs: the box of the plane's fitted leaves (plane space).
    let mut rects = Vec::with_capacity(planes.len());
    let mut slabs = Vec::with_capacity(planes.len());
    for plane in planes {
        let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
        let (mut h0, mut h1) = (0.0f32, 0.0f32);
        for &l in &plane.leaves {
            let leaf = &leaves[l as usize];
            let rec = record(plant, leaf, plane);
            records[l as usize] = rec;
            let (lo_uv, hi_uv) = rec.uv_box();
            if lo_uv.cmpgt(hi_uv).any() {
                continue;
            }
            for t in uv_tris(leaf) {
                for uv in t {
                    let x = leaf_point(&rec, uv);
                    lo = lo.min(x.truncate());
                    hi = hi.max(x.truncate());
                    (h0, h1) = (h0.min(x.z), h1.max(x.z));
                }
            }
        }
        if lo.x > hi.x {
            (lo, hi) = (plane.min, plane.max);
        }
        // A rectangle of some width even for a single edge-on leaf.
        rects.push((lo - Vec2::splat(1e-3), hi + Vec2::splat(1e-3)));
        slabs.push([h0 - 1e-3, h1 + 1e-3, 0.0, 0.0]);
    }
    let area: f32 = rects
        .iter()
        .map(|(lo, hi)| (hi.x - lo.x) * (hi.y - lo.y))
        .sum();
    let cell_m = (area / spec.cells.max(1) as f32).sqrt().max(1e-5);
    let mut out_planes = Vec::with_capacity(planes.len());
    let mut cells: Vec<u32> = Vec::new();
    let mut lists: Vec<u32> = Vec::new();
    let mut members = Vec::with_capacity(planes.len());
    for ((plane, &(min, max)), &slab) in planes.iter().zip(&rects).zip(&slabs) {
        let size = max - min;
        let cm = cell_m
            .max(size.x / MAX_CELLS_PER_SIDE as f32)
            .max(size.y / MAX_CELLS_PER_SIDE as f32);
        let nx = ((size.x / cm).ceil() as u32).clamp(1, MAX_CELLS_PER_SIDE);
        let ny = ((size.y / cm).ceil() as u32).clamp(1, MAX_CELLS_PER_SIDE);
        let rec = PlaneRecord {
            origin_cell: plane.origin.extend(cm).to_array(),
            u: plane.u.extend(min.x).to_array(),
            v: plane.v.extend(min.y).to_array(),
            n: plane.normal.extend(size.x).to_array(),
            grid: [nx, ny, cells.len() as u32, size.y.to_bits()],
            slab,
        };
        // Per cell: (height at the centre, record).
        let mut per_cell: Vec<Vec<(f32, u32)>> = vec![Vec::new(); (nx * ny) as usize];
        let mut touched: Vec<u32> = Vec::new();
        for &l in &plane.leaves {
            let leaf = &leaves[l as usize];
            // Sorted by the height of the leaf's centre above the plane.
            let height = plane.height(leaf.centre);
            touched.clear();
            leaf_cells(
                &records[l as usize],
                &uv_tris(leaf),
                min,
                cm,
                (nx, ny),
                &mut touched,
            );
            touched.sort_unstable();
            touched.dedup();
            for &c in &touched {
                per_cell[c as usize].push((height, l));
            }
        }
        for list in &mut per_cell {
            // Front (highest above the plane) first; ties by leaf number, so the order is total.
            list.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
            list.truncate(MAX_LIST);
            if list.is_empty() {
                cells.push(0);
                continue;
            }
            if lists.len() + list.len() > MAX_ENTRIES {
                return Err(format!(
                    "{}: more than {MAX_ENTRIES} leaf fragments in one cloud — lower billboard-cloud cells",
                    plant.name
                ));
            }
            cells.push(((lists.len() as u32) << 8) | list.len() as u32);
            lists.extend(list.iter().map(|x| x.1));
        }
        out_planes.push(rec);
        members.push(plane.leaves.clone());
    }
    let mut cloud = Cloud {
        planes: out_planes,
        members,
        cells,
        lists,
        records,
        tile: spec.tile,
        lowres: Vec::new(),
        layered: spec.layered,
    };
    cloud.lowres = (0..cloud.planes.len())
        .flat_map(|p| [true, false].map(|front| (p, front)))
        .map(|(p, front)| lowres_tile(&cloud, plant, p, front, spec).levels())
        .collect();
    if !spec.layered {
        cloud.cells.clear();
        cloud.lists.clear();
        cloud.records.clear();
        // Drawn flat, from its tiles.
        for p in &mut cloud.planes {
            p.slab = [0.0; 4];
        }
    }
    Ok(cloud)
}

/// The low-resolution tile of `plane` seen from its front (`front`) or back side: at each of
/// `supersample²` points per texel the list walk's first opaque leaf, its albedo (front or
/// back image, times the leaf's colour), its bent normal turned towards the side seen and its
/// interpolated occlusion.
fn lowres_tile(
    cloud: &Cloud,
    plant: &Plant,
    plane: usize,
    front: bool,
    spec: CloudSpec,
) -> TileImage {
    let p = &cloud.planes[plane];
    let n_plane = Vec3::from_slice(&p.n[..3]) * if front { 1.0 } else { -1.0 };
    // Seen straight on (plane space), away from the viewer.
    let down = Vec3::Z * if front { -1.0 } else { 1.0 };
    let (size, ss) = (spec.tile as usize, spec.supersample.max(1) as usize);
    let inv = 1.0 / (ss * ss) as f32;
    let mut color = vec![[0.0f32; 4]; size * size];
    let mut normal_depth = vec![[0.0f32; 4]; size * size];
    let (min, ext) = (p.min(), p.size());
    let back_tex = if plant.leaf_back.width > 0 {
        &plant.leaf_back
    } else {
        &plant.leaf_texture
    };
    for y in 0..size {
        for x in 0..size {
            let (mut c, mut nd, mut hits) = ([0.0f32; 4], Vec3::ZERO, 0.0f32);
            let mut ao_sum = 0.0;
            for sy in 0..ss {
                for sx in 0..ss {
                    let f = Vec2::new(
                        (x as f32 + (sx as f32 + 0.5) / ss as f32) / size as f32,
                        (y as f32 + (sy as f32 + 0.5) / ss as f32) / size as f32,
                    );
                    let st = min + f * ext;
                    let Some(hit) = walk(cloud, plant, plane, st.extend(0.0), down) else {
                        continue;
                    };
                    let rec = &cloud.records[hit.record as usize];
                    let (s, albedo, ao) = shade(rec, plant, back_tex, hit.uv, n_plane);
                    for k in 0..3 {
                        c[k] += albedo[k];
                    }
                    c[3] += 1.0;
                    nd += s;
                    ao_sum += ao;
                    hits += 1.0;
                }
            }
            color[y * size + x] = c.map(|v| v * inv);
            if hits > 0.0 {
                let n = nd.normalize_or(n_plane);
                normal_depth[y * size + x] = [n.x, n.y, n.z, ao_sum / hits];
            }
        }
    }
    TileImage {
        size: spec.tile,
        color,
        normal_depth,
    }
}

/// A leaf texel's bent normal facing `toward`, its linear albedo (premultiplied by 1) and
/// its occlusion, as the fragment shader computes them.
fn shade(
    rec: &LeafRecord,
    plant: &Plant,
    back_tex: &LeafTexture,
    uv: Vec2,
    toward: Vec3,
) -> (Vec3, [f32; 3], f32) {
    let (lo, hi) = rec.uv_box();
    let q = ((uv - lo) / (hi - lo).max(Vec2::splat(1e-6))).clamp(Vec2::ZERO, Vec2::ONE);
    let face = oct_decode(rec.normal);
    let n = rec.normal_at(q);
    let t = oct_decode(rec.tangent);
    let t = (t - n * t.dot(n)).normalize_or(n.any_orthonormal_vector());
    let flip = (rec.color >> 24) & 1 == 1;
    let b = n.cross(t) * if flip { -1.0 } else { 1.0 };
    let bump = if plant.leaf_normal.width > 0 {
        let m = sample(&plant.leaf_normal, uv);
        Vec3::new(m[0], m[1], m[2]) * 2.0 - Vec3::ONE
    } else {
        Vec3::Z
    };
    let bent = (t * bump.x + b * bump.y + n * bump.z).normalize_or(n);
    let seen_front = face.dot(toward) >= 0.0;
    let tex = sample(
        if seen_front {
            &plant.leaf_texture
        } else {
            back_tex
        },
        uv,
    );
    let col = [
        (rec.color & 255) as f32 / 255.0,
        ((rec.color >> 8) & 255) as f32 / 255.0,
        ((rec.color >> 16) & 255) as f32 / 255.0,
    ];
    let albedo = [0, 1, 2].map(|k| crate::technique::common::srgb_to_linear(tex[k]) * col[k]);
    let a = [0, 8, 16, 24].map(|s| ((rec.ao >> s) & 255) as f32 / 255.0);
    let ao =
        (a[0] * (1.0 - q.x) + a[1] * q.x) * (1.0 - q.y) + (a[2] * (1.0 - q.x) + a[3] * q.x) * q.y;
    let s = if seen_front { bent } else { -bent };
    (s, albedo, ao)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn octahedral_normals_round_trip() {
        for d in [
            Vec3::X,
            -Vec3::Y,
            Vec3::new(0.3, -0.8, 0.52).normalize(),
            Vec3::new(-0.7, 0.1, -0.7).normalize(),
        ] {
            assert!(oct_decode(oct_encode(d)).dot(d) > 0.9999, "{d:?}");
        }
    }

    #[test]
    fn separating_axes() {
        let t = [Vec2::ZERO, Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)];
        assert!(triangle_overlaps_box(t, Vec2::splat(0.2), Vec2::splat(0.3)));
        // Beyond the hypotenuse, inside the bounding box.
        assert!(!triangle_overlaps_box(
            t,
            Vec2::splat(0.6),
            Vec2::splat(0.9)
        ));
        assert!(!triangle_overlaps_box(
            t,
            Vec2::splat(1.1),
            Vec2::splat(2.0)
        ));
    }

    #[test]
    fn bilinear_fit_is_exact_on_corners() {
        let s = [
            (Vec2::new(0.0, 0.0), 0.1),
            (Vec2::new(1.0, 0.0), 0.4),
            (Vec2::new(0.0, 1.0), 0.6),
            (Vec2::new(1.0, 1.0), 0.9),
        ];
        let c = fit_bilinear(&s);
        for (got, want) in c.iter().zip([0.1, 0.4, 0.6, 0.9]) {
            assert!((got - want).abs() < 0.01, "{c:?}");
        }
    }
}
