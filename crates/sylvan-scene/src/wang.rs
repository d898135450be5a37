//! Poisson-disk Wang tiles: the aperiodic tiling of tileable point patterns that BN12 §4 lays
//! its tree seeds out with, after Cohen, Shade, Hiller and Deussen 2003, "Wang Tiles for Image
//! and Texture Generation" (CSHD03; its Poisson-disk tiles).
//!
//! A [`WangSet`] is 16 square tiles of side `T`, one per choice of 2 colours on each of the 4
//! edges (2 for horizontal edges, 2 for vertical ones). Any placement of the tiles in which
//! touching edges share a colour keeps every two points at least `r` apart, across edges and
//! corners too; [`WangSet::tile_of`] picks the tile of copy `(tx, ty)` from edge colours hashed
//! from `(seed, tx, ty)`, so the tiling is deterministic, non-periodic and needs no storage.
//!
//! # Construction
//!
//! Every edge of the square grid owns the *diamond* whose diagonal it is (vertices: the edge's
//! two ends and the centres of the two tiles beside it); these diamonds tile the plane, and a
//! tile is the four half-diamonds of its edges, cut along its two diagonals (as in CSHD03).
//! Let `w = r/2` (plus 1e-4 for rounding).
//!
//! 1. **Diamond cores.** For each edge colour (2 horizontal, 2 vertical) Bridson's sampling
//!    fills the diamond's *core*, the points ≥ `w` from the diamond's boundary, once. Both
//!    tiles beside an edge take their half of the same core, so the spacing holds across
//!    every edge. Two core points of *different* diamonds are ≥ 2w = r apart whatever the
//!    colours: the diamonds are convex with disjoint interiors, so the segment between the
//!    points leaves the first diamond (≥ w after its start) before it enters the second (≥ w
//!    before its end).
//! 2. **Seam refill.** The points of a tile not in a core are those within `w` of its
//!    diagonals (where its four half-diamonds meet, CSHD03's seams). Each of the 16 tiles
//!    refills this band by Bridson's sampling conditioned on the core points of its four
//!    diamonds (both halves, so neighbours' points count), leaving out the disks of radius
//!    `R = 1.5 r` about its corners.
//! 3. **Why the corners hold.** A corner is the one place where points a tile cannot know
//!    meet it: the other two diamonds at that corner and the refill bands of the three other
//!    tiles there. (a) A refill point `p` of tile A at distance ≥ R from corner `c`, against
//!    the core of a foreign diamond at `c`: that core is a right-angled cone with its apex
//!    `w√2` beyond `c`, pointing away from A; its nearest point to `p` is the apex (distance
//!    ≥ |p − c| ≥ R) or on its side (distance ≥ (|p − c| + w√2)/√2 ≥ R/√2 + r/2 > r).
//!    (b) Against the refill band of the tile beside A across an edge at `c`: the two bands
//!    follow perpendicular rays from `c` and are ≤ w wide on either side of them, so with both
//!    points ≥ R from `c` their distance is ≥ √2·(√(R² − w²) − w) = 1.29 r (≥ r needs
//!    R ≥ 1.31 r). The tile diagonally across `c` has its band on the opposite ray (≥ 2.8 r);
//!    every other pair of diagonals is parallel and ≥ T/√2 apart, or far away. (c) Within a
//!    tile Bridson's conditioning keeps the spacing. Hence any valid tiling keeps `r`, given
//!    `T ≥ 4 r` (checked by [`WangSet::new`]).
//!
//! # Deviations from CSHD03
//!
//! - CSHD03 joins the half-diamonds along a seam chosen to keep the spacing; here a band
//!   about the seams is emptied and refilled by conditioned Bridson, with no relaxation, using
//!   the same sampler (Roberts' variant of Bridson, [`crate::poisson_disk`]) as the other
//!   methods.
//! - No refill point lies within 1.5 r of a tile corner (the shadermap plan's D12): the
//!   diamond cores still reach to 0.71 r of it, so the hole is small: the measured density is
//!   about 1 % below [`crate::poisson_tile`]'s at the same radius (−1.1 % for tiles of 24 r,
//!   −0.8 % at the forest's 53 r; tests/wang.rs).
//! - Colours come from a hash of the edge's coordinates rather than from CSHD03's sequential
//!   random choice of tiles that match the already placed neighbours; every combination of
//!   colours exists among the 16 tiles, so any colouring is valid and each copy is computed
//!   alone, in any order. The tiling is non-periodic because it is random (hashed), not
//!   because the tile set forces it (it does not, as in CSHD03's stochastic tilings).

