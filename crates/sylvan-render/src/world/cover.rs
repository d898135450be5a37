//! The ground cover: BN12 §4's coverage tiles at one level and its mips, with §5's density map,
//! made per world tile from the same trees the tiles draw, for BN12's ground lighting (eq.
//! 10–12), the sky on the trees (eq. 9) and the forest field's coverage (`field.wgsl`'s
//! `field_cover_gain`, read at the mip of the pixel's footprint: the quadtree below the
//! world's tile, `CoverLayout::levels`).
//!
//! Per tile a `G × G` grid (`G` = tile / [`TEXEL_M`], so about 2 m texels) holds, in RGBA8:
//! - **Γ**: the share of the texel covered by tree crowns seen from above — one disk per tree,
//!   the plant's mean horizontal half-extent at the tree's scale, about the crown's centre
//!   (BN12 draws "one disk per tree"); overlapping disks combine as `1 − Π(1 − a)`;
//! - **Γ̄**: Γ's local mean (two box filters, [`BLUR_M`] either side). BN12's eq. 10 uses
//!   `Λ_h A`, the coarse density times the mean crown area; Γ̄ is the same quantity measured on
//!   the trees actually placed, so `Δ = 1 − a3 (Γ − Γ̄)` averages to 1 by construction, as
//!   BN12 requires, whatever the crowns' shapes and overlaps (a deviation, stated);
//! - **Λ_h**: the local tree density (trees per m², the same filter over the trunk bases),
//!   stored as `sqrt(Λ_h / LAMBDA_MAX)`. It is the density map of eq. 9 for placed trees and
//!   seeded forests alike: the density of the trees drawn, not of the maps they came from;
//! - **n·u_z** of the terrain (eq. 9's slope term for the trees standing there).
//!
//! Tiles are produced on worker threads when they come within reach and held in one
//! **toroidal atlas** of `N × N` tiles around the eye: world tile (x, z) lives in cell
//! (x mod N, z mod N), so one repeat-addressed texture is sampled at `world / (N · tile)` with
//! bilinear filtering seamless across tiles, and a `N × N` tag texture says which tile each
//! cell holds (a cell holding another tile reads as "no cover": Γ = Γ̄, the scene's mean
//! density). `N` spans twice the reach plus the world's prefetch ring (`[world] prefetch_m`), so
//! tiles entering the reach were asked for a ring earlier. Memory is `(N G)² × 4` bytes,
//! `N G` ≤ [`MAX_ATLAS`] (64 MiB at most, a window of 8 km at 2 m texels), whatever the size of
//! the world.

use super::produce::{Job, Produced, Producer, Source};
use super::{TileKey, worker_threads};
use crate::RenderError;
use crate::frame::Frustum;
use glam::{Vec2, Vec3};
use std::sync::Arc;
use sylvan_gpu::Gpu;

/// Target texel size of the cover, metres (the tile is split into a whole number of texels).
pub const TEXEL_M: f32 = 2.0;
/// Half support of the local mean Γ̄ and of the density Λ_h, metres.
pub const BLUR_M: f32 = 16.0;
/// Largest side of the atlas, texels.
pub const MAX_ATLAS: u32 = 4096;
/// Density at the top of the stored range, trees per m² (25,000 per hectare).
pub const LAMBDA_MAX: f32 = 2.5;
/// Texel format of the atlas.
pub const COVER_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Format of the tag texture: per cell `x + z · 65536 + 1` of the tile it holds, 0 for none.
pub const TAG_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;

/// How a tile's cover is laid out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CoverLayout {
    /// Tile side, metres.
    pub tile_m: f32,
    /// Texels per tile side.
    pub texels: u32,
    /// Box-filter radius, texels (applied twice).
    pub blur: u32,
    /// Texels of trees gathered beyond the tile on each side (the filters' reach and the
    /// widest crown).
    pub margin: u32,
}

impl CoverLayout {
    /// The layout for tiles of `tile_m` and crowns up to `crown_m` in radius.
    pub fn new(tile_m: f32, crown_m: f32) -> Self {
        let texels = ((tile_m / TEXEL_M).round() as u32).clamp(8, 512);
        let texel = tile_m / texels as f32;
        let blur = ((BLUR_M / (2.0 * texel)).round() as u32).max(1);
        let margin = 2 * blur + (crown_m.clamp(0.0, 200.0) / texel).ceil() as u32 + 1;
        Self {
            tile_m,
            texels,
            blur,
            margin,
        }
    }

