//! The turtle (ABOP §1.5, table of symbols p. 209): interprets a derived [`Word`] into a
//! [`Skeleton`] (chains of internodes and leaves), the LCV04 §3.2.1 box hierarchy and the
//! MNP01 instancing view, in one pass over the string.
//!
//! Frame: heading H starts +Y (up), left L = −X, up U = +Z (H × L = U). `+`/`-` turn about U:
//! `+` turns counter-clockwise seen from a viewer on the +Z side. `&`/`^` pitch down/up about
//! L, `\`/`/` roll left/right about H, `|` turns 180°, `$` rolls L horizontal.
//! `F(l)` draws an internode (default `step:`), `f(l)` moves, `!(w)` sets the diameter (`!`
//! alone multiplies it by `taper:`), `'(i)` sets the colour index (`'` alone increments it),
//! `~(s)` places a leaf of length `s` (default `leaf:`), `%` cuts the rest of the branch,
//! `[`/`]` push/pop. An `F` thinner than `twig:` moves without drawing. Other letters and digits draw nothing. With `tropism:` each `F` bends H
//! towards T by e·|H × T| (ABOP §2.3).

use crate::PlantError;
use crate::hierarchy::RawNode;
use crate::instancing::Instance;
use crate::lsystem::{LSystem, Word};
use crate::skeleton::{ChainPoint, LeafFrame, Skeleton};
use glam::{DVec3, Mat4, Vec3};
use std::collections::HashMap;

/// Most internodes (`F`) one plant may draw; checked before interpreting.
pub const MAX_INTERNODES: usize = 2_000_000;
/// Most leaves (`~`) one plant may carry; checked before interpreting.
pub const MAX_LEAVES: usize = 2_000_000;

/// A base object while it is recorded.
#[derive(Debug, Clone, Default)]
pub struct ObjectRecord {
    /// Own chains and leaves in the object's frame (leaves are also instances of object 0).
    pub skeleton: Skeleton,
    /// Sub-objects (leaves included, as object 0 scaled to their size).
    pub instances: Vec<Instance>,
    /// Level: 0 leaf, else 1 + highest instanced level.
    pub level: u32,
    /// Occurrences in the plant.
    pub uses: u32,
}

/// Everything the turtle produces.
#[derive(Debug, Clone, Default)]
pub struct Interpretation {
    /// The whole plant, world frame, string order.
    pub skeleton: Skeleton,
    /// Branch boxes (LCV04), before leaf-only brackets are merged.
    pub(crate) nodes: Vec<RawNode>,
    /// Instancing: object 0 is the unit leaf, object 1 the plant.
    pub objects: Vec<ObjectRecord>,
    /// Drawn internodes.
    pub internodes: usize,
}

#[derive(Clone, Copy)]
struct State {
    pos: DVec3,
    h: DVec3,
    l: DVec3,
    u: DVec3,
    width: f64,
    color: u8,
    chain: u32,
    lchain: u32,
    node: u32,
}

struct Rec {
    obj: Option<u32>,
    inv: Mat4,
}

fn frame(s: &State) -> Mat4 {
    let f = |v: DVec3| v.as_vec3();
    Mat4::from_cols(
        (-f(s.l)).extend(0.0),
        f(s.h).extend(0.0),
        f(s.u).extend(0.0),
        f(s.pos).extend(1.0),
    )
}

fn rotate(a: DVec3, b: DVec3, angle_deg: f64) -> (DVec3, DVec3) {
    let (s, c) = angle_deg.to_radians().sin_cos();
    (a * c + b * s, b * c - a * s)
}

/// Content hashes of every bracketed branch (indexed by the `[`), and how often each occurs.
fn content_keys(w: &Word, share: bool) -> (Vec<u64>, HashMap<u64, u32>) {
    let mut keys = vec![0u64; w.len()];
    let mut counts = HashMap::new();
    if !share {
        return (keys, counts);
    }
    const P: u64 = 0x0000_0100_0000_01b3;
    let mix = |h: u64, t: u64| (h ^ t).wrapping_mul(P).rotate_left(29);
    // (open index, running hash, uses `$`, draws wood)
    let mut stack: Vec<(usize, u64, bool, bool)> = Vec::new();
    for i in 0..w.len() {
        let m = w.modules[i];
        match m.sym {
            b'[' => stack.push((i, 0xcbf2_9ce4_8422_2325, false, false)),
            b']' => {
                if let Some((o, h, unique, draws)) = stack.pop() {
                    let mut k = crate::rng::Rng::new(h).next_u64();
                    if unique {
                        k ^= (o as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15);
                    }
                    keys[o] = k;
                    // Leaf-only brackets (petioles) stay part of their branch.
                    if draws {
                        *counts.entry(k).or_insert(0) += 1;
                    }
                    if let Some(top) = stack.last_mut() {
                        top.1 = mix(top.1, k);
                        top.2 |= unique;
                        top.3 |= draws;
                    }
                }
            }
            sym => {
                if let Some(top) = stack.last_mut() {
                    let mut h = mix(top.1, sym as u64 | (m.n as u64) << 8);
                    for a in w.args(i) {
                        h = mix(h, a.to_bits());
                    }
                    top.1 = h;
                    top.2 |= sym == b'$';
                    top.3 |= sym == b'F';
                }
            }
        }
    }
    (keys, counts)
}

