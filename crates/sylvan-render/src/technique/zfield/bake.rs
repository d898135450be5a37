//! BN12 §5 "Precomputations": per plant, one orthographic view per direction of the diamond
//! grid ([`HemiGrid`], 181 at order 9), each texel holding the min depth `z`, the max depth
//! `z̄`, the ambient occlusion `δ` of the isolated tree on flat ground and the opacity `α`
//! (`z`, `z̄`, `δ` premultiplied by `α`), plus albedo and normal as the shared baker makes them
//! for every image technique. Mips are box-filtered premultiplied.

use super::ZFieldBakeParams;
use crate::RenderError;
use crate::bake::codec::{DecodeError, Decoder, Encoder};
use crate::bake::image::{TileImage, TileLevel};
use crate::bake::views::PlaneFrame;
use crate::bake::{BakeRequest, PlantBaker};
use crate::directions::HemiGrid;
use crate::technique::params::ParamTable;
use glam::Vec3;
use sylvan_gpu::Gpu;
use sylvan_plant::Plant;

/// Bumped whenever the payload below or the bake changes.
pub const FORMAT_VERSION: u32 = 1;

/// Ambient occlusion is evaluated against the views' opacity and depth at this mip size (or
/// the tile, if smaller): smooth, and 16× cheaper than the full tile at 128².
const AO_LEVEL_SIZE: u32 = 32;

/// The shared frame of every view: the square enclosing the bounding box's circumscribed
/// sphere, seen along `dir` (as `octahedral`'s, so all views share scale and depth range).
pub fn view_frame(plant: &Plant, dir: Vec3) -> PlaneFrame {
    let (min, max) = (Vec3::from(plant.bbox_min), Vec3::from(plant.bbox_max));
    PlaneFrame::for_sphere(dir, (min + max) * 0.5, (max - min).length() * 0.5)
}

/// One view of a z-field: the shared baker's albedo and normal mips, and the z-field channels.
#[derive(Debug, Clone, PartialEq)]
pub struct ZView {
    /// Premultiplied albedo + coverage, normal + depth (as `octahedral`'s tiles).
    pub levels: Vec<TileLevel>,
    /// Per mip (`tile >> m` texels a side): RGBA8 unorm `(α z, α z̄, α δ, α)`, `z` and `z̄` in
    /// [0, 1] across the frame's depth (0: the face towards the view, `radius` in front of the
    /// centre plane; 1: `radius` behind it).
    pub zfield: Vec<Vec<u8>>,
}

/// The baked asset of one plant.
#[derive(Debug, Clone, PartialEq)]
pub struct ZFieldBaked {
    /// Order of the direction grid ([`HemiGrid`]).
    pub order: u32,
    /// Tile size in texels.
    pub tile: u32,
    /// Model-space centre of the frames (the bounding-box centre `o`).
    pub centre: [f32; 3],
    /// Half side (and half depth) of every frame: the bounding sphere's radius.
    pub radius: f32,
    /// `views[k]`: grid direction `k`.
    pub views: Vec<ZView>,
}

impl ZFieldBaked {
    /// Bytes of image data (all mips: albedo, normal and z-field).
    pub fn image_bytes(&self) -> u64 {
        self.views
            .iter()
            .map(|v| {
                let a: usize = v
                    .levels
                    .iter()
                    .map(|l| l.color.len() + l.normal.len())
                    .sum();
                let z: usize = v.zfield.iter().map(Vec::len).sum();
                (a + z) as u64
            })
            .sum()
    }
}

/// `zfield`'s offline half.
pub struct ZFieldBake;

impl crate::bake::Bake for ZFieldBake {
    const NAME: &'static str = "zfield";
    const FORMAT_VERSION: u32 = FORMAT_VERSION;
    type Params = ZFieldBakeParams;
    type Asset = ZFieldBaked;

    fn describe(b: &ZFieldBaked) -> crate::bake::AssetSummary {
        let mut fields = serde_json::Map::new();
        fields.insert("order".into(), b.order.into());
        fields.insert("views".into(), b.views.len().into());
        crate::bake::AssetSummary {
            line: format!(
                "{} z-field views (diamond grid order {}) of {}²",
                b.views.len(),
                b.order,
                b.tile
            ),
            image_bytes: b.image_bytes(),
            images: b.views.len(),
            tile: b.tile,
            fields,
        }
    }