use crate::placement::bridson_in;
use crate::rng::{Rng, hash2, mix};
use glam::Vec2;
use std::f32::consts::SQRT_2;

/// Colours per edge orientation.
const COLOURS: usize = 2;
/// Radius about each tile corner that no refill point enters, × r (see the module docs).
const CORNER_KEEP_OUT: f32 = 1.5;
/// Salt of the tiling's edge-colour hash.
const TILING_SALT: u64 = 0x57A4_6E11_0C0A_D5E5;

/// A set of 16 Poisson-disk Wang tiles (2 colours per edge orientation; Cohen, Shade, Hiller
/// and Deussen 2003) and the hashed, non-periodic tiling of the plane made with them, as BN12
/// §4 lays out tree seeds.
///
/// Each edge colour owns a Poisson-disk diamond (the edge's two ends and the centres of the
/// tiles beside it), sampled once and kept ≥ r/2 inside its boundary; a tile is the four
/// half-diamonds of its edges, plus its diagonal seams refilled by Bridson's sampling
/// conditioned on those points, except within 1.5 r of its corners. Any valid tiling then keeps
/// every two points ≥ r apart, across edges and corners (the argument is in `wang.rs`'s module
/// docs; `tests/wang.rs` checks every pair of tiles that can touch).
#[derive(Debug, Clone)]
pub struct WangSet {
    side: f32,
    radius: f32,
    tiling: u64,
    /// Per tile, its points in `[0, side)²`, sorted by y then x.
    tiles: Vec<Vec<Vec2>>,
}

impl WangSet {
    /// Number of tiles in a set.
    pub const TILES: usize = COLOURS.pow(4);

    /// The set of tiles of side `side` metres whose points keep `radius` metres apart in any
    /// valid tiling, built deterministically from `seed` (the same arguments give the same
    /// points, bit for bit). Panics unless `side ≥ 4 × radius > 0` and both are finite.
    pub fn new(side: f32, radius: f32, seed: u64) -> Self {
        assert!(
            radius > 0.0 && side.is_finite() && side >= 4.0 * radius,
            "Wang tiles need side ≥ 4 r > 0 (side {side}, r {radius})"
        );
        let w = 0.5 * radius * (1.0 + 1e-4);
        let half = 0.5 * side;
        // 1. Diamond cores, sampled in the diamond's bounding square and moved to the frame of
        //    the tile above (horizontal edge) or to the right (vertical edge) of their edge.
        let core = half - w * SQRT_2;
        let diamond = |kind: i64, colour: usize, shift: Vec2| -> Vec<Vec2> {
            let mut rng = Rng::new(hash2(seed, kind, colour as i64));
            let inside = |p: Vec2| (p.x - half).abs() + (p.y - half).abs() <= core;
            bridson_in([side, side], radius, &mut rng, false, &[], inside)
                .into_iter()
                .map(|p| p - shift)
                .collect()
        };
        let horizontal: Vec<Vec<Vec2>> = (0..COLOURS)
            .map(|c| diamond(0, c, Vec2::new(0.0, half)))
            .collect();
        let vertical: Vec<Vec<Vec2>> = (0..COLOURS)
            .map(|c| diamond(1, c, Vec2::new(half, 0.0)))
            .collect();
        // 2. Per tile, its four half-diamonds and the refilled seams.
        let below_side = |v: f32| if v < side { v } else { side.next_down() };
        let diagonal = |q: Vec2| (q.x - q.y).abs().min((q.x + q.y - side).abs()) / SQRT_2;
        let keep_out = CORNER_KEEP_OUT * radius;
        let margin = 2.0 * radius;
        let tiles = (0..Self::TILES)
            .map(|t| {
                let [s, wc, n, e] = Self::colours(t);
                let mut points: Vec<Vec2> = Vec::new();
                points.extend(horizontal[s].iter().filter(|p| p.y >= 0.0));
                points.extend(
                    horizontal[n]
                        .iter()
                        .filter(|p| p.y < 0.0)
                        .map(|p| Vec2::new(p.x, below_side(p.y + side))),
                );
                points.extend(vertical[wc].iter().filter(|p| p.x >= 0.0));
                points.extend(
                    vertical[e]
                        .iter()
                        .filter(|p| p.x < 0.0)
                        .map(|p| Vec2::new(below_side(p.x + side), p.y)),
                );
                // The refill runs in the tile grown by `margin`, conditioned on the cores'
                // points (both halves of each diamond) near the band.
                let offset = Vec2::splat(margin);
                let boxed = side + 2.0 * margin;
                let fixed: Vec<Vec2> = horizontal[s]
                    .iter()
                    .copied()
                    .chain(horizontal[n].iter().map(|p| *p + Vec2::new(0.0, side)))
                    .chain(vertical[wc].iter().copied())
                    .chain(vertical[e].iter().map(|p| *p + Vec2::new(side, 0.0)))
                    .filter(|&q| diagonal(q) < 2.0 * radius)
                    .map(|q| q + offset)
                    .filter(|p| (0.0..boxed).contains(&p.x) && (0.0..boxed).contains(&p.y))
                    .collect();
                let inside = |p: Vec2| {
                    let q = p - offset;
                    let corner = Vec2::new(q.x.min(side - q.x), q.y.min(side - q.y));
                    (0.0..side).contains(&q.x)
                        && (0.0..side).contains(&q.y)
                        && diagonal(q) < w
                        && corner.length_squared() >= keep_out * keep_out
                };
                let mut rng = Rng::new(hash2(seed, 2, t as i64));
                let refill = bridson_in([boxed; 2], radius, &mut rng, false, &fixed, inside);
                points.extend(refill.into_iter().map(|p| p - offset));
                points.sort_by(|a, b| a.y.total_cmp(&b.y).then(a.x.total_cmp(&b.x)));
                points
            })
            .collect();
        Self {
            side,
            radius,
            tiling: mix(seed ^ TILING_SALT),
            tiles,
        }
    }