/// Sides of a chain's rings from its radius (metres): branches are triangles or squares, the
/// trunk a hexagon or octagon. Fixed per chain.
fn ring_sides(r: f64) -> u8 {
    if r >= 0.1 {
        8
    } else if r >= 0.05 {
        6
    } else if r >= 0.03 {
        4
    } else {
        3
    }
}

fn unit_leaf() -> LeafFrame {
    LeafFrame {
        pos: Vec3::ZERO,
        heading: Vec3::Y,
        side: Vec3::NEG_X,
        normal: Vec3::Z,
        size: 1.0,
        color: 0,
    }
}

/// The unit leaf quad, object 0 of the instancing view.
pub fn unit_leaf_frame() -> LeafFrame {
    unit_leaf()
}

/// Interprets `w` with the turtle of `ls`.
pub fn interpret(ls: &LSystem, w: &Word) -> Result<Interpretation, PlantError> {
    let nf = w.count(b'F');
    let nl = w.count(b'~');
    if nf > MAX_INTERNODES || nl > MAX_LEAVES {
        return Err(PlantError::file(
            &ls.file,
            format!(
                "the plant would have {nf} internodes and {nl} leaves; the limits are {MAX_INTERNODES} and {MAX_LEAVES}"
            ),
            "lower `iterations:`",
        ));
    }
    let partners = w.bracket_partners();
    let share = ls.tropism.is_none();
    let (keys, counts) = content_keys(w, share);
    let mut objmap: HashMap<(u64, u64, u8), u32> = HashMap::new();
    let mut out = Interpretation::default();
    out.skeleton.points.reserve(nf + nf / 4);
    out.skeleton.segments.reserve(nf);
    out.skeleton.leaves.reserve(nl);
    out.objects.push(ObjectRecord {
        level: 0,
        ..Default::default()
    });
    out.objects[0].skeleton.leaves.push(unit_leaf());
    out.objects.push(ObjectRecord::default());
    out.nodes.push(RawNode::default());
    let mut close_order: Vec<u32> = Vec::new();
    let mut rec = vec![Rec {
        obj: Some(1),
        inv: Mat4::IDENTITY,
    }];
    let tropism = ls
        .tropism
        .map(|(t, e)| (DVec3::from(t).normalize_or_zero(), e));
    let mut st = State {
        pos: DVec3::ZERO,
        h: DVec3::Y,
        l: DVec3::NEG_X,
        u: DVec3::Z,
        width: ls.width,
        color: 0,
        chain: u32::MAX,
        lchain: u32::MAX,
        node: 0,
    };
    // (state, open index, pushed a Rec)
    let mut stack: Vec<(State, usize, bool)> = Vec::new();
    let mut i = 0;
    while i < w.len() {
        let sym = w.sym(i);
        let args = w.args(i);
        let a0 = args.first().copied();
        match sym {
            b'F' => {
                let len = a0.unwrap_or(ls.step);
                if len.abs() > 1e-9 {
                    if st.width < ls.twig {
                        // Thinner than `twig:`: move without drawing (like `f`).
                        st.pos += st.h * len;
                        st.chain = u32::MAX;
                        st.lchain = u32::MAX;
                    } else {
                        draw(&mut out, &mut st, &rec, len);
                    }
                    if let Some((t, e)) = tropism {
                        let axis = st.h.cross(t);
                        let a = e * axis.length();
                        if a.abs() > 1e-12 {
                            let q = glam::DQuat::from_axis_angle(axis.normalize(), a);
                            st.h = (q * st.h).normalize();
                            st.l = (q * st.l).normalize();
                            st.u = st.h.cross(st.l).normalize();
                        }
                    }
                }
            }
            b'f' => {
                st.pos += st.h * a0.unwrap_or(ls.step);
                st.chain = u32::MAX;
                st.lchain = u32::MAX;
            }
            b'+' => (st.h, st.l) = rotate(st.h, st.l, a0.unwrap_or(ls.angle)),
            b'-' => (st.h, st.l) = rotate(st.h, st.l, -a0.unwrap_or(ls.angle)),
            b'&' => (st.h, st.u) = rotate(st.h, -st.u, a0.unwrap_or(ls.angle)).into_neg_second(),
            b'^' => (st.h, st.u) = rotate(st.h, -st.u, -a0.unwrap_or(ls.angle)).into_neg_second(),
            b'\\' => (st.l, st.u) = rotate(st.l, st.u, a0.unwrap_or(ls.angle)),
            b'/' => (st.l, st.u) = rotate(st.l, st.u, -a0.unwrap_or(ls.angle)),
            b'|' => (st.h, st.l) = (-st.h, -st.l),
            b'$' => {
                let l = DVec3::Y.cross(st.h);
                if l.length_squared() > 1e-12 {
                    st.l = l.normalize();
                    st.u = st.h.cross(st.l);
                }
            }
            b'!' => st.width = a0.map_or(st.width * ls.taper, f64::abs),
            b'\'' => st.color = a0.map_or(st.color.wrapping_add(1), |c| c.clamp(0.0, 255.0) as u8),
            b'~' => leaf(&mut out, &st, &rec, a0.unwrap_or(ls.leaf_size)),
            b'%' => {
                // Cut: jump to the `]` closing the current branch (or the end).
                i = stack
                    .last()
                    .map_or(w.len(), |&(_, o, _)| partners[o] as usize);
                continue;
            }
            b'[' => {
                let mut pushed = false;
                if let Some(Rec {
                    obj: Some(cur),
                    inv,
                }) = rec.last()
                {
                    let (cur, inv) = (*cur, *inv);
                    if counts.get(&keys[i]).copied().unwrap_or(0) >= 2 {
                        let key = (keys[i], st.width.to_bits(), st.color);
                        let fr = frame(&st);
                        let (obj, new) = match objmap.get(&key) {
                            Some(&o) => (o, false),
                            None => {
                                let o = out.objects.len() as u32;
                                out.objects.push(ObjectRecord::default());
                                objmap.insert(key, o);
                                (o, true)
                            }
                        };
                        out.objects[cur as usize].instances.push(Instance {
                            object: obj,
                            transform: inv * fr,
                        });
                        rec.push(Rec {
                            obj: new.then_some(obj),
                            inv: fr.inverse(),
                        });
                        pushed = true;
                    }
                }
                stack.push((st, i, pushed));
                out.nodes.push(RawNode {
                    parent: st.node,
                    leaves: out.skeleton.leaves.len() as u32..0,
                    segments: out.skeleton.segments.len() as u32..0,
                    ..Default::default()
                });
                st.node = out.nodes.len() as u32 - 1;
                st.chain = u32::MAX;
                st.lchain = u32::MAX;
            }
            b']' => {
                if let Some((prev, _, pushed)) = stack.pop() {
                    close_node(&mut out, st.node, prev.node);
                    if pushed && let Some(Rec { obj: Some(o), .. }) = rec.pop() {
                        close_object(&mut out, o, &mut close_order);
                    }
                    st = prev;
                }
            }
            _ => {}
        }
        i += 1;
    }
    // Unclosed brackets cannot happen in derived words; close defensively.
    while let Some((prev, _, pushed)) = stack.pop() {
        close_node(&mut out, st.node, prev.node);
        if pushed && let Some(Rec { obj: Some(o), .. }) = rec.pop() {
            close_object(&mut out, o, &mut close_order);
        }
        st = prev;
    }
    let root = &mut out.nodes[0];
    root.leaves.end = out.skeleton.leaves.len() as u32;
    root.segments.end = out.skeleton.segments.len() as u32;
    close_object(&mut out, 1, &mut close_order);
    // Uses: parents before children (reverse post-order).
    out.objects[1].uses = 1;
    for &o in close_order.iter().rev() {
        let u = out.objects[o as usize].uses;
        let insts: Vec<u32> = out.objects[o as usize]
            .instances
            .iter()
            .map(|x| x.object)
            .collect();
        for c in insts {
            out.objects[c as usize].uses += u;
        }
    }
    Ok(out)
}

