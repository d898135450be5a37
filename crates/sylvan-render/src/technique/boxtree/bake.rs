//! LCV04 §3.2: choosing the boxes that get images (§3.2.4), baking six images per box (§3.2.2,
//! §3.2.3), and laying the plant's triangles out so that what a box leaves as geometry when
//! it is opened is one contiguous index range.

use super::BoxTreeBakeParams;
use crate::RenderError;
use crate::bake::codec::{DecodeError, Decoder, Encoder};
use crate::bake::image::TileLevel;
use crate::bake::views::PlaneLayout;
use crate::bake::{BakeRequest, PlantBaker};
use glam::Vec3;
use std::ops::Range;
use sylvan_gpu::Gpu;
use sylvan_plant::Plant;

/// Bumped whenever the payload below, the baker's output, or the selection changes.
pub const FORMAT_VERSION: u32 = 1;

/// One textured box of the box tree.
#[derive(Debug, Clone, PartialEq)]
pub struct BakedBox {
    /// The plant hierarchy node whose subtree the box bounds.
    pub node: u32,
    /// Parent box (`u32::MAX` for the root box).
    pub parent: u32,
    /// Textured boxes directly below this one.
    pub children: Vec<u32>,
    /// Model-space box minimum (metres).
    pub min: [f32; 3],
    /// Model-space box maximum.
    pub max: [f32; 3],
    /// What this box leaves as real geometry when opened: a range of the re-ordered leaf
    /// indices (leaves in no textured child box).
    pub residual_leaves: Range<u32>,
    /// Same for wood (with `bake_wood`; without, all wood is always geometry).
    pub residual_wood: Range<u32>,
    /// Metres per texel of this box's images (largest plane extent / tile size): with the
    /// view's pixels-per-metre it gives the LOD distance (LCV04 §4.1).
    pub metres_per_texel: f32,
    /// Leaves inside the box.
    pub leaves: u32,
}

/// The baked asset of one plant: the box tree, the re-ordered indices and the images.
#[derive(Debug, Clone, PartialEq)]
pub struct BoxTreeBaked {
    /// Tile size in texels.
    pub tile: u32,
    /// The plane arrangement the images were baked for.
    pub layout: PlaneLayout,
    /// Whether box images include the wood inside the box.
    pub bake_wood: bool,
    /// Textured boxes, root first, parents before children.
    pub boxes: Vec<BakedBox>,
    /// `plant.leaves.indices` re-ordered so each box's residual leaves are contiguous.
    pub leaf_indices: Vec<u32>,
    /// `plant.wood.indices` re-ordered likewise.
    pub wood_indices: Vec<u32>,
    /// `tiles[box * images_per_box + image]`: the mip chain of each image.
    pub tiles: Vec<Vec<TileLevel>>,
}

impl BoxTreeBaked {
    /// Images per box.
    pub fn images_per_box(&self) -> u32 {
        self.layout.images()
    }

    /// Bytes of image data (all mips, colour and normal).
    pub fn image_bytes(&self) -> u64 {
        self.tiles
            .iter()
            .flatten()
            .map(|l| (l.color.len() + l.normal.len()) as u64)
            .sum()
    }

    /// Structural checks: parents before children, ranges inside the index arrays.
    fn validate(&self) -> Result<(), String> {
        let n = self.boxes.len() as u32;
        for (i, b) in self.boxes.iter().enumerate() {
            if (i == 0) != (b.parent == u32::MAX) || (i > 0 && b.parent >= i as u32) {
                return Err(format!("box {i} has parent {}", b.parent));
            }
            if b.children.iter().any(|&c| c <= i as u32 || c >= n) {
                return Err(format!("box {i} has a child out of order"));
            }
            if b.residual_leaves.end > self.leaf_indices.len() as u32
                || b.residual_wood.end > self.wood_indices.len() as u32
                || b.residual_leaves.start > b.residual_leaves.end
                || b.residual_wood.start > b.residual_wood.end
            {
                return Err(format!("box {i} has a residual range outside the indices"));
            }
            if !(b.metres_per_texel.is_finite() && b.metres_per_texel > 0.0) {
                return Err(format!("box {i} has no valid texel size"));
            }
        }
        Ok(())
    }
}

/// A box chosen for images, before baking.
#[derive(Debug, Clone, PartialEq)]
pub struct Selected {
    /// Hierarchy node.
    pub node: u32,
    /// Parent selected box (`u32::MAX` for the root).
    pub parent: u32,
}