    /// Texel side, metres.
    pub fn texel_m(&self) -> f32 {
        self.tile_m / self.texels as f32
    }

    /// Mip levels of a tile (level 0 included): halvings while the side stays whole, at most
    /// down to one texel a tile — the quadtree of BN12 §4's coverage tiles below the world's
    /// tile; coarser, the field's density raster.
    pub fn levels(&self) -> u32 {
        self.texels.trailing_zeros().min(self.texels.ilog2()) + 1
    }
}

/// The 2 × 2 means of a `side²` RGBA8 grid (side even).
fn halve(src: &[[u8; 4]], side: usize) -> Vec<[u8; 4]> {
    let h = side / 2;
    let mut out = Vec::with_capacity(h * h);
    for z in 0..h {
        for x in 0..h {
            let at = |dx: usize, dz: usize| src[(2 * z + dz) * side + 2 * x + dx];
            out.push(std::array::from_fn(|c| {
                let sum: u32 = [at(0, 0), at(1, 0), at(0, 1), at(1, 1)]
                    .iter()
                    .map(|t| t[c] as u32)
                    .sum();
                ((sum + 2) / 4) as u8
            }));
        }
    }
    out
}

/// One tile's cover, as uploaded (`texels²` RGBA8, row-major, row 0 at the tile's low Z), and
/// its mip levels (each the 2 × 2 means of the one before, down to [`CoverLayout::levels`]).
pub(crate) struct CoverTile {
    pub key: TileKey,
    pub texels: Vec<[u8; 4]>,
    pub mips: Vec<Vec<[u8; 4]>>,
}

impl Produced for CoverTile {
    fn key(&self) -> TileKey {
        self.key
    }
}

/// The horizontal crown disk of each species per metre of tree height: the centre's offset
/// (model x, z) and radius, from the plant's bounding box.
pub(crate) fn crown_disks(source: &Source) -> Vec<(Vec2, f32)> {
    source
        .bounds
        .iter()
        .map(|b| {
            let h = b.max.y.max(1e-3);
            let c = (b.min + b.max) * 0.5;
            let r = ((b.max.x - b.min.x) + (b.max.z - b.min.z)) * 0.25;
            (Vec2::new(c.x, c.z) / h, r / h)
        })
        .collect()
}

/// Produces tile `key`'s cover from every tree within its margin (see the module doc).
pub(crate) fn produce(source: &Source, layout: &CoverLayout, key: TileKey) -> CoverTile {
    let g = layout.texels as usize;
    let m = layout.margin as usize;
    let e = g + 2 * m;
    let texel = layout.texel_m();
    let origin =
        Vec2::new(key.x as f32, key.z as f32) * layout.tile_m - Vec2::splat(m as f32 * texel);
    let extent = Vec2::splat(e as f32 * texel);
    let disks = crown_disks(source);
    let mut open = vec![1.0f32; e * e];
    let mut count = vec![0.0f32; e * e];
    // The margin holds the filters' reach and the widest crown: the trees based in the
    // extended grid are every tree that counts inside the tile.
    let trees = source.trees_in(origin, origin + extent);
    const SUB: usize = 4;
    for t in &trees {
        let Some(&(offset, radius)) = disks.get(t.species as usize) else {
            continue;
        };
        let base = Vec2::new(t.position.x, t.position.z);
        let local = (base - origin) / texel;
        if local.cmpge(Vec2::ZERO).all() && local.cmplt(Vec2::splat(e as f32)).all() {
            count[local.y as usize * e + local.x as usize] += 1.0;
        }
        let (s, c) = t.rotation.sin_cos();
        let o = offset * t.height;
        let centre = base + Vec2::new(c * o.x + s * o.y, -s * o.x + c * o.y);
        let r = radius * t.height;
        let lo = ((centre - Vec2::splat(r) - origin) / texel).floor();
        let hi = ((centre + Vec2::splat(r) - origin) / texel).floor();
        let (x0, z0) = (lo.x.max(0.0) as usize, lo.y.max(0.0) as usize);
        let (x1, z1) = (hi.x.min(e as f32 - 1.0), hi.y.min(e as f32 - 1.0));
        if x1 < 0.0 || z1 < 0.0 {
            continue;
        }
        let (x1, z1) = (x1 as usize, z1 as usize);
        for z in z0..=z1 {
            for x in x0..=x1 {
                // The disk's share of the texel, on a 4 × 4 sub-grid.
                let mut inside = 0;
                for sz in 0..SUB {
                    for sx in 0..SUB {
                        let p = origin
                            + Vec2::new(
                                x as f32 + (sx as f32 + 0.5) / SUB as f32,
                                z as f32 + (sz as f32 + 0.5) / SUB as f32,
                            ) * texel;
                        inside += usize::from(p.distance_squared(centre) <= r * r);
                    }
                }
                open[z * e + x] *= 1.0 - inside as f32 / (SUB * SUB) as f32;
            }
        }
    }
    let gamma: Vec<f32> = open.iter().map(|o| 1.0 - o).collect();
    let mut mean = gamma.clone();
    blur(&mut mean, e, layout.blur as usize);
    blur(&mut count, e, layout.blur as usize);
    let per_m2 = 1.0 / (texel * texel);
    let mut texels = Vec::with_capacity(g * g);
    for z in 0..g {
        for x in 0..g {
            let i = (z + m) * e + x + m;
            let w = origin + (Vec2::new((x + m) as f32, (z + m) as f32) + 0.5) * texel;
            let up = source.terrain.normal_at(w.x, w.y).y;
            let density = (count[i] * per_m2 / LAMBDA_MAX).clamp(0.0, 1.0).sqrt();
            texels.push([
                unorm8(gamma[i]),
                unorm8(mean[i]),
                unorm8(density),
                unorm8(up),
            ]);
        }
    }
    let mut mips: Vec<Vec<[u8; 4]>> = Vec::new();
    let mut side = g;
    for _ in 1..layout.levels() {
        let next = halve(mips.last().unwrap_or(&texels), side);
        side /= 2;
        mips.push(next);
    }
    CoverTile { key, texels, mips }
}

