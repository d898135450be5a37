//! MNP01 §4's level selection for one tree, GPU-free: from the projected size of its baked
//! texels, how much of the tree's presence goes to its tree billboard, to its opened level below
//! (main branches and rest) and to its meshes — as a whole, or branch by branch
//! ([`HbtDrawParams::mesh_per_branch`]) — each switch cross-faded by a smoothstep over
//! `pixels · (1 ± band)` ([`HbtDrawParams::band`]). [`Hbt::update`](super::Hbt::update) calls
//! [`select`] per tree and pass and draws what it returns.

use crate::technique::common::smoothstep;
use crate::technique::hbt::HbtDrawParams;

/// One switch between two levels by projected texel size: the level below opens when a texel
/// of the level above would cover more than `pixels` pixels, cross-faded over
/// `[lo, hi] = pixels · (1 ± band)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Switch {
    /// Pixels per texel where the level below starts to show.
    pub lo: f32,
    /// Pixels per texel where it has replaced the level above.
    pub hi: f32,
}

impl Switch {
    /// The switch at `pixels` per texel, cross-faded over the relative `band` (0: a hard switch).
    pub fn new(pixels: f32, band: f32) -> Self {
        Self {
            lo: pixels * (1.0 - band),
            hi: pixels * (1.0 + band),
        }
    }

    /// The share of the level below when one texel of the level above covers `texel_px`
    /// pixels: 0 up to `lo`, 1 from `hi` (and at `lo` when the band is empty), smooth between.
    pub fn share(&self, texel_px: f32) -> f32 {
        smoothstep(self.lo, self.hi, texel_px)
    }
}

/// Pixels one texel of side `texel` (model metres per unit scale) covers on a tree of scale
/// `scale` at `dist` metres, `pixels_per_metre` being the pixels one metre covers at one metre.
pub fn texel_pixels(texel: f32, scale: f32, pixels_per_metre: f32, dist: f32) -> f32 {
    texel * scale * pixels_per_metre / dist
}

/// The share opened by `switch` at `texel_px` pixels per texel, 0 when there is nothing to
/// open into (`opens` false: no level below the tree, no small branches below a main branch).
pub fn open_share(switch: Switch, opens: bool, texel_px: f32) -> f32 {
    if opens { switch.share(texel_px) } else { 0.0 }
}

/// The pixels per texel of the level just above the meshes at which the meshes open:
/// `mesh_texel_pixels` below a level of branches, `open_texel_pixels` for a plant without a
/// level below (its tree level is replaced where it would be magnified; the branches' earlier
/// switch has no meaning for it).
pub fn mesh_pixels(p: &HbtDrawParams, has_below: bool) -> f32 {
    if has_below {
        p.mesh_texel_pixels
    } else {
        p.open_texel_pixels
    }
}

/// What one tree's levels cost to draw, in microseconds of GPU time (#15: levels chosen per
/// plant from what they cost, not only from where they are magnified). Measured on lavapipe
/// (the 2-core VM of BENCHMARKS.md, "`hbt`: the level below against the meshes"): one
/// chestnut and one pine alone at 256² and 512², the trees pass with the tree level, the level
/// below and the meshes each forced, fitted per billboard, per shaded fragment and per
/// triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelCosts {
    /// One billboard of the level below, whatever its size (vertex work, set-up, its
    /// visibility interpolation).
    pub billboard_us: f32,
    /// One fragment of the level below's billboards (BTF look-ups, cube-map visibility).
    pub branch_fragment_us: f32,
    /// One triangle of the plant's meshes.
    pub triangle_us: f32,
    /// One fragment of the tree's own area drawn as meshes.
    pub mesh_fragment_us: f32,
}

impl LevelCosts {
    /// lavapipe's (chestnut: 16 µs a billboard and 0.69 µs a fragment of its level below,
    /// pine: 19 and 0.29; meshes 0.14 µs a triangle and 0.13 a fragment).
    pub const LAVAPIPE: LevelCosts = LevelCosts {
        billboard_us: 17.0,
        branch_fragment_us: 0.5,
        triangle_us: 0.14,
        mesh_fragment_us: 0.13,
    };

    /// The level below's cost and the meshes' for one tree of `b` (`triangles` in its meshes)
    /// where it opens (`open_texel_pixels` pixels per tree texel).
    pub fn at_opening(
        &self,
        b: &crate::technique::hbt::bake::HbtBaked,
        triangles: usize,
        open_texel_pixels: f32,
    ) -> (f32, f32) {
        let pixels = b.tree_pixels(open_texel_pixels);
        let below = self.billboard_us * b.placements.len() as f32
            + self.branch_fragment_us * b.branch_fill() * pixels;
        let meshes = self.triangle_us * triangles as f32 + self.mesh_fragment_us * pixels;
        (below, meshes)
    }