trait NegSecond {
    fn into_neg_second(self) -> (DVec3, DVec3);
}
impl NegSecond for (DVec3, DVec3) {
    fn into_neg_second(self) -> (DVec3, DVec3) {
        (self.0, -self.1)
    }
}

fn close_node(out: &mut Interpretation, node: u32, parent: u32) {
    let leaves_end = out.skeleton.leaves.len() as u32;
    let seg_end = out.skeleton.segments.len() as u32;
    let n = &mut out.nodes[node as usize];
    n.leaves.end = leaves_end;
    n.segments.end = seg_end;
    let bb = n.bbox;
    out.nodes[parent as usize].bbox.merge(&bb);
}

fn close_object(out: &mut Interpretation, o: u32, order: &mut Vec<u32>) {
    let lvl = out.objects[o as usize]
        .instances
        .iter()
        .map(|x| out.objects[x.object as usize].level + 1)
        .max()
        .unwrap_or(1);
    out.objects[o as usize].level = lvl.max(1);
    order.push(o);
}

fn draw(out: &mut Interpretation, st: &mut State, rec: &[Rec], len: f64) {
    let radius = (st.width * 0.5) as f32;
    let recording = match rec.last() {
        Some(Rec { obj: Some(o), inv }) => Some((*o, *inv)),
        _ => None,
    };
    let start = st.pos;
    st.pos += st.h * len;
    let h = st.h.as_vec3();
    // World chain.
    push_chain(
        &mut out.skeleton,
        &mut st.chain,
        start.as_vec3(),
        st.pos.as_vec3(),
        h,
        st.l.as_vec3(),
        radius,
        st.color,
        ring_sides(st.width * 0.5),
        len as f32,
    );
    let node = &mut out.nodes[st.node as usize];
    node.bbox.add_sphere(start.as_vec3(), radius);
    node.bbox.add_sphere(st.pos.as_vec3(), radius);
    node.own_internodes += 1;
    out.internodes += 1;
    if let Some((o, inv)) = recording {
        let sk = &mut out.objects[o as usize].skeleton;
        let p0 = inv.transform_point3(start.as_vec3());
        let p1 = inv.transform_point3(st.pos.as_vec3());
        let hl = inv.transform_vector3(h).normalize_or_zero();
        let ll = inv.transform_vector3(st.l.as_vec3()).normalize_or_zero();
        push_chain(
            sk,
            &mut st.lchain,
            p0,
            p1,
            hl,
            ll,
            radius,
            st.color,
            ring_sides(st.width * 0.5),
            len as f32,
        );
    }
}