fn unorm8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Two passes of a separable box filter of radius `r` over an `e × e` grid (edges clamped).
fn blur(v: &mut [f32], e: usize, r: usize) {
    let mut tmp = vec![0.0f32; e * e];
    for _ in 0..2 {
        box_pass(v, &mut tmp, e, r, 1, e);
        box_pass(&tmp, v, e, r, e, 1);
    }
}

/// One box pass along lines of `e` samples `step` apart, lines `line` apart.
fn box_pass(src: &[f32], dst: &mut [f32], e: usize, r: usize, step: usize, line: usize) {
    let norm = 1.0 / (2 * r + 1) as f32;
    for l in 0..e {
        let at = |i: isize| src[l * line + (i.clamp(0, e as isize - 1) as usize) * step];
        let mut sum: f32 = (-(r as isize)..=r as isize).map(at).sum();
        for i in 0..e {
            dst[l * line + i * step] = sum * norm;
            sum += at(i as isize + r as isize + 1) - at(i as isize - r as isize);
        }
    }
}

/// The ground cover on the GPU: the toroidal atlas, its tags and the producer that fills them.
pub struct GroundCover {
    layout: CoverLayout,
    /// Cells per side of the atlas (`N`).
    cells: u32,
    /// Tiles along X and Z in the world.
    tiles: [i32; 2],
    texture: wgpu::Texture,
    tags: wgpu::Texture,
    view: wgpu::TextureView,
    tags_view: wgpu::TextureView,
    sampler: wgpu::Sampler,
    /// Which tile each cell holds.
    filled: Vec<Option<TileKey>>,
    producer: Option<Producer<CoverTile>>,
    /// The uniforms `frame.cover` and `frame.cover_extra` (see `frame.wgsl`).
    uniforms: [[f32; 4]; 3],
    produced: u32,
    /// Tiles are waited for up to here from the eye, metres.
    reach_m: f32,
    /// Milliseconds the last frame waited for tiles.
    wait_ms: f64,
    /// Produced, not uploaded yet: the ring's tiles, paced as the world's ([`super::due`]).
    arrived: Vec<CoverTile>,
    /// The eye's last position (horizontal).
    last_eye: Option<Vec2>,
}

