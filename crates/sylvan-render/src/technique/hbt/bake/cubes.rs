//! MNP01 §3.3 at the branch level: the visibility cube-maps of each placement of a level below
//! the tree, from the other placements' baked coverage.

use super::{Mips, ObjectBtf, Placement, view_frame};
use crate::directions::DirectionLut;
use crate::technique::hbt::visibility;
use glam::Vec3;

/// The coverage of an object's BTF for the visibility cube-maps: the alpha of its sky-facing
/// ambient images, one per view sample.
pub fn coverage<'a>(
    lut: &'a DirectionLut,
    ambient: &'a [Mips],
    min: Vec3,
    max: Vec3,
    tile: u32,
) -> visibility::Coverage<'a> {
    let views = lut.set().len();
    visibility::Coverage {
        lut,
        frames: lut
            .set()
            .directions()
            .iter()
            .map(|&d| view_frame(d, min, max, tile))
            .collect(),
        images: ambient[..views].iter().map(|m| m.as_slice()).collect(),
        tile,
        min,
        max,
    }
}

/// MNP01 §3.3 at the branch level: for each placement, the cube-maps at its box's 8 corners
/// of the rest of the tree (the other placements).
pub(super) fn branch_cubes(
    objects: &[ObjectBtf],
    placements: &[Placement],
    lut: &DirectionLut,
    tile: u32,
    res: usize,
) -> Vec<u8> {
    let covers: Vec<visibility::Coverage> = objects
        .iter()
        .map(|o| {
            coverage(
                lut,
                &o.ambient,
                Vec3::from(o.bbox_min),
                Vec3::from(o.bbox_max),
                tile,
            )
        })
        .collect();
    let occluders: Vec<visibility::Occluder> = placements
        .iter()
        .map(|p| visibility::Occluder::new(&covers[p.object as usize], p.affine()))
        .collect();
    let layout = visibility::CubeLayout::new(res);
    let per = layout.dirs.len();
    let mut out = vec![0u8; placements.len() * visibility::CORNERS * per];
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = (placements.len().div_ceil(threads)).max(1) * visibility::CORNERS * per;
    std::thread::scope(|scope| {
        for (c, part) in out.chunks_mut(chunk).enumerate() {
            let (occluders, layout, covers) = (&occluders, &layout, &covers);
            scope.spawn(move || {
                let mut open = Vec::new();
                let first = c * chunk / (visibility::CORNERS * per);
                for (k, map) in part.chunks_mut(per).enumerate() {
                    let (p, corner) = (first + k / visibility::CORNERS, k % visibility::CORNERS);
                    let cov = &covers[placements[p].object as usize];
                    let at = occluders[p]
                        .to_frame
                        .transform_point3(visibility::corner(cov.min, cov.max, corner));
                    let others: Vec<&visibility::Occluder> = occluders
                        .iter()
                        .enumerate()
                        .filter(|&(q, _)| q != p)
                        .map(|(_, o)| o)
                        .collect();
                    visibility::render(at, &others, None, layout, &mut open, map);
                }
            });
        }
    });
    out
}