#[allow(clippy::too_many_arguments)]
fn push_chain(
    sk: &mut Skeleton,
    chain: &mut u32,
    p0: Vec3,
    p1: Vec3,
    h: Vec3,
    l: Vec3,
    radius: f32,
    color: u8,
    sides: u8,
    len: f32,
) {
    let (a, sides, v0) = if *chain == u32::MAX {
        sk.points.push(ChainPoint {
            pos: p0,
            heading: h,
            side: l,
            radius,
            color,
            sides,
            v: 0.0,
            prev: u32::MAX,
        });
        (sk.points.len() as u32 - 1, sides, 0.0)
    } else {
        let p = &mut sk.points[*chain as usize];
        if p.prev != u32::MAX {
            p.heading = (p.heading + h).normalize_or(h);
        } else {
            p.heading = h;
        }
        (*chain, p.sides, p.v)
    };
    sk.points.push(ChainPoint {
        pos: p1,
        heading: h,
        side: l,
        radius,
        color,
        sides,
        v: v0 + len.abs(),
        prev: a,
    });
    let b = sk.points.len() as u32 - 1;
    sk.segments.push([a, b]);
    *chain = b;
}

fn leaf(out: &mut Interpretation, st: &State, rec: &[Rec], size: f64) {
    let size = size.abs() as f32;
    let lf = LeafFrame {
        pos: st.pos.as_vec3(),
        heading: st.h.as_vec3(),
        side: st.l.as_vec3(),
        normal: st.u.as_vec3(),
        size,
        color: st.color,
    };
    let node = &mut out.nodes[st.node as usize];
    let half = lf.side * size * 0.5;
    for c in [
        lf.pos - half,
        lf.pos + half,
        lf.pos - half + lf.heading * size,
        lf.pos + half + lf.heading * size,
    ] {
        node.bbox.add(c);
    }
    out.skeleton.leaves.push(lf);
    if let Some(Rec { obj: Some(o), inv }) = rec.last() {
        let t = *inv * frame(st) * Mat4::from_scale(Vec3::splat(size));
        out.objects[*o as usize].instances.push(Instance {
            object: 0,
            transform: t,
        });
    }
}