    /// Whether `b`'s level below costs at least as much as its meshes where the tree opens:
    /// then the level is dominated — the meshes are closer to the reference, and no dearer.
    pub fn below_costs_more(
        &self,
        b: &crate::technique::hbt::bake::HbtBaked,
        triangles: usize,
        open_texel_pixels: f32,
    ) -> bool {
        let (below, meshes) = self.at_opening(b, triangles, open_texel_pixels);
        below >= meshes
    }
}

/// What the selection needs of one plant: its baked texel sizes and its two switches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantLod {
    /// Tree-level texel side per unit scale (model metres).
    pub texel: f32,
    /// Texel side of the level drawn just above the meshes per unit scale (the largest main
    /// branch's, or the tree's without a level below).
    pub mesh_texel: f32,
    /// Bounding radius per unit scale.
    pub radius: f32,
    /// Placements of the level below (0: the tree opens straight into its meshes).
    pub placements: usize,
    /// Whether the meshes open branch by branch (the plant's meshes split by placement).
    pub per_branch: bool,
    /// Tree → level below ([`HbtDrawParams::open_texel_pixels`]).
    pub open: Switch,
    /// → meshes, at [`mesh_pixels`].
    pub mesh: Switch,
}

/// One tree in one pass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TreeAt {
    /// The tree's presence (the scene's own fade), shared out by [`select`].
    pub presence: f32,
    /// Its uniform scale.
    pub scale: f32,
    /// Eye to its box centre, metres (> 0).
    pub dist: f32,
    /// Pixels one metre covers at one metre.
    pub pixels_per_metre: f32,
    /// Whether the plant's meshes are drawn at all (`levels` = 3).
    pub meshes: bool,
    /// Whether this pass draws the tree's meshes: the camera pass, or a cascade that shades its
    /// leaves.
    pub meshes_here: bool,
    /// A shadow pass: a tree opened into BTFs only casts at the tree level.
    pub shadow: bool,
}

/// One placement of an opened tree that opens into its own meshes by its own texel (branch by
/// branch).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PartAt {
    /// Texel side of its lowest BTF level per unit tree scale.
    pub texel: f32,
    /// Eye to its box centre, metres (> 0).
    pub dist: f32,
    /// Whether this pass draws its meshes (as [`TreeAt::meshes_here`]).
    pub meshes_here: bool,
}

/// How one tree's presence is shared (they sum to it).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Shares {
    /// Its meshes as a whole.
    pub meshes: f32,
    /// Its tree billboard.
    pub tree: f32,
    /// Its opened level below: each placement's part drawn as meshes by `part_mesh`, the rest
    /// as its billboard.
    pub below: f32,
}

