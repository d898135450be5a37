//! MNP01 §3.2/§7: the levels below the tree — which objects each is made of and where they are
//! placed. The main branches ([`branch_level`]: the root's branch instances as a few
//! representatives, plus the plant's rest) and the small branches of each main branch
//! ([`small_level`]), both cut from the plant's instancing hierarchy ([`split_object`]) and
//! grouped by [`representatives`].

use super::REST_OBJECT;
use glam::{Mat4, Vec3};
use sylvan_plant::{Instancing, Mesh, Plant};

/// The base objects one level below the plant (MNP01 §3.2, §7: the main branches): distinct
/// objects the root instances directly, leaves excluded, in order of first use, with how many
/// times the root places each.
pub fn main_branches(plant: &Plant) -> Vec<(u32, u32)> {
    let inst = &plant.instancing;
    let Some(root) = inst.objects.get(inst.root as usize) else {
        return Vec::new();
    };
    let mut out: Vec<(u32, u32)> = Vec::new();
    for i in &root.instances {
        let level = inst.objects.get(i.object as usize).map_or(0, |o| o.level);
        if level == 0 || i.object == inst.root {
            continue;
        }
        match out.iter_mut().find(|(o, _)| *o == i.object) {
            Some(e) => e.1 += 1,
            None => out.push((i.object, 1)),
        }
    }
    out
}

/// Base object `object` of `plant` expanded into a plant of its own (its frame, the plant's
/// leaf texture), ready for the baker.
pub fn object_plant(plant: &Plant, object: u32) -> Plant {
    split_object(plant, object, &|_| false, "").1
}

/// Expands base object `object` of `plant` into a plant of its own, except the non-leaf
/// instances `stop` selects (anywhere below it): those are returned as (object, transform into
/// `object`'s frame) and left out. `label` names the remainder (empty: `object N`).
fn split_object(
    plant: &Plant,
    object: u32,
    stop: &dyn Fn(u32) -> bool,
    label: &str,
) -> (Vec<(u32, Mat4)>, Plant) {
    struct Walk<'a> {
        inst: &'a Instancing,
        stop: &'a dyn Fn(u32) -> bool,
        wood: Mesh,
        leaves: Mesh,
        stopped: Vec<(u32, Mat4)>,
    }
    fn expand(w: &mut Walk<'_>, o: u32, m: &Mat4, depth: u32) {
        let Some(obj) = w.inst.objects.get(o as usize) else {
            return;
        };
        if depth > 256 {
            return;
        }
        w.wood.append_transformed(&obj.wood, m);
        w.leaves.append_transformed(&obj.leaves, m);
        for i in &obj.instances {
            let leaf = w
                .inst
                .objects
                .get(i.object as usize)
                .is_some_and(|c| c.level == 0);
            let t = *m * i.transform;
            if !leaf && (w.stop)(i.object) {
                w.stopped.push((i.object, t));
            } else {
                expand(w, i.object, &t, depth + 1);
            }
        }
    }
    let mut w = Walk {
        inst: &plant.instancing,
        stop,
        wood: Mesh::default(),
        leaves: Mesh::default(),
        stopped: Vec::new(),
    };
    expand(&mut w, object, &Mat4::IDENTITY, 0);
    let (mut min, mut max) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in w.wood.positions.iter().chain(&w.leaves.positions) {
        min = min.min(Vec3::from(*p));
        max = max.max(Vec3::from(*p));
    }
    if min.x > max.x {
        (min, max) = (Vec3::ZERO, Vec3::ZERO);
    }
    let what = if label.is_empty() {
        format!("object {object}")
    } else {
        label.to_string()
    };
    let out = Plant {
        name: format!("{} {what}", plant.name),
        leaf_count: w.leaves.indices.len() / indices_per_leaf(plant),
        wood: w.wood,
        leaves: w.leaves,
        leaf_texture: plant.leaf_texture.clone(),
        leaf_back: plant.leaf_back.clone(),
        leaf_normal: plant.leaf_normal.clone(),
        bbox_min: min.to_array(),
        bbox_max: max.to_array(),
        hierarchy: Default::default(),
        instancing: Default::default(),
        internodes: 0,
    };
    (w.stopped, out)
}

/// Indices of one leaf of `plant` (6 for a card, more for a single leaf's blade).
fn indices_per_leaf(plant: &Plant) -> usize {
    (plant.leaves.indices.len() / plant.leaf_count.max(1)).max(3)
}

