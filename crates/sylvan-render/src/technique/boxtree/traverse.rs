//! LCV04 §4.1–§4.2 per tree and frame: walk the box tree from the root, draw a box's images
//! when the box is beyond its LOD distance, else open it — its residual leaves (and wood) as
//! geometry, its textured children visited in turn. Near the LOD distance, over a band, both
//! are drawn with complementary *presence* weights (§4.2's alpha-blended transition): the
//! impostor's opacity is `1 − (1 − α)^w` (its optical depth scaled by `w`), and geometry
//! leaves are kept with probability `w`, so the sum is seamless rather than a hard switch.
//! GPU-free.

use super::bake::BakedBox;
use glam::Vec3;

/// What the traversal needs from the view.
#[derive(Debug, Clone, PartialEq)]
pub struct LodView {
    /// Eye position (world).
    pub eye: Vec3,
    /// Pixels covered by one metre at one metre's distance (`height / (2 tan(fov_y / 2))`),
    /// divided by the texel-to-pixel ratio at which a box opens (1: open when a texel would
    /// cover more than a pixel).
    pub pixels_per_metre: f32,
    /// For a shadow cascade: its texel footprint (metres) and the eye-distance range of the
    /// receivers it shadows. Boxes outside that range (shadowed through other cascades) need no
    /// more detail than the footprint; boxes inside keep the camera's level, so that what the
    /// eye sees shadows itself consistently.
    pub footprint: Option<(f32, std::ops::Range<f32>)>,
    /// Relative width of the transition band beyond the LOD distance (0.3: the box starts
    /// fading at 1.3 × its LOD distance and is fully open at 1 ×).
    pub band: f32,
}

impl LodView {
    /// Metres covered by one pixel at `distance`.
    pub fn footprint_at(&self, distance: f32) -> f32 {
        let perspective = distance / self.pixels_per_metre.max(1e-6);
        match &self.footprint {
            Some((f, receivers)) if !receivers.contains(&distance) => f.max(perspective),
            _ => perspective,
        }
    }
}

/// A tree's placement: base, uniform scale, rotation about Y as (cos, sin).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Trunk base (world).
    pub base: Vec3,
    /// Uniform scale (plant units → metres).
    pub scale: f32,
    /// cos(rotation).
    pub cos: f32,
    /// sin(rotation).
    pub sin: f32,
}

impl Placement {
    /// Model-space point → world.
    pub fn to_world(&self, p: Vec3) -> Vec3 {
        let q = p * self.scale;
        self.base
            + Vec3::new(
                self.cos * q.x + self.sin * q.z,
                q.y,
                -self.sin * q.x + self.cos * q.z,
            )
    }
}

/// Presences this close to 0 or 1 are snapped (see [`traverse`]).
pub const SNAP: f32 = 0.02;

/// Impostor presence for a pixel footprint `ratio` times the box's texel size: 1 (images only)
/// at `1 + band` and beyond, 0 (opened) at 1 or below, smooth in between. In a perspective view
/// the ratio is the distance over the box's LOD distance (LCV04 §4.1: where one of its texels
/// covers one pixel).
pub fn impostor_presence(ratio: f32, band: f32) -> f32 {
    crate::technique::common::smoothstep01((ratio - 1.0) / band.max(1e-3))
}