fn volume(min: [f32; 3], max: [f32; 3], floor: f32) -> f32 {
    (0..3).map(|i| (max[i] - min[i]).max(floor)).product()
}

/// Boxes whose volume is more than this fraction of the nearest textured box above them are
/// near-duplicates (they would open at almost the same distance) and get no images.
pub const MAX_VOLUME_RATIO: f32 = 0.5;

/// LCV04 §3.2.4: the root box always gets images; another node's box gets images when its
/// volume is at least `threshold` × the volume of the nearest box above it that has images,
/// and it holds at least `min_leaves` leaves. Nodes are considered largest box first, so when
/// `max_boxes` cuts the list it keeps the boxes that matter most (a box is never smaller than
/// a box inside it, so parents are still decided before their children). The result is in
/// hierarchy order, parents before children.
///
/// Deviations: the paper compares with the node's *parent* box; comparing with the nearest
/// *textured* ancestor stops chains of small nested twigs from each getting images. Boxes above
/// [`MAX_VOLUME_RATIO`] of that ancestor are skipped as near-duplicates (a monopodial branch's
/// nested continuations are each ~0.9 of the one before). Box extents are floored at 5% of the
/// plant's largest extent so flat boxes are not volume-less.
pub fn select_boxes(
    plant: &Plant,
    threshold: f32,
    min_leaves: u32,
    max_boxes: u32,
) -> Vec<Selected> {
    let nodes = &plant.hierarchy.nodes;
    if nodes.is_empty() {
        return vec![Selected {
            node: u32::MAX,
            parent: u32::MAX,
        }];
    }
    let ext = (0..3)
        .map(|i| plant.bbox_max[i] - plant.bbox_min[i])
        .fold(0.0f32, f32::max);
    let floor = (ext * 0.05).max(1e-3);
    let vol: Vec<f32> = nodes
        .iter()
        .map(|n| volume(n.bbox_min, n.bbox_max, floor))
        .collect();
    let mut order: Vec<usize> = (1..nodes.len()).collect();
    // Largest first; ties in hierarchy order (parents first).
    order.sort_by(|&a, &b| vol[b].total_cmp(&vol[a]).then(a.cmp(&b)));
    let mut textured = vec![false; nodes.len()];
    textured[0] = true;
    let mut count = 1;
    for i in order {
        if count >= max_boxes as usize {
            break;
        }
        let n = &nodes[i];
        let mut a = n.parent;
        let anc = loop {
            match a {
                Some(p) if textured[p as usize] => break p as usize,
                Some(p) => a = nodes[p as usize].parent,
                None => break 0,
            }
        };
        let ratio = vol[i] / vol[anc];
        if (threshold..=MAX_VOLUME_RATIO).contains(&ratio) && n.leaves.len() as u32 >= min_leaves {
            textured[i] = true;
            count += 1;
        }
    }
    // Hierarchy order, each with its nearest textured ancestor as parent box.
    let mut index = vec![u32::MAX; nodes.len()];
    let mut out = Vec::with_capacity(count);
    for (i, n) in nodes.iter().enumerate().filter(|(i, _)| textured[*i]) {
        let mut a = n.parent;
        let parent = loop {
            match a {
                Some(p) if textured[p as usize] => break index[p as usize],
                Some(p) => a = nodes[p as usize].parent,
                None => break u32::MAX,
            }
        };
        index[i] = out.len() as u32;
        out.push(Selected {
            node: i as u32,
            parent,
        });
    }
    out
}

/// Index ranges of `whole` not covered by any of `holes` (sorted, disjoint, inside `whole`).
fn gaps(whole: Range<u32>, mut holes: Vec<Range<u32>>) -> Vec<Range<u32>> {
    holes.sort_by_key(|r| r.start);
    let mut out = Vec::new();
    let mut at = whole.start;
    for h in holes {
        if h.start > at {
            out.push(at..h.start);
        }
        at = at.max(h.end);
    }
    if at < whole.end {
        out.push(at..whole.end);
    }
    out
}

/// The box tree without images: boxes, residual ranges, re-ordered indices, and the bake
/// requests (box-major, image-minor). GPU-free.
pub struct Layout {
    /// Boxes (images not yet baked).
    pub boxes: Vec<BakedBox>,
    /// Re-ordered leaf indices.
    pub leaf_indices: Vec<u32>,
    /// Re-ordered wood indices.
    pub wood_indices: Vec<u32>,
    /// One request per image.
    pub requests: Vec<BakeRequest>,
}