/// Mean vertex position of a plant's wood and leaves (its frame's origin when empty).
fn centroid(p: &Plant) -> Vec3 {
    let all = p.wood.positions.iter().chain(&p.leaves.positions);
    let n = p.wood.positions.len() + p.leaves.positions.len();
    all.map(|&v| Vec3::from(v)).sum::<Vec3>() / n.max(1) as f32
}

/// Bounding-box diagonal of a plant (or expanded object).
fn diagonal(p: &Plant) -> f32 {
    (Vec3::from(p.bbox_max) - Vec3::from(p.bbox_min)).length()
}

/// How one object is drawn by its representative: (object, representative index, map from the
/// representative's frame to the object's).
type Fit = (u32, usize, Mat4);

/// What an object of the level above is split into: the objects cut off below it (with
/// transforms into its frame), its rest, and how many times it is placed.
struct Parent {
    children: Vec<(u32, Mat4)>,
    rest: Plant,
    uses: u32,
}

/// Representatives of many distinct objects (MNP01 builds each level from a few instanced
/// base objects; an L-system tree has as many distinct ones as its parameters vary): the
/// `distinct` (object, placements, object as a plant) are sorted by size and cut into at most
/// `max_objects` groups of equal placement count; each group is drawn with its most used
/// member (largest on ties), scaled by the ratio of bounding-box diagonals about the object's
/// base and turned about it so that its centroid points where the member's does (objects of one
/// group often differ only by the turn at their bracket: a bough left or right of its branch, a
/// main branch pitched more or less). Returns the representatives (object, plant) and, per
/// object id of `distinct`, its representative's index and the map from the representative's
/// frame to the member's.
fn representatives(
    mut distinct: Vec<(u32, u32, Plant)>,
    max_objects: usize,
) -> (Vec<(u32, Plant)>, Vec<Fit>) {
    distinct.sort_by(|a, b| diagonal(&a.2).total_cmp(&diagonal(&b.2)));
    let total: u32 = distinct.iter().map(|d| d.1).sum();
    let groups = max_objects.max(1).min(distinct.len().max(1));
    // group[i]: the group of distinct[i] (equal shares of the placements, in size order).
    let mut group = Vec::with_capacity(distinct.len());
    let mut seen = 0u32;
    for d in &distinct {
        let g = ((seen as u64 * groups as u64) / total.max(1) as u64) as usize;
        group.push(g.min(groups - 1));
        seen += d.1;
    }
    let mut reps: Vec<(u32, Plant)> = Vec::new();
    let mut rep_of_group = vec![usize::MAX; groups];
    for (g, rep) in rep_of_group.iter_mut().enumerate() {
        let best = (0..distinct.len())
            .filter(|&i| group[i] == g)
            .max_by_key(|&i| (distinct[i].1, i));
        if let Some(i) = best {
            *rep = reps.len();
            reps.push((distinct[i].0, distinct[i].2.clone()));
        }
    }
    let centroids: Vec<Vec3> = reps.iter().map(|r| centroid(&r.1)).collect();
    let of = distinct
        .iter()
        .zip(&group)
        .filter_map(|(d, &g)| {
            let r = rep_of_group[g];
            (r != usize::MAX).then(|| {
                let scale = diagonal(&d.2) / diagonal(&reps[r].1).max(1e-6);
                let (from, to) = (centroids[r], centroid(&d.2));
                let turn = if from.length() > 1e-4 && to.length() > 1e-4 {
                    glam::Quat::from_rotation_arc(from.normalize(), to.normalize())
                } else {
                    glam::Quat::IDENTITY
                };
                (
                    d.0,
                    r,
                    Mat4::from_scale_rotation_translation(Vec3::splat(scale), turn, Vec3::ZERO),
                )
            })
        })
        .collect();
    (reps, of)
}

/// The level below the tree as drawn: at most `max_objects` representative main branches plus
/// the plant's rest, and where each is placed.
pub struct BranchLevel {
    /// (instancing object or [`REST_OBJECT`], the object as a plant, placements using it).
    pub objects: Vec<(u32, Plant, u32)>,
    /// (index into `objects`, object frame → parent frame).
    pub placements: Vec<(u32, Mat4)>,
    /// Per object of the level above (the small-branch level only; empty for the main
    /// branches): the range of `placements` it opens into (empty when it does not open).
    pub ranges: Vec<[u32; 2]>,
}

/// Chooses the level below the tree (MNP01 §3.2, §7): the distinct objects the root instances
/// directly (leaves excluded) — the main branches — as at most `max_objects` representatives
/// (`representatives`), and the root's own wood with the leaves it places directly, one
/// more object, the *rest*, placed at the identity.
pub fn branch_level(plant: &Plant, max_objects: usize) -> BranchLevel {
    // Every branch instance of the root is cut off (deeper ones belong to them); the rest is
    // kept even alone (an imported mesh has nothing else).
    let (children, rest) = split_root(plant);
    let mut level = from_children(
        plant,
        &[Parent {
            children,
            rest,
            uses: 1,
        }],
        max_objects,
        true,
    );
    level.ranges.clear();
    level
}