/// What the ground-cover uniforms hold besides the atlas's shape.
#[derive(Debug, Clone, Copy)]
pub(crate) struct CoverSettings {
    /// BN12's a3 (eq. 10); 0 with `enabled` false turns the ground's occlusion off.
    pub contrast: f32,
    /// The ground's sky is occluded at all (false: the plain hemispherical sky).
    pub enabled: bool,
    /// Mean tree height, metres (the depth of eq. 9's hole at the ground).
    pub mean_height_m: f32,
    /// Trees per m² where no tile is held.
    pub fallback_density: f32,
    /// Trees are drawn up to here, metres (infinite: everywhere).
    pub trees_end_m: f32,
    /// How far from the eye tiles are wanted, metres.
    pub reach_m: f32,
    /// Tiles are asked for this much beyond `reach_m` (the world's prefetch ring), so a tile
    /// entering the reach has been produced ahead instead of waited for.
    pub prefetch_m: f32,
    /// Largest crown radius of any tree, metres.
    pub crown_m: f32,
}

impl GroundCover {
    /// The atlas for `source`'s world; starts the workers when `settings.enabled`.
    pub(crate) fn new(
        gpu: &Gpu,
        source: Arc<Source>,
        terrain_size: [f32; 2],
        settings: &CoverSettings,
    ) -> Result<Self, RenderError> {
        let layout = CoverLayout::new(source.tile_m, settings.crown_m);
        let tiles = terrain_size.map(|s| ((s / layout.tile_m).ceil() as i32).max(1));
        let limit = gpu.device.limits().max_texture_dimension_2d.min(MAX_ATLAS);
        let window = settings.reach_m.min(1e9) + settings.prefetch_m.min(1e9);
        let wanted = (2.0 * window / layout.tile_m).ceil() as i64 + 2;
        let cells = if settings.enabled {
            (wanted.min(tiles[0].max(tiles[1]) as i64) as u32)
                .min(limit / layout.texels)
                .max(1)
        } else {
            1
        };
        let side = if settings.enabled {
            cells * layout.texels
        } else {
            1
        };
        let levels = if settings.enabled { layout.levels() } else { 1 };
        let texture = texture_2d(gpu, "ground_cover", side, COVER_FORMAT, levels);
        let tags = texture_2d(gpu, "ground_cover_tags", cells, TAG_FORMAT, 1);
        let sampler = gpu.device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("ground_cover_sampler"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        let producer = settings.enabled.then(|| {
            let job: Job<CoverTile> = Arc::new(move |k| produce(&source, &layout, k));
            Producer::new(job, worker_threads(), "cover")
        });
        let end = if settings.trees_end_m.is_finite() {
            settings.trees_end_m
        } else {
            1e30
        };
        Ok(Self {
            view: texture.create_view(&Default::default()),
            tags_view: tags.create_view(&Default::default()),
            texture,
            tags,
            sampler,
            filled: vec![None; (cells * cells) as usize],
            producer,
            uniforms: [
                [
                    layout.tile_m,
                    cells as f32,
                    settings.contrast,
                    f32::from(u8::from(settings.enabled)),
                ],
                [
                    settings.fallback_density,
                    settings.mean_height_m,
                    end,
                    LAMBDA_MAX,
                ],
                [layout.texel_m(), levels as f32, 0.0, 0.0],
            ],
            layout,
            cells,
            tiles,
            produced: 0,
            reach_m: settings.reach_m,
            wait_ms: 0.0,
            arrived: Vec::new(),
            last_eye: None,
        })
    }

    /// The atlas view (group 0, binding 3).
    pub(crate) fn view(&self) -> &wgpu::TextureView {
        &self.view
    }

    /// The tag view (group 0, binding 4).
    pub(crate) fn tags_view(&self) -> &wgpu::TextureView {
        &self.tags_view
    }

    /// The atlas sampler (group 0, binding 5).
    pub(crate) fn sampler(&self) -> &wgpu::Sampler {
        &self.sampler
    }

    /// `frame.cover`, `frame.cover_extra` and `frame.cover_lod`.
    pub(crate) fn uniforms(&self) -> [[f32; 4]; 3] {
        self.uniforms
    }

    /// GPU bytes held.
    pub fn bytes(&self) -> u64 {
        let s = self.texture.size();
        let texels: u64 = (0..self.texture.mip_level_count())
            .map(|l| (s.width as u64 >> l) * (s.height as u64 >> l))
            .sum();
        (texels + (self.cells as u64).pow(2)) * 4
    }

    /// Tiles produced so far, GPU bytes, atlas cells and texels per tile side, and the CPU
    /// milliseconds spent producing tiles on the render thread or waiting for them (the
    /// `ground_cover` entry of the frame statistics).
    pub fn named(&self) -> std::collections::BTreeMap<String, f64> {
        [
            ("tiles_produced", self.produced as f64),
            ("gpu_bytes", self.bytes() as f64),
            ("cells", (self.cells * self.cells) as f64),
            ("texels_per_tile", self.layout.texels as f64),
            ("wait_ms", self.wait_ms),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect()
    }

    /// Per frame: asks for the tiles of the window around `eye`, waits for those within
    /// `range` that the camera may see, and uploads them and, paced by the eye's speed, the
    /// others that arrived (a row of the window arrives at once when the eye enters a tile).
    pub(crate) fn prepare(&mut self, gpu: &Gpu, eye: Vec3, range: f32, camera: &Frustum) {
        if self.producer.is_none() {
            return;
        }
        let range = range.min(self.reach_m);
        let t = self.layout.tile_m;
        let n = self.cells as i32;
        let lo = [0, 1].map(|a| {
            let e = ((if a == 0 { eye.x } else { eye.z }) / t).floor() as i32;
            (e - n / 2).clamp(0, (self.tiles[a] - n).max(0))
        });
        let p = Vec2::new(eye.x, eye.z);
        // The first frame waits for the whole window (as the world's ring): startup ends with
        // nothing left to upload until the eye moves.
        let first = self.last_eye.is_none();
        let step = self.last_eye.map_or(0.0, |l| l.distance(p));
        self.last_eye = Some(p);
        if self.arrived.is_empty() && self.filled_around(lo) {
            self.wait_ms = 0.0;
            return;
        }
        let Some(producer) = &mut self.producer else {
            return;
        };
        let queued: std::collections::HashSet<TileKey> =
            self.arrived.iter().map(|a| a.key).collect();
        let mut wanted = Vec::new();
        for z in lo[1]..(lo[1] + n).min(self.tiles[1]) {
            for x in lo[0]..(lo[0] + n).min(self.tiles[0]) {
                let key = TileKey { x, z };
                if self.filled[cell(key, n)] != Some(key) {
                    wanted.push((key.distance(p, t), key));
                }
            }
        }
        producer.request(wanted.iter().copied().filter(|w| !queued.contains(&w.1)));
        let keep: std::collections::HashSet<TileKey> = wanted.iter().map(|w| w.1).collect();
        producer.cancel(|k| keep.contains(&k));
        let needed = |k: TileKey| {
            let min = Vec3::new(k.x as f32 * t, -1e5, k.z as f32 * t);
            first
                || k.distance(p, t) <= range
                    && camera.intersects_box(min, min + Vec3::new(t, 2e5, t))
        };
        let must: Vec<TileKey> = wanted
            .iter()
            .map(|w| w.1)
            .filter(|&k| !queued.contains(&k) && needed(k))
            .collect();
        self.arrived.extend(producer.finished());
        let start = std::time::Instant::now();
        if !must.is_empty() {
            self.arrived.extend(producer.wait_for(&must));
        }
        self.wait_ms = start.elapsed().as_secs_f64() * 1e3;
        self.arrived.retain(|a| keep.contains(&a.key));
        // Those the camera needs now, then the ring nearest first, at the eye's pace (at rest,
        // all: a tile of cover is a 64 KiB upload, and the window's tiles arrive at the
        // workers' pace).
        let take = super::due(
            &mut self.arrived,
            |a| needed(a.key),
            |a| (a.key.distance(p, t) - range, a.texels.len() as u64 * 4),
            step,
            u64::MAX,
        );
        let batch: Vec<CoverTile> = self.arrived.drain(..take).collect();
        for tile in batch {
            self.upload(gpu, &tile);
            self.produced += 1;
        }
    }

    /// Whether every cell of the window from `lo` holds its tile.
    fn filled_around(&self, lo: [i32; 2]) -> bool {
        let n = self.cells as i32;
        (lo[1]..(lo[1] + n).min(self.tiles[1])).all(|z| {
            (lo[0]..(lo[0] + n).min(self.tiles[0]))
                .all(|x| self.filled[cell(TileKey { x, z }, n)] == Some(TileKey { x, z }))
        })
    }

    fn upload(&mut self, gpu: &Gpu, tile: &CoverTile) {
        let n = self.cells as i32;
        let c = cell(tile.key, n);
        let (cx, cz) = ((c % n as usize) as u32, (c / n as usize) as u32);
        let levels = std::iter::once(&tile.texels).chain(&tile.mips);
        for (level, texels) in levels
            .enumerate()
            .take(self.texture.mip_level_count() as usize)
        {
            let g = self.layout.texels >> level;
            gpu.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &self.texture,
                    mip_level: level as u32,
                    origin: wgpu::Origin3d {
                        x: cx * g,
                        y: cz * g,
                        z: 0,
                    },
                    aspect: wgpu::TextureAspect::All,
                },
                bytemuck::cast_slice(texels),
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(g * 4),
                    rows_per_image: Some(g),
                },
                wgpu::Extent3d {
                    width: g,
                    height: g,
                    depth_or_array_layers: 1,
                },
            );
        }
        let tag = tile.key.x as u32 + tile.key.z as u32 * 65536 + 1;
        gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &self.tags,
                mip_level: 0,
                origin: wgpu::Origin3d { x: cx, y: cz, z: 0 },
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::bytes_of(&tag),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4),
                rows_per_image: Some(1),
            },
            wgpu::Extent3d {
                width: 1,
                height: 1,
                depth_or_array_layers: 1,
            },
        );
        self.filled[c] = Some(tile.key);
    }
}