    /// The tiles' side, metres.
    pub fn side(&self) -> f32 {
        self.side
    }

    /// The minimum distance between points of any valid tiling, metres.
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// The points of tile `tile` (< [`Self::TILES`]) in tile coordinates `[0, side)²`, sorted
    /// by y, then x.
    pub fn points(&self, tile: usize) -> &[Vec2] {
        &self.tiles[tile]
    }

    /// The edge colours of tile `tile`: `[bottom, left, top, right]` (bottom/top are
    /// horizontal-edge colours, left/right vertical-edge ones), each < 2.
    pub fn colours(tile: usize) -> [usize; 4] {
        [tile & 1, (tile >> 1) & 1, (tile >> 2) & 1, (tile >> 3) & 1]
    }

    /// The tile of copy `(tx, ty)` (covering `[tx·side, (tx+1)·side) × [ty·side, (ty+1)·side)`):
    /// the bottom and left edges of a copy take their colours from bits of a hash of
    /// `(seed, tx, ty)`, its top and right edges those of the copies above and to the right, so
    /// touching copies always agree. Deterministic, constant time, non-periodic.
    pub fn tile_of(&self, tx: i64, ty: i64) -> usize {
        let bits = |x: i64, y: i64| hash2(self.tiling, x, y) >> 32;
        let here = bits(tx, ty);
        let bottom = here & 1;
        let left = (here >> 1) & 1;
        let top = bits(tx, ty.wrapping_add(1)) & 1;
        let right = (bits(tx.wrapping_add(1), ty) >> 1) & 1;
        (bottom | left << 1 | top << 2 | right << 3) as usize
    }

    /// The points of copy `(tx, ty)` in world coordinates (its tile's points offset by the
    /// copy's corner), in the tile's order.
    pub fn copy_points(&self, tx: i64, ty: i64) -> impl Iterator<Item = Vec2> + '_ {
        let origin = Vec2::new(tx as f32, ty as f32) * self.side;
        self.tiles[self.tile_of(tx, ty)]
            .iter()
            .map(move |&p| origin + p)
    }

    /// Mean points per m² over the 16 tiles (each is equally likely under the hashed tiling).
    pub fn density(&self) -> f64 {
        let n: usize = self.tiles.iter().map(Vec::len).sum();
        n as f64 / (Self::TILES as f64 * self.side as f64 * self.side as f64)
    }
}