/// Walks one tree's box tree. `impostor(box, presence, distance)` is called for each box drawn
/// as images, `residual(box, presence)` for each opened box's geometry. Presences along any
/// root-to-leaf path sum to `presence` (the tree's own, 1 unless a LOD chain is fading it).
/// Uses `stack` as scratch (no allocation once it has grown).
pub fn traverse(
    boxes: &[BakedBox],
    at: &Placement,
    view: &LodView,
    presence: f32,
    stack: &mut Vec<(u32, f32)>,
    mut impostor: impl FnMut(u32, f32, f32),
    mut residual: impl FnMut(u32, f32),
) {
    stack.clear();
    stack.push((0, presence));
    while let Some((b, w)) = stack.pop() {
        let bx = &boxes[b as usize];
        let centre = (Vec3::from(bx.min) + Vec3::from(bx.max)) * 0.5;
        let d = at.to_world(centre).distance(view.eye);
        let texel = bx.metres_per_texel * at.scale;
        let t = impostor_presence(view.footprint_at(d) / texel.max(1e-9), view.band);
        // Within 2% of either end of the band, snap: a sliver of presence would cost a whole
        // draw of the other representation for an invisible contribution.
        let t = if t < SNAP {
            0.0
        } else if t > 1.0 - SNAP {
            1.0
        } else {
            t
        };
        if t > 0.0 {
            impostor(b, w * t, d);
        }
        let open = w * (1.0 - t);
        if open > 0.0 {
            residual(b, open);
            stack.extend(bx.children.iter().map(|&c| (c, open)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn boxes() -> Vec<BakedBox> {
        let b = |parent: u32, children: Vec<u32>, min: [f32; 3], max: [f32; 3]| BakedBox {
            node: 0,
            parent,
            children,
            min,
            max,
            residual_leaves: 0..0,
            residual_wood: 0..0,
            metres_per_texel: (max[1] - min[1]) / 64.0,
            leaves: 1,
        };
        vec![
            b(u32::MAX, vec![1, 2], [-2.0, 0.0, -2.0], [2.0, 10.0, 2.0]),
            b(0, vec![], [0.0, 5.0, 0.0], [2.0, 7.0, 2.0]),
            b(0, vec![], [-2.0, 2.0, -2.0], [0.0, 4.0, 0.0]),
        ]
    }

    type Visits = Vec<(u32, f32)>;

    fn run(distance: f32) -> (Visits, Visits) {
        let view = LodView {
            eye: Vec3::new(0.0, 5.0, -distance),
            pixels_per_metre: 500.0,
            footprint: None,
            band: 0.3,
        };
        let at = Placement {
            base: Vec3::ZERO,
            scale: 1.0,
            cos: 1.0,
            sin: 0.0,
        };
        let (mut imp, mut res) = (Vec::new(), Vec::new());
        traverse(
            &boxes(),
            &at,
            &view,
            1.0,
            &mut Vec::new(),
            |b, w, _| imp.push((b, w)),
            |b, w| res.push((b, w)),
        );
        (imp, res)
    }

    #[test]
    fn far_is_one_impostor_near_is_geometry() {
        // Root LOD distance: 10/64 × 500 = 78 m.
        let (imp, res) = run(500.0);
        assert_eq!(imp, vec![(0, 1.0)]);
        assert!(res.is_empty());
        let (imp, res) = run(0.5);
        assert!(imp.is_empty(), "{imp:?}");
        assert_eq!(res.len(), 3);
        assert!(res.iter().all(|r| r.1 == 1.0));
    }

    #[test]
    fn presence_is_conserved_through_transitions() {
        for d in (1..400).map(|i| i as f32 * 0.5) {
            let (imp, res) = run(d);
            // Along root → child: impostor(root) + impostor(child) + residual(child) = 1.
            for child in [1u32, 2] {
                let w =
                    |v: &[(u32, f32)], b| v.iter().filter(|x| x.0 == b).map(|x| x.1).sum::<f32>();
                let total = w(&imp, 0) + w(&imp, child) + w(&res, child);
                assert!((total - 1.0).abs() < 1e-3, "d {d}: {total}");
            }
        }
    }

    #[test]
    fn presence_is_continuous_in_distance() {
        let mut prev = impostor_presence(0.0, 0.3);
        for i in 1..2000 {
            let p = impostor_presence(i as f32 * 0.001, 0.3);
            assert!((p - prev).abs() < 0.01);
            prev = p;
        }
        assert_eq!(impostor_presence(1.0, 0.3), 0.0);
        assert_eq!(impostor_presence(1.3, 0.3), 1.0);
    }

    #[test]
    fn footprint_floor_applies_outside_the_cascade_receivers() {
        let view = LodView {
            eye: Vec3::ZERO,
            pixels_per_metre: 500.0,
            footprint: Some((0.5, 100.0..300.0)),
            band: 0.3,
        };
        assert_eq!(view.footprint_at(1.0), 0.5);
        assert_eq!(view.footprint_at(200.0), 0.4);
        assert_eq!(view.footprint_at(320.0), 0.64);
        assert_eq!(view.footprint_at(1000.0), 2.0);
    }
}