    /// Bakes `plant`: every grid view from the front (albedo, normal, min depth, opacity) and
    /// from behind (max depth), then the ambient occlusion of every front texel against all
    /// the views, and the premultiplied mips.
    fn bake(
        gpu: &Gpu,
        plant: &Plant,
        p: &ZFieldBakeParams,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<ZFieldBaked, RenderError> {
        p.validate().map_err(RenderError::Option)?;
        let grid = HemiGrid::new(p.order).expect("validated");
        let frames: Vec<PlaneFrame> = grid
            .directions()
            .into_iter()
            .map(|d| view_frame(plant, d))
            .collect();
        let requests: Vec<BakeRequest> = [1.0f32, -1.0]
            .iter()
            .flat_map(|&side| {
                frames
                    .iter()
                    .map(move |f| (f, side))
                    .map(|(f, side)| BakeRequest {
                        side,
                        ..BakeRequest::whole(plant, *f)
                    })
            })
            .collect();
        let baker = PlantBaker::new(gpu, plant, p.tile, p.supersample)?;
        let total = requests.len() + frames.len();
        let images = baker.bake(gpu, &requests, |done| progress(done, total))?;
        let (front, back) = images.split_at(frames.len());
        let fields: Vec<Vec<[f32; 4]>> = front
            .iter()
            .zip(back)
            .map(|(f, b)| depth_field(f, b))
            .collect();
        let ao = ambient_occlusion(grid, &frames, &fields, p.tile, p.ao_density);
        progress(total, total);
        let views = front
            .iter()
            .zip(fields)
            .zip(ao)
            .map(|((img, mut field), ao)| {
                for (t, a) in field.iter_mut().zip(ao) {
                    t[2] = a * t[3];
                }
                ZView {
                    levels: img.levels(),
                    zfield: mips(&field, p.tile)
                        .iter()
                        .map(|l| l.iter().flatten().map(|&v| unorm8(v)).collect())
                        .collect(),
                }
            })
            .collect();
        Ok(ZFieldBaked {
            order: p.order,
            tile: p.tile,
            centre: frames[0].centre.to_array(),
            radius: frames[0].half.x,
            views,
        })
    }
}

/// `(α z, α z̄, 0, α)` of one view from its front and back images (the back image shares the
/// front's texel grid; its depth runs from the other face).
fn depth_field(front: &TileImage, back: &TileImage) -> Vec<[f32; 4]> {
    front
        .color
        .iter()
        .zip(&front.normal_depth)
        .zip(back.color.iter().zip(&back.normal_depth))
        .map(|((fc, fnd), (bc, bnd))| {
            let a = fc[3];
            if a <= 0.0 {
                return [0.0; 4];
            }
            let z = fnd[3];
            let zbar = if bc[3] > 0.0 {
                (1.0 - bnd[3]).max(z)
            } else {
                z
            };
            [a * z, a * zbar, 0.0, a]
        })
        .collect()
}

/// The premultiplied box-filtered mip chain of a `size`² field, level 0 first.
pub fn mips(field: &[[f32; 4]], size: u32) -> Vec<Vec<[f32; 4]>> {
    let mut out = vec![field.to_vec()];
    let mut n = size as usize;
    while n > 1 {
        let h = n / 2;
        let prev = out.last().expect("level 0");
        let mut next = vec![[0.0f32; 4]; h * h];
        for y in 0..h {
            for x in 0..h {
                let mut acc = [0.0f32; 4];
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let t = prev[(2 * y + dy) * n + 2 * x + dx];
                    for k in 0..4 {
                        acc[k] += 0.25 * t[k];
                    }
                }
                next[y * h + x] = acc;
            }
        }
        out.push(next);
        n = h;
    }
    out
}

/// One view's opacity and depth at the ambient-occlusion mip: `(α, z)` per texel, `z` not
/// premultiplied (0 where `α` is 0).
struct Occluder {
    frame: PlaneFrame,
    weight: f32,
    size: usize,
    texels: Vec<[f32; 2]>,
}