/// MNP01 §4 for one tree: opens it into the level below when its texels would be magnified
/// (`lod.open`), and into its meshes when the level above them would be (`lod.mesh`) — as a
/// whole, or with `lod.per_branch` each placement by its own texel and distance (`parts`, one
/// per placement, consumed only then: `None` for a placement that opens with the rest, as the
/// rest — the trunk — does with the first branch to open). Writes into `part_mesh`, per
/// placement, its share of [`Shares::below`] drawn as meshes.
pub fn select(
    lod: &PlantLod,
    tree: &TreeAt,
    parts: impl Iterator<Item = Option<PartAt>>,
    part_mesh: &mut Vec<f32>,
) -> Shares {
    let (scale, ppm, dist, presence) =
        (tree.scale, tree.pixels_per_metre, tree.dist, tree.presence);
    // MNP01 §4: open the tree when its texels would be magnified.
    let open = open_share(
        lod.open,
        lod.placements > 0,
        texel_pixels(lod.texel, scale, ppm, dist),
    );
    // How the tree's presence is shared: its meshes as a whole, its tree billboard, and its
    // opened objects (each a mesh part and a billboard by `part_mesh`). The polygonal level
    // opens when the BTF level above it would be magnified, decided from the camera in every
    // pass so that a tree casts what it shows; a pass casts meshes only into the cascades that
    // shade them.
    part_mesh.clear();
    let (mut whole, mut tree_bb, mut below) = (0.0, 0.0, 0.0);
    // Branch by branch, unless no branch could be near enough (its largest texel at the tree's
    // nearest point).
    let reach = texel_pixels(
        lod.mesh_texel,
        scale,
        ppm,
        (dist - lod.radius * scale).max(1e-3),
    );
    if tree.meshes && lod.per_branch && reach > lod.mesh.lo {
        // Branch by branch: each placement by its own lowest BTF texel and distance; the rest
        // (trunk) with the first branch that opens.
        let mut most = 0.0f32;
        let mut least = 1.0f32;
        for part in parts {
            let m = part.map(|q| {
                let m = lod.mesh.share(texel_pixels(q.texel, scale, ppm, q.dist));
                most = most.max(m);
                if q.meshes_here { m } else { 0.0 }
            });
            part_mesh.push(m.unwrap_or(-1.0));
        }
        let rest = if tree.meshes_here { most } else { 0.0 };
        for m in part_mesh.iter_mut() {
            if *m < 0.0 {
                *m = rest;
            }
            least = least.min(*m);
        }
        let opened = open.max(most);
        if least * opened >= 0.998 {
            whole = presence;
        } else {
            tree_bb = (1.0 - opened) * presence;
            below = opened * presence;
        }
    } else {
        let mesh = if tree.meshes && tree.meshes_here {
            lod.mesh
                .share(texel_pixels(lod.mesh_texel, scale, ppm, dist))
        } else {
            0.0
        };
        whole = mesh * presence;
        tree_bb = (1.0 - open) * (1.0 - mesh) * presence;
        below = open * (1.0 - mesh) * presence;
        part_mesh.resize(lod.placements, 0.0);
    }
    // Trees opened into BTFs only cast at the tree level.
    if tree.shadow && !part_mesh.iter().any(|&m| m > 0.0) {
        tree_bb += below;
        below = 0.0;
    }
    Shares {
        meshes: whole,
        tree: tree_bb,
        below,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tree-like plant: 10 m tall at 64-texel tiles, main branches an eighth of it.
    fn plant(p: &HbtDrawParams, placements: usize, per_branch: bool) -> PlantLod {
        let texel = 10.0 / 64.0;
        PlantLod {
            texel,
            mesh_texel: if placements > 0 { texel / 8.0 } else { texel },
            radius: 6.0,
            placements,
            per_branch,
            open: Switch::new(p.open_texel_pixels, p.band),
            mesh: Switch::new(mesh_pixels(p, placements > 0), p.band),
        }
    }

    fn at(dist: f32) -> TreeAt {
        TreeAt {
            presence: 1.0,
            scale: 1.0,
            dist,
            pixels_per_metre: 600.0,
            meshes: true,
            meshes_here: true,
            shadow: false,
        }
    }

    /// Distances from 1 m to ~3 km, nearest first.
    fn distances() -> impl Iterator<Item = f32> {
        (0..400).map(|i| 1.02f32.powi(i))
    }

    fn total(s: Shares) -> f32 {
        s.meshes + s.tree + s.below
    }

    #[test]
    fn shares_sum_to_the_presence() {
        let mut part_mesh = Vec::new();
        for band in [0.0, 0.3, 0.9] {
            let p = HbtDrawParams {
                band,
                ..Default::default()
            };
            for (placements, per_branch) in [(0, false), (12, false), (12, true)] {
                let lod = plant(&p, placements, per_branch);
                for dist in distances() {
                    for presence in [1.0, 0.4] {
                        let tree = TreeAt {
                            presence,
                            ..at(dist)
                        };
                        // Parts at staggered distances around the tree's.
                        let parts = (0..placements).map(|j| {
                            (j % 3 != 0).then_some(PartAt {
                                texel: lod.mesh_texel,
                                dist: dist * (0.8 + 0.04 * j as f32),
                                meshes_here: true,
                            })
                        });
                        let s = select(&lod, &tree, parts, &mut part_mesh);
                        assert!((total(s) - presence).abs() < 1e-5, "{s:?} at {dist} m");
                        assert!(s.meshes >= 0.0 && s.tree >= 0.0 && s.below >= 0.0, "{s:?}");
                        assert_eq!(part_mesh.len(), placements);
                        assert!(part_mesh.iter().all(|m| (0.0..=1.0).contains(m)));
                    }
                }
            }
        }
    }

    #[test]
    fn nearer_trees_open_further() {
        let p = HbtDrawParams::default();
        let lod = plant(&p, 12, false);
        let mut part_mesh = Vec::new();
        let mut last: Option<Shares> = None;
        let (mut saw_below, mut saw_meshes) = (false, false);
        for dist in distances() {
            let s = select(&lod, &at(dist), std::iter::empty(), &mut part_mesh);
            if let Some(l) = last {
                // Farther: no more meshes, no less tree billboard, no more opened below the
                // tree (the branches' share only ever goes to the tree or the meshes).
                assert!(s.meshes <= l.meshes + 1e-6, "{s:?} after {l:?} at {dist} m");
                assert!(s.tree + 1e-6 >= l.tree, "{s:?} after {l:?} at {dist} m");
                assert!(
                    s.meshes + s.below <= l.meshes + l.below + 1e-6,
                    "{s:?} at {dist} m"
                );
            }
            saw_below |= s.below > 0.5;
            saw_meshes |= s.meshes > 0.999;
            last = Some(s);
        }
        let far = last.unwrap();
        assert_eq!(far.tree, 1.0, "far trees are drawn as one billboard");
        assert!(
            saw_below && saw_meshes,
            "the branches and the meshes both open nearer"
        );
    }

    #[test]
    fn band_zero_is_a_hard_switch() {
        let p = HbtDrawParams {
            band: 0.0,
            ..Default::default()
        };
        let lod = plant(&p, 12, false);
        let mut part_mesh = Vec::new();
        // The tree opens where one texel covers `open_texel_pixels`.
        let opens_at = lod.texel * 600.0 / p.open_texel_pixels;
        let share =
            |d: f32, part_mesh: &mut Vec<f32>| select(&lod, &at(d), std::iter::empty(), part_mesh);
        let near = share(opens_at * 0.999, &mut part_mesh);
        let far = share(opens_at * 1.001, &mut part_mesh);
        assert_eq!((far.tree, far.below, far.meshes), (1.0, 0.0, 0.0));
        assert_eq!((near.tree, near.below, near.meshes), (0.0, 1.0, 0.0));
        for dist in distances() {
            let s = share(dist, &mut part_mesh);
            for x in [s.meshes, s.tree, s.below] {
                assert!(x == 0.0 || x == 1.0, "{s:?} at {dist} m");
            }
        }
    }

    #[test]
    fn a_plant_without_a_level_below_opens_straight_into_its_meshes() {
        let p = HbtDrawParams::default();
        let lod = plant(&p, 0, false);
        assert_eq!(
            lod.mesh, lod.open,
            "its meshes open where its tree level would"
        );
        let mut part_mesh = Vec::new();
        let mut saw_meshes = false;
        for dist in distances() {
            let s = select(&lod, &at(dist), std::iter::empty(), &mut part_mesh);
            assert_eq!(s.below, 0.0, "{s:?} at {dist} m");
            assert!((s.tree + s.meshes - 1.0).abs() < 1e-6);
            saw_meshes |= s.meshes == 1.0;
        }
        assert!(saw_meshes);
        // Without meshes it stays a tree billboard however near.
        let tree = TreeAt {
            meshes: false,
            ..at(1.0)
        };
        let s = select(&lod, &tree, std::iter::empty(), &mut part_mesh);
        assert_eq!(s.tree, 1.0);
    }

    #[test]
    fn branch_by_branch_opens_the_nearest_branches_first() {
        let p = HbtDrawParams {
            mesh_per_branch: true,
            ..Default::default()
        };
        let lod = plant(&p, 3, true);
        let mut part_mesh = Vec::new();
        // Where a branch's meshes open.
        let mid = lod.mesh_texel * 600.0 / p.mesh_texel_pixels;
        let parts = |near: f32| {
            [
                Some(PartAt {
                    texel: lod.mesh_texel,
                    dist: near,
                    meshes_here: true,
                }),
                Some(PartAt {
                    texel: lod.mesh_texel,
                    dist: 4.0 * mid,
                    meshes_here: true,
                }),
                // Opens with the first branch.
                None,
            ]
        };
        let s = select(&lod, &at(mid), parts(0.5 * mid).into_iter(), &mut part_mesh);
        assert_eq!(part_mesh, [1.0, 0.0, 1.0], "{s:?}");
        assert!(s.below > 0.999 && s.meshes == 0.0, "{s:?}");
        // Every part meshed: the tree as a whole.
        let all = [0.1, 0.2, 0.3].map(|k| {
            Some(PartAt {
                texel: lod.mesh_texel,
                dist: k * mid,
                meshes_here: true,
            })
        });
        let s = select(&lod, &at(mid), all.into_iter(), &mut part_mesh);
        assert_eq!((s.meshes, s.tree, s.below), (1.0, 0.0, 0.0));
        // A shadow pass casting no meshes casts at the tree level.
        let shadow = TreeAt {
            shadow: true,
            meshes_here: false,
            ..at(mid)
        };
        let off = parts(0.5 * mid).map(|q| {
            q.map(|q| PartAt {
                meshes_here: false,
                ..q
            })
        });
        let s = select(&lod, &shadow, off.into_iter(), &mut part_mesh);
        assert_eq!((s.tree, s.below), (1.0, 0.0), "{s:?}");
    }
}