/// Lays out the box tree of `plant` for `p`.
pub fn layout(plant: &Plant, p: &BoxTreeBakeParams) -> Layout {
    let selected = select_boxes(plant, p.volume_threshold, p.min_leaves, p.max_boxes);
    let nodes = &plant.hierarchy.nodes;
    let whole_leaves = 0..plant.leaves.indices.len() as u32;
    let whole_wood = 0..plant.wood.indices.len() as u32;
    // Subtree ranges per selected box; a plant without hierarchy is one box.
    let ranges = |s: &Selected| -> (Range<u32>, Range<u32>, [f32; 3], [f32; 3], u32) {
        match nodes.get(s.node as usize) {
            Some(n) => (
                n.leaf_indices.clone(),
                n.wood_indices.clone(),
                n.bbox_min,
                n.bbox_max,
                n.leaves.len() as u32,
            ),
            None => (
                whole_leaves.clone(),
                whole_wood.clone(),
                plant.bbox_min,
                plant.bbox_max,
                plant.leaf_count as u32,
            ),
        }
    };
    let mut boxes: Vec<BakedBox> = selected
        .iter()
        .map(|s| {
            let (_, _, min, max, leaves) = ranges(s);
            BakedBox {
                node: s.node,
                parent: s.parent,
                children: Vec::new(),
                min,
                max,
                residual_leaves: 0..0,
                residual_wood: 0..0,
                metres_per_texel: 0.0,
                leaves,
            }
        })
        .collect();
    for i in 1..boxes.len() {
        let parent = boxes[i].parent as usize;
        boxes[parent].children.push(i as u32);
    }
    // The root box covers the whole plant (wood and leaves), whatever node 0 says.
    boxes[0].min = plant.bbox_min;
    boxes[0].max = plant.bbox_max;
    // Depth-first: a box's residual triangles, then its children's subtrees.
    let mut leaf_indices = Vec::with_capacity(plant.leaves.indices.len());
    let mut wood_indices = Vec::with_capacity(plant.wood.indices.len());
    let mut stack = vec![0usize];
    while let Some(b) = stack.pop() {
        let (leaves, wood, ..) = if b == 0 {
            (
                whole_leaves.clone(),
                whole_wood.clone(),
                [0.0; 3],
                [0.0; 3],
                0,
            )
        } else {
            ranges(&selected[b])
        };
        let kids: Vec<&Selected> = boxes[b]
            .children
            .iter()
            .map(|&c| &selected[c as usize])
            .collect();
        let start = leaf_indices.len() as u32;
        for g in gaps(leaves, kids.iter().map(|k| ranges(k).0).collect()) {
            leaf_indices.extend_from_slice(&plant.leaves.indices[g.start as usize..g.end as usize]);
        }
        boxes[b].residual_leaves = start..leaf_indices.len() as u32;
        let start = wood_indices.len() as u32;
        for g in gaps(wood, kids.iter().map(|k| ranges(k).1).collect()) {
            wood_indices.extend_from_slice(&plant.wood.indices[g.start as usize..g.end as usize]);
        }
        boxes[b].residual_wood = start..wood_indices.len() as u32;
        stack.extend(boxes[b].children.iter().rev().map(|&c| c as usize));
    }
    let mut requests = Vec::new();
    for (b, s) in boxes.iter_mut().zip(&selected) {
        let (min, max) = (Vec3::from(b.min), Vec3::from(b.max));
        let (leaves, wood) = if s.node == 0 || s.node == u32::MAX {
            (whole_leaves.clone(), whole_wood.clone())
        } else {
            let (l, w, ..) = ranges(s);
            (l, w)
        };
        let mut largest = 0.0f32;
        for frame in p.layout.frames(min, max) {
            largest = largest.max(frame.half.x.max(frame.half.y) * 2.0);
            for side in [1.0, -1.0].into_iter().take(p.layout.sides() as usize) {
                requests.push(BakeRequest {
                    frame,
                    side,
                    leaves: vec![leaves.clone()],
                    wood: if p.bake_wood {
                        vec![wood.clone()]
                    } else {
                        vec![]
                    },
                });
            }
        }
        b.metres_per_texel = (largest / p.tile as f32).max(1e-6);
    }
    Layout {
        boxes,
        leaf_indices,
        wood_indices,
        requests,
    }
}