/// The atlas cell of tile `key` in an `n × n` toroidal atlas.
fn cell(key: TileKey, n: i32) -> usize {
    (key.z.rem_euclid(n) * n + key.x.rem_euclid(n)) as usize
}

fn texture_2d(
    gpu: &Gpu,
    label: &str,
    side: u32,
    format: wgpu::TextureFormat,
    levels: u32,
) -> wgpu::Texture {
    gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: side,
            height: side,
            depth_or_array_layers: 1,
        },
        mip_level_count: levels,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mips_halve_to_a_texel_a_tile_and_keep_the_mean() {
        let layout = CoverLayout::new(256.0, 5.0);
        assert_eq!(layout.texels, 128);
        assert_eq!(layout.levels(), 8);
        assert_eq!(
            CoverLayout::new(200.0, 5.0).levels(),
            3,
            "100 texels: 100, 50, 25"
        );
        let side = 8;
        let grid: Vec<[u8; 4]> = (0..side * side)
            .map(|i| [(i * 4) as u8, if i % 2 == 0 { 255 } else { 0 }, 7, 9])
            .collect();
        let half = halve(&grid, side);
        assert_eq!(half.len(), 16);
        let mean =
            |g: &[[u8; 4]], c: usize| g.iter().map(|t| t[c] as f32).sum::<f32>() / g.len() as f32;
        for c in 0..4 {
            assert!(
                (mean(&half, c) - mean(&grid, c)).abs() <= 0.5,
                "channel {c}"
            );
        }
        assert_eq!(
            half[0][1], 128,
            "a 2 × 2 of 255 and 0 averages to its middle"
        );
    }

    #[test]
    fn box_filter_keeps_the_mean_and_spreads_a_spike() {
        let e = 33;
        let mut v = vec![0.0f32; e * e];
        v[16 * e + 16] = 1.0;
        blur(&mut v, e, 3);
        let sum: f32 = v.iter().sum();
        assert!((sum - 1.0).abs() < 1e-4, "sum {sum}");
        assert!(v[16 * e + 16] > v[16 * e + 19] && v[16 * e + 19] > 0.0);
        assert_eq!(v[0], 0.0);
    }

    fn source(trees: &[(f32, f32)], slope: f32) -> Source {
        let res = 65u32;
        let size = 256.0;
        let heights = (0..res * res)
            .map(|i| (i % res) as f32 / (res - 1) as f32 * size * slope)
            .collect();
        let terrain = sylvan_scene::Terrain {
            size: [size, size],
            resolution: [res, res],
            heights,
        };
        let placed: Vec<sylvan_scene::TreeInstance> = trees
            .iter()
            .map(|&(x, z)| sylvan_scene::TreeInstance {
                position: Vec3::new(x, 0.0, z),
                height: 10.0,
                rotation: 0.3,
                species: 0,
                seed: 0,
            })
            .collect();
        let bounds = vec![crate::instances::SpeciesBounds {
            min: Vec3::new(-3.0, 0.0, -3.0),
            max: Vec3::new(3.0, 10.0, 3.0),
        }];
        Source::new(terrain, None, &placed, bounds, 128.0)
    }

    fn texel(tile: &CoverTile, x: usize, z: usize, g: usize) -> [f32; 4] {
        tile.texels[z * g + x].map(|v| v as f32 / 255.0)
    }

    /// Γ is 1 under a crown and 0 in the open; Γ̄ is Γ's mean (so Δ averages to 1, BN12
    /// eq. 10); Λ_h is the trees per m² around; n·u_z is the terrain's.
    #[test]
    fn a_tiles_cover_has_the_crowns_their_mean_the_density_and_the_slope() {
        // A 6 × 6 grid of trees 8 m apart in the middle of tile (0, 0) (128 m, 2 m texels).
        let trees: Vec<(f32, f32)> = (0..36)
            .map(|i| (44.0 + (i % 6) as f32 * 8.0, 44.0 + (i / 6) as f32 * 8.0))
            .collect();
        let src = source(&trees, 0.0);
        let layout = CoverLayout::new(128.0, 3.0);
        let g = layout.texels as usize;
        assert_eq!(g, 64);
        let tile = produce(&src, &layout, TileKey { x: 0, z: 0 });
        // Texel (22, 22) holds the trunk at (44, 44); (2, 2) is 40 m from any tree.
        assert!(
            texel(&tile, 22, 22, g)[0] > 0.95,
            "{:?}",
            texel(&tile, 22, 22, g)
        );
        assert_eq!(texel(&tile, 2, 2, g)[0], 0.0);
        // Mean Γ = mean Γ̄ over the tile (the stand lies well inside it).
        let mean = |c: usize| {
            (0..g * g)
                .map(|i| texel(&tile, i % g, i / g, g)[c])
                .sum::<f32>()
                / (g * g) as f32
        };
        let (gamma, smooth) = (mean(0), mean(1));
        assert!(
            (gamma - smooth).abs() < 0.01 * gamma.max(0.05),
            "Γ {gamma} vs Γ̄ {smooth}"
        );
        // Covered share: 36 disks of radius 3 m over the tile.
        let disks = 36.0 * std::f32::consts::PI * 9.0 / (128.0 * 128.0);
        assert!((gamma - disks).abs() < 0.1 * disks, "Γ {gamma} vs {disks}");
        // Λ_h in the middle of the stand: one tree per 64 m².
        let d = texel(&tile, 32, 32, g)[2];
        let density = d * d * LAMBDA_MAX;
        assert!((density - 1.0 / 64.0).abs() < 0.25 / 64.0, "Λ_h {density}");
        assert_eq!(texel(&tile, 2, 2, g)[3], 1.0);
        // A terrain rising 1 m per 2 m along X: n·u_z = 1/√1.25.
        let sloped = produce(&source(&trees, 0.5), &layout, TileKey { x: 0, z: 0 });
        let up = texel(&sloped, 10, 10, g)[3];
        assert!((up - 1.0 / 1.25f32.sqrt()).abs() < 0.01, "n·u_z {up}");
    }

    /// Crowns across a tile's edge are in both tiles' cover, alike (the margin gathers them).
    #[test]
    fn crowns_across_a_tile_edge_are_in_both_tiles() {
        let src = source(&[(128.5, 60.0)], 0.0);
        let layout = CoverLayout::new(128.0, 3.0);
        let g = layout.texels as usize;
        let left = produce(&src, &layout, TileKey { x: 0, z: 0 });
        let right = produce(&src, &layout, TileKey { x: 1, z: 0 });
        // The disk spans x 125.5–131.5: texel 63 of tile 0 and texel 0 of tile 1, row 30.
        assert!(texel(&left, 63, 30, g)[0] > 0.9);
        assert!(texel(&right, 0, 30, g)[0] > 0.9);
        assert!((texel(&left, 63, 30, g)[1] - texel(&right, 0, 30, g)[1]).abs() < 0.02);
    }

    #[test]
    fn cells_wrap_around() {
        assert_eq!(cell(TileKey { x: 0, z: 0 }, 4), 0);
        assert_eq!(cell(TileKey { x: 5, z: 6 }, 4), 2 * 4 + 1);
        assert_eq!(cell(TileKey { x: -1, z: 0 }, 4), 3);
    }
}