/// The plant's root split as [`branch_level`] splits it: every branch instance of the root
/// (deeper ones belong to them) with its transform, and the rest.
pub(in crate::technique::hbt) fn split_root(plant: &Plant) -> (Vec<(u32, Mat4)>, Plant) {
    split_object(plant, plant.instancing.root, &|_| true, "rest")
}

/// The common end of both levels: `parents` are, per object of the level above, the objects
/// it places (with transforms), its rest and how many times it is placed; the children are
/// grouped into representatives and each parent's placements follow, then its rest (only when
/// it has children, unless `lonely_rest`).
fn from_children(
    plant: &Plant,
    parents: &[Parent],
    max_objects: usize,
    lonely_rest: bool,
) -> BranchLevel {
    let mut distinct: Vec<(u32, u32, Plant)> = Vec::new();
    for Parent { children, uses, .. } in parents {
        for &(o, _) in children {
            match distinct.iter_mut().find(|d| d.0 == o) {
                Some(d) => d.1 += uses,
                None => distinct.push((o, *uses, object_plant(plant, o))),
            }
        }
    }
    let (reps, of) = representatives(distinct, max_objects);
    let mut objects: Vec<(u32, Plant, u32)> = reps.into_iter().map(|(o, p)| (o, p, 0)).collect();
    let mut placements = Vec::new();
    let mut ranges = Vec::with_capacity(parents.len());
    for Parent {
        children,
        rest,
        uses,
    } in parents
    {
        let start = placements.len() as u32;
        if lonely_rest || !children.is_empty() {
            for (o, t) in children {
                let Some(&(_, r, fit)) = of.iter().find(|x| x.0 == *o) else {
                    continue;
                };
                objects[r].2 += uses;
                placements.push((r as u32, *t * fit));
            }
            if !rest.wood.indices.is_empty() || !rest.leaves.indices.is_empty() {
                placements.push((objects.len() as u32, Mat4::IDENTITY));
                objects.push((REST_OBJECT, rest.clone(), *uses));
            }
        }
        ranges.push([start, placements.len() as u32]);
    }
    BranchLevel {
        objects,
        placements,
        ranges,
    }
}

/// How much smaller than its main branch a small branch is: the small branches of a main
/// branch are the largest branch objects below it whose bounding-box diagonal is at most this
/// fraction of the main branch's (MNP01 §7: small branches grouped into main branches).
pub const SMALL_BRANCH_RATIO: f32 = 0.5;

/// MNP01 §7's third level: the small branches of each main-branch object of `main` (at most
/// `max_objects` representatives over the whole plant, `representatives`) placed in its
/// frame, then its rest (its own wood and the leaves and branch parts above the cut). A main
/// branch without small branches does not open (an empty range); nor does the plant's rest.
pub fn small_level(plant: &Plant, main: &BranchLevel, max_objects: usize) -> BranchLevel {
    let inst = &plant.instancing;
    let parents: Vec<Parent> = main
        .objects
        .iter()
        .map(|(o, p, uses)| {
            if *o == REST_OBJECT {
                return Parent {
                    children: Vec::new(),
                    rest: Plant::default(),
                    uses: 0,
                };
            }
            let cut = SMALL_BRANCH_RATIO * diagonal(p);
            // The size of every branch object below it, once.
            let mut sizes: Vec<(u32, f32)> = Vec::new();
            let mut stack = vec![*o];
            while let Some(x) = stack.pop() {
                for i in inst
                    .objects
                    .get(x as usize)
                    .map_or(&[][..], |b| &b.instances)
                {
                    let leaf = inst
                        .objects
                        .get(i.object as usize)
                        .is_none_or(|c| c.level == 0);
                    if !leaf && i.object != *o && !sizes.iter().any(|s| s.0 == i.object) {
                        sizes.push((i.object, diagonal(&object_plant(plant, i.object))));
                        stack.push(i.object);
                    }
                    if sizes.len() > 4096 {
                        break;
                    }
                }
            }
            let stop = |c: u32| sizes.iter().any(|s| s.0 == c && s.1 <= cut);
            let (children, rest) = split_object(plant, *o, &stop, &format!("object {o} rest"));
            Parent {
                children,
                rest,
                uses: *uses,
            }
        })
        .collect();
    from_children(plant, &parents, max_objects, false)
}