/// `boxtree`'s offline half (LCV04 §3.2): the box images of one plant.
pub struct BoxTreeBake;

impl crate::bake::Bake for BoxTreeBake {
    const NAME: &'static str = "boxtree";
    const FORMAT_VERSION: u32 = FORMAT_VERSION;
    type Params = BoxTreeBakeParams;
    type Asset = BoxTreeBaked;

    fn check(b: &BoxTreeBaked, plant: &Plant) -> Result<(), String> {
        for (what, indices, mesh) in [
            ("leaf", &b.leaf_indices, &plant.leaves),
            ("wood", &b.wood_indices, &plant.wood),
        ] {
            if indices.len() % 3 != 0 || indices.len() != mesh.indices.len() {
                return Err(format!(
                    "{} {what} indices for the plant's {}",
                    indices.len(),
                    mesh.indices.len()
                ));
            }
            if let Some(i) = indices
                .iter()
                .find(|&&i| i as usize >= mesh.positions.len())
            {
                return Err(format!(
                    "{what} index {i} out of range of {} vertices",
                    mesh.positions.len()
                ));
            }
        }
        for (k, bx) in b.boxes.iter().enumerate() {
            // `u32::MAX`: the whole plant of a plant without a branch hierarchy.
            if bx.node != u32::MAX && bx.node as usize >= plant.hierarchy.nodes.len() {
                return Err(format!(
                    "box {k}: node {} of {}",
                    bx.node,
                    plant.hierarchy.nodes.len()
                ));
            }
            let finite = bx.min.iter().chain(&bx.max).all(|c| c.is_finite());
            if !finite || (0..3).any(|a| bx.min[a] > bx.max[a]) {
                return Err(format!("box {k}: bounds {:?}–{:?}", bx.min, bx.max));
            }
        }
        Ok(())
    }

    fn describe(b: &BoxTreeBaked) -> crate::bake::AssetSummary {
        let mut fields = serde_json::Map::new();
        fields.insert("boxes".into(), b.boxes.len().into());
        fields.insert("planes".into(), b.layout.name().into());
        crate::bake::AssetSummary {
            line: format!(
                "{} boxes, {} images of {}² ({} planes)",
                b.boxes.len(),
                b.tiles.len(),
                b.tile,
                b.layout.name()
            ),
            image_bytes: b.image_bytes(),
            images: b.tiles.len(),
            tile: b.tile,
            fields,
        }
    }

    /// Bakes `plant`: layout, then every image on the GPU. `progress(done, total)` is called as
    /// images complete.
    fn bake(
        gpu: &Gpu,
        plant: &Plant,
        p: &BoxTreeBakeParams,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<BoxTreeBaked, RenderError> {
        let l = layout(plant, p);
        let baker = PlantBaker::new(gpu, plant, p.tile, p.supersample)?;
        let total = l.requests.len();
        let images = baker.bake(gpu, &l.requests, |done| progress(done, total))?;
        Ok(BoxTreeBaked {
            tile: p.tile,
            layout: p.layout,
            bake_wood: p.bake_wood,
            boxes: l.boxes,
            leaf_indices: l.leaf_indices,
            wood_indices: l.wood_indices,
            tiles: images.iter().map(|t| t.levels()).collect(),
        })
    }
}

impl crate::bake::codec::Codec for BoxTreeBaked {
    /// The payload written to the cache.
    fn encode(&self) -> Vec<u8> {
        let mut e = Encoder::default();
        e.u32(self.tile);
        e.str(self.layout.name());
        e.u32(self.bake_wood as u32);
        e.u64(self.boxes.len() as u64);
        for b in &self.boxes {
            e.u32(b.node);
            e.u32(b.parent);
            e.u32s(&b.children);
            e.f32s(&b.min);
            e.f32s(&b.max);
            e.u32s(&[
                b.residual_leaves.start,
                b.residual_leaves.end,
                b.residual_wood.start,
                b.residual_wood.end,
                b.leaves,
            ]);
            e.f32(b.metres_per_texel);
        }
        e.u32s(&self.leaf_indices);
        e.u32s(&self.wood_indices);
        e.u64(self.tiles.len() as u64);
        for levels in &self.tiles {
            TileLevel::encode_chain(&mut e, levels);
        }
        e.buf
    }