impl Occluder {
    /// How much of the sky along this view's direction the model-space point `p` loses:
    /// `α (1 − exp(−κ · depth behind the view's front surface in radii))`, bilinear.
    fn occlusion(&self, p: Vec3, density: f32) -> f32 {
        let f = &self.frame;
        let r = f.half.x;
        let q = p - f.centre;
        let s = (0.5 + 0.5 * q.dot(f.u) / r) * self.size as f32 - 0.5;
        let t = (0.5 - 0.5 * q.dot(f.v) / r) * self.size as f32 - 0.5;
        let depth = 0.5 - 0.5 * q.dot(f.f) / r;
        let (x0, y0) = (s.floor(), t.floor());
        let (fx, fy) = (s - x0, t - y0);
        let n = self.size as i32;
        let mut occ = 0.0;
        for (dx, dy, w) in [
            (0, 0, (1.0 - fx) * (1.0 - fy)),
            (1, 0, fx * (1.0 - fy)),
            (0, 1, (1.0 - fx) * fy),
            (1, 1, fx * fy),
        ] {
            let (x, y) = (x0 as i32 + dx, y0 as i32 + dy);
            if x < 0 || y < 0 || x >= n || y >= n {
                continue;
            }
            let [a, z] = self.texels[(y * n + x) as usize];
            // Depth units are 2 radii; half a texel of slack keeps a surface from occluding
            // itself.
            let behind = (2.0 * (depth - z) - 1.0 / self.size as f32).max(0.0);
            occ += w * a * (1.0 - (-density * behind).exp());
        }
        occ
    }
}