    /// Reads a payload back, checking every count and range against the rest.
    fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        let bad = |m: String| DecodeError(m);
        let mut d = Decoder::new(bytes);
        let tile = d.u32()?;
        let layout_name = d.str()?;
        let layout = PlaneLayout::parse(&layout_name)
            .ok_or_else(|| bad(format!("unknown plane layout '{layout_name}'")))?;
        let bake_wood = d.u32()? != 0;
        let nboxes = d.u64()?;
        if nboxes == 0 || nboxes > super::MAX_BOXES as u64 {
            return Err(bad(format!(
                "{nboxes} boxes (1–{} allowed)",
                super::MAX_BOXES
            )));
        }
        let mut boxes = Vec::with_capacity(nboxes as usize);
        for _ in 0..nboxes {
            let node = d.u32()?;
            let parent = d.u32()?;
            let children = d.u32s()?;
            let arr3 = |v: Vec<f32>| -> Result<[f32; 3], DecodeError> {
                v.try_into()
                    .map_err(|_| DecodeError("box corner is not 3 floats".into()))
            };
            let min = arr3(d.f32s()?)?;
            let max = arr3(d.f32s()?)?;
            let r = d.u32s()?;
            if r.len() != 5 {
                return Err(bad("box ranges are not 5 integers".into()));
            }
            let metres_per_texel = d.f32()?;
            boxes.push(BakedBox {
                node,
                parent,
                children,
                min,
                max,
                residual_leaves: r[0]..r[1],
                residual_wood: r[2]..r[3],
                leaves: r[4],
                metres_per_texel,
            });
        }
        let leaf_indices = d.u32s()?;
        let wood_indices = d.u32s()?;
        let ntiles = d.u64()?;
        if ntiles != nboxes * layout.images() as u64 {
            return Err(bad(format!(
                "{ntiles} images for {nboxes} boxes × {}",
                layout.images()
            )));
        }
        let mut tiles = Vec::with_capacity(ntiles as usize);
        for _ in 0..ntiles {
            let levels = TileLevel::decode_chain(&mut d, tile)?;
            tiles.push(levels);
        }
        d.finish()?;
        let baked = Self {
            tile,
            layout,
            bake_wood,
            boxes,
            leaf_indices,
            wood_indices,
            tiles,
        };
        baked.validate().map_err(DecodeError)?;
        Ok(baked)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_between_holes() {
        assert_eq!(gaps(0..10, vec![6..8, 2..4]), vec![0..2, 4..6, 8..10]);
        let whole: Vec<Range<u32>> = std::iter::once(0..4).collect();
        assert_eq!(gaps(0..4, whole), Vec::<Range<u32>>::new());
        assert_eq!(gaps(3..9, vec![]), vec![3..9]);
    }

    #[test]
    fn layout_partitions_the_plant() {
        let plant = sylvan_plant::preset("pine").unwrap();
        let p = BoxTreeBakeParams::default();
        let l = layout(&plant, &p);
        assert!(l.boxes.len() > 1, "pine should get more than the root box");
        // Re-ordering is a permutation of triangles.
        let sorted = |v: &[u32]| {
            let mut t: Vec<[u32; 3]> = v.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
            t.sort();
            t
        };
        assert_eq!(sorted(&l.leaf_indices), sorted(&plant.leaves.indices));
        assert_eq!(sorted(&l.wood_indices), sorted(&plant.wood.indices));
        // Each box's subtree (its residual plus its descendants' residuals) is all its leaves.
        fn subtree(l: &Layout, b: usize) -> u32 {
            l.boxes[b].residual_leaves.len() as u32
                + l.boxes[b]
                    .children
                    .iter()
                    .map(|&c| subtree(l, c as usize))
                    .sum::<u32>()
        }
        for (i, b) in l.boxes.iter().enumerate() {
            assert_eq!(subtree(&l, i), b.leaves * 6, "box {i}");
            assert!(b.residual_leaves.start % 3 == 0 && b.residual_leaves.end % 3 == 0);
        }
        assert_eq!(l.requests.len(), l.boxes.len() * p.layout.images() as usize);
        // Higher thresholds give fewer boxes (LCV04 §3.2.4's storage/realism trade-off).
        let few = select_boxes(&plant, 0.4, p.min_leaves, p.max_boxes).len();
        let many = select_boxes(&plant, 0.001, p.min_leaves, p.max_boxes).len();
        assert!(
            few <= l.boxes.len() && l.boxes.len() <= many,
            "{few} {} {many}",
            l.boxes.len()
        );
    }
}