/// BN12 §5's `δ` of the isolated tree on flat ground: per front texel of every view, the
/// cosine-weighted fraction of the upper hemisphere's sky its surface point sees, the sky
/// sampled along a sub-grid of the views (each view's own opacity and depth tell how much of
/// the tree lies between the point and the sky in its direction). The ground below the tree
/// hides only the lower hemisphere, which is not sampled.
fn ambient_occlusion(
    grid: HemiGrid,
    frames: &[PlaneFrame],
    fields: &[Vec<[f32; 4]>],
    tile: u32,
    density: f32,
) -> Vec<Vec<f32>> {
    let n = grid.order() as i32;
    let step = (n / 3).max(1);
    let level = tile.ilog2().saturating_sub(AO_LEVEL_SIZE.min(tile).ilog2()) as usize;
    let occluders: Vec<Occluder> = (0..frames.len())
        .filter(|&k| {
            let (i, j) = grid.lattice(k as u32);
            i % step == 0 && j % step == 0 && frames[k].f.y > 1e-3
        })
        .map(|k| {
            let m = &mips(&fields[k], tile)[level];
            Occluder {
                frame: frames[k],
                weight: frames[k].f.y,
                size: (tile >> level) as usize,
                texels: m
                    .iter()
                    .map(|t| [t[3], if t[3] > 0.0 { t[0] / t[3] } else { 0.0 }])
                    .collect(),
            }
        })
        .collect();
    let total: f32 = occluders.iter().map(|o| o.weight).sum();
    let one_view = |k: usize| -> Vec<f32> {
        let f = &frames[k];
        let n = tile as usize;
        fields[k]
            .iter()
            .enumerate()
            .map(|(i, t)| {
                if t[3] <= 0.0 {
                    return 1.0;
                }
                let (x, y) = (i % n, i / n);
                let z = t[0] / t[3];
                let p = f.point((x as f32 + 0.5) / n as f32, (y as f32 + 0.5) / n as f32)
                    + f.f * (f.half.x * (1.0 - 2.0 * z));
                let lost: f32 = occluders
                    .iter()
                    .map(|o| o.weight * o.occlusion(p, density))
                    .sum();
                (1.0 - lost / total.max(1e-6)).clamp(0.0, 1.0)
            })
            .collect()
    };
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get().min(8));
    let mut out: Vec<Vec<f32>> = vec![Vec::new(); frames.len()];
    std::thread::scope(|s| {
        let chunk = frames.len().div_ceil(threads);
        let handles: Vec<_> = (0..frames.len())
            .step_by(chunk)
            .map(|start| {
                let one_view = &one_view;
                s.spawn(move || {
                    (start..(start + chunk).min(frames.len()))
                        .map(one_view)
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        let mut k = 0;
        for h in handles {
            for v in h.join().expect("ambient occlusion worker") {
                out[k] = v;
                k += 1;
            }
        }
    });
    out
}

fn unorm8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

impl crate::bake::codec::Codec for ZFieldBaked {
    /// The payload written to the cache.
    fn encode(&self) -> Vec<u8> {
        let mut e = Encoder::default();
        e.u32(self.order);
        e.u32(self.tile);
        e.f32s(&self.centre);
        e.f32(self.radius);
        e.u64(self.views.len() as u64);
        for v in &self.views {
            TileLevel::encode_chain(&mut e, &v.levels);
            e.u64(v.zfield.len() as u64);
            for l in &v.zfield {
                e.bytes(l);
            }
        }
        e.buf
    }

    /// Reads a payload back, checking every count and size.
    fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        let bad = |m: String| DecodeError(m);
        let mut d = Decoder::new(bytes);
        let order = d.u32()?;
        let tile = d.u32()?;
        let p = ZFieldBakeParams {
            order,
            tile,
            ..Default::default()
        };
        p.validate().map_err(bad)?;
        let centre: [f32; 3] = d
            .f32s()?
            .try_into()
            .map_err(|_| bad("centre is not 3 floats".into()))?;
        let radius = d.f32()?;
        if !(radius.is_finite() && radius > 0.0) || centre.iter().any(|c| !c.is_finite()) {
            return Err(bad(format!("frame radius {radius} or centre is not valid")));
        }
        let want = HemiGrid::new(order).expect("validated").len() as u64;
        let n = d.u64()?;
        if n != want {
            return Err(bad(format!("{n} views for a grid of order {order}")));
        }
        let mut views = Vec::with_capacity(n as usize);
        for _ in 0..n {
            let levels = TileLevel::decode_chain(&mut d, tile)?;
            let m = d.u64()?;
            if m != levels.len() as u64 {
                return Err(bad(format!("{m} z-field mips for {} levels", levels.len())));
            }
            let mut zfield = Vec::with_capacity(m as usize);
            for l in &levels {
                let z = d.bytes()?;
                if z.len() != l.color.len() {
                    return Err(bad("a z-field mip has the wrong size".into()));
                }
                zfield.push(z.to_vec());
            }
            views.push(ZView { levels, zfield });
        }
        d.finish()?;
        Ok(Self {
            order,
            tile,
            centre,
            radius,
            views,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mips_are_premultiplied_box_filters() {
        let mut f = vec![[0.0f32; 4]; 16];
        // One opaque texel at depth 0.5 in a 4×4 field.
        f[5] = [0.5, 0.75, 0.9, 1.0];
        let m = mips(&f, 4);
        assert_eq!(m.len(), 3);
        assert_eq!(m[1][0], [0.125, 0.1875, 0.225, 0.25]);
        // Un-premultiplied, the depth survives filtering exactly.
        let t = m[2][0];
        assert!((t[0] / t[3] - 0.5).abs() < 1e-6 && (t[1] / t[3] - 0.75).abs() < 1e-6);
    }

    #[test]
    fn occluders_shadow_points_behind_their_front_surface() {
        let frame = PlaneFrame::for_sphere(Vec3::Y, Vec3::ZERO, 1.0);
        let o = Occluder {
            frame,
            weight: 1.0,
            size: 4,
            // Opaque, front surface at the centre plane (depth 0.5) everywhere.
            texels: vec![[1.0, 0.5]; 16],
        };
        let above = o.occlusion(Vec3::new(0.0, 0.5, 0.0), 16.0);
        let below = o.occlusion(Vec3::new(0.0, -0.5, 0.0), 16.0);
        assert!(above < 1e-6, "{above}");
        assert!(below > 0.8, "{below}");
    }
}
