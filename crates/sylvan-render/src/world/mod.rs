//! The tiled world and the GPU-driven frame (#15): the terrain is split into square tiles; a
//! tile's trees are produced when it first comes within range (view or shadow, plus a
//! prefetch ring) — on the GPU for a `wang` forest (`seed.rs`, BN12 §4), else on worker
//! threads — kept in one GPU pool of fixed-size pages under a memory
//! budget, and evicted, farthest first, when the budget is exceeded. Per frame the CPU culls
//! *tiles* against the camera and each cascade and lays out one instance list per (pass,
//! species); a compute pass culls the *trees* of those tiles, appends the survivors to their
//! lists and writes indirect draw arguments. Nothing per frame is per tree on the CPU, and
//! nothing at start or per frame depends on the size of the world — only on the tiles in range.
//! Even per tile a static frame does little: the wanted tiles are listed when the eye enters
//! another tile, asked for only while one is missing, and culled per pass from a contiguous
//! snapshot made when a tile is inserted or evicted (`Wanted`); the cull gets one record per
//! run of consecutive pool pages.
//!
//! This is the producer/cache design of BN12 §4 (and Proland's tile producers) applied to tree
//! instances. Deviations and limits:
//! - the grid is flat (one level): quadtree levels come with coverage tiles (BN12 shader-maps);
//! - tiles are culled on the CPU (a few hundred per frame), trees on the GPU;
//! - occlusion culling (an option, [`World::set_occlusion`]) tests the camera pass's trees
//!   against the *previous* frame's depth pyramid (`hiz.rs`): one frame late, not used after a
//!   cut;
//! - the pool and the lists are each one storage binding, so at most
//!   `max_storage_buffer_binding_size / 32` trees (4.2M on a 128 MiB limit) are resident or
//!   listed at once — a frame needing more lists only what fits and counts the rest
//!   (`trees_dropped`).

pub mod cover;
pub use pops::PopCounts;
mod cull;
mod hiz;
mod pops;
mod produce;
mod seed;

pub use cull::{Culled, IndirectDraw, ListLayout, ListRequest, MAX_SPECIES, intersect_windows};
pub use hiz::MAX_MOVE_M as OCCLUSION_MAX_MOVE_M;

use crate::RenderError;
use crate::frame::{CASCADES, CasterCull, Frustum};
use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};
pub(crate) use produce::Source;
use produce::{Producer, TileTrees};
use std::collections::HashMap;
use std::sync::Arc;
use sylvan_gpu::Gpu;
use sylvan_scene::Scene;

/// Trees per pool page (the unit tiles are allocated in; a multiple of the cull workgroup).
pub const PAGE: u32 = 256;
/// Passes the lists serve: the camera and each cascade.
pub const PASSES: usize = 1 + CASCADES;
/// How much sooner than the eye could reach them the prefetch ring's tiles are inserted
/// (see [`ring_inserts`]).
const RING_MARGIN: f32 = 1.25;
/// Frames over which the ring's tiles already in reach that no pass sees are inserted.
const SOON_FRAMES: f32 = 8.0;
/// The ring's tiles inserted per frame while the eye rests, at most (bytes): the ring fills
/// within a few frames, ready for whatever speed the eye starts at, and then a frame does
/// nothing (forest-10m: ~10 tiles a frame).
const REST_BYTES: u64 = 2 << 20;

/// Tiles of the prefetch ring seeded on the GPU per frame, at most, and batches of them in
/// flight (their results are read in a later frame, without waiting; tiles a pass sees are
/// seeded and read back at once).
const SEED_TILES_PER_FRAME: usize = 16;
const SEED_BATCHES_IN_FLIGHT: usize = 2;

/// Ring tiles seeded on the GPU, results not read yet.
struct SeedBatch {
    keys: Vec<TileKey>,
    pages: Vec<Vec<u32>>,
    pending: seed::Pending,
}

/// Trees fade out over the last 10 % of a finite `[world] tree_distance_m` (their presence,
/// as the level-of-detail cross-fades), so none pops at the edge.
pub const TREE_DISTANCE_FADE: f32 = 0.1;

/// A tile of the world grid: tile (x, z) covers `[x, x+1) × [z, z+1)` times the tile size.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, PartialOrd, Ord)]
pub struct TileKey {
    /// Column (along X).
    pub x: i32,
    /// Row (along Z).
    pub z: i32,
}

impl TileKey {
    /// The tile holding world point (x, z).
    pub fn of(x: f32, z: f32, tile_m: f32) -> Self {
        Self {
            x: (x / tile_m).floor() as i32,
            z: (z / tile_m).floor() as i32,
        }
    }

    /// Horizontal distance from `p` (x, z) to the tile's square.
    fn distance(self, p: Vec2, tile_m: f32) -> f32 {
        let min = Vec2::new(self.x as f32, self.z as f32) * tile_m;
        let max = min + Vec2::splat(tile_m);
        (p.clamp(min, max) - p).length()
    }
}

/// One tree in the pool: the instance as the vertex shaders read it, with the species in
/// `rot.w`'s bits (the cull shader writes the presence there in the lists).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug, PartialEq)]
pub(crate) struct PoolTree {
    pub base_scale: [f32; 4],
    pub rot: [f32; 4],
}

const TREE_BYTES: u64 = std::mem::size_of::<PoolTree>() as u64;

struct Resident {
    pages: Vec<u32>,
    count: u32,
    species_counts: Vec<u32>,
    min: Vec3,
    max: Vec3,
}

/// Per frame: where the camera is and which passes draw.
pub(crate) struct WorldView<'a> {
    /// Eye (world).
    pub eye: Vec3,
    /// The camera pass draws trees nearer than this (metres).
    pub far: f32,
    /// Per pass its frustum, `None` for a pass not drawn (shadows off).
    pub frustums: &'a [Option<Frustum>; PASSES],
    /// With shadows: which casters each cascade needs (the same test the GPU cull makes per
    /// tree, here per tile).
    pub casters: Option<&'a CasterCull>,
    /// The output's pixels per metre at one metre (a tree's apparent height, for the
    /// field's per-tree end: [`crate::technique::FieldEnd`]).
    pub pixels_per_metre: f32,
}

/// What the world did in the last frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WorldStats {
    /// Tiles resident in the pool.
    pub tiles_resident: u32,
    /// Tiles requested and not produced yet.
    pub tiles_pending: u32,
    /// Tiles produced since the last frame.
    pub tiles_produced: u32,
    /// Tiles inserted into the pool this frame.
    pub tiles_inserted: u32,
    /// Tiles produced and waiting to be inserted.
    pub tiles_queued: u32,
    /// Tiles the frame had to wait for (visible and missing).
    pub tiles_waited: u32,
    /// Tiles evicted this frame.
    pub tiles_evicted: u32,
    /// Tiles seeded on the GPU this frame (also counted as produced and inserted).
    pub tiles_seeded: u32,
    /// Trees resident in the pool.
    pub trees_resident: u64,
    /// Trees in the tiles the camera pass may see (the tree cull's input).
    pub trees_considered: u64,
    /// Trees drawn per pass (read back after the frame).
    pub trees_drawn: [u32; PASSES],
    /// Trees that passed the cull but did not fit a list.
    pub trees_dropped: u32,
    /// Trees in the camera's view dropped by the occlusion test (read back after the frame).
    pub trees_occluded: u32,
    /// Pool and list bytes on the GPU.
    pub gpu_bytes: u64,
    /// With the pop audit on: what it counted (read back after the frame).
    pub pops: Option<PopCounts>,
}

impl WorldStats {
    /// As named values (the `world` entry of the frame statistics).
    pub fn named(&self) -> std::collections::BTreeMap<String, f64> {
        let mut m = std::collections::BTreeMap::new();
        for (k, v) in [
            ("tiles_resident", self.tiles_resident as f64),
            ("tiles_pending", self.tiles_pending as f64),
            ("tiles_produced", self.tiles_produced as f64),
            ("tiles_inserted", self.tiles_inserted as f64),
            ("tiles_queued", self.tiles_queued as f64),
            ("tiles_waited", self.tiles_waited as f64),
            ("tiles_evicted", self.tiles_evicted as f64),
            ("tiles_seeded", self.tiles_seeded as f64),
            ("trees_resident", self.trees_resident as f64),
            ("trees_considered", self.trees_considered as f64),
            ("trees_drawn_camera", self.trees_drawn[0] as f64),
            (
                "trees_drawn_shadows",
                self.trees_drawn[1..].iter().sum::<u32>() as f64,
            ),
            ("trees_dropped", self.trees_dropped as f64),
            ("trees_occluded", self.trees_occluded as f64),
            ("gpu_bytes", self.gpu_bytes as f64),
        ] {
            m.insert(k.to_string(), v);
        }
        for (c, &n) in self.trees_drawn[1..].iter().enumerate() {
            m.insert(format!("trees_drawn_shadow{c}"), n as f64);
        }
        if let Some(p) = &self.pops {
            for (k, v) in [
                ("pops_appeared", p.appeared as f64),
                ("pops_vanished", p.vanished as f64),
                ("pops_jumped", p.jumped as f64),
                ("pops_largest", p.largest as f64),
                ("pops_step", p.step as f64),
            ] {
                m.insert(k.to_string(), v);
            }
        }
        m
    }
}

/// The tiled world: tile cache, pool, and the GPU cull that fills the per-frame lists.
pub struct World {
    settings: sylvan_scene::World,
    /// Tiles along X and Z.
    tiles: [i32; 2],
    producer: Producer<TileTrees>,
    /// The GPU seed producer (a `wang` forest; `None`: every tile from `producer`).
    seeds: Option<seed::GpuSeeds>,
    seeding: Vec<SeedBatch>,
    source: Arc<Source>,
    resident: HashMap<TileKey, Resident>,
    /// Produced, not inserted yet (see [`ring_inserts`]).
    arrived: Vec<TileTrees>,
    pool: wgpu::Buffer,
    free_pages: Vec<u32>,
    pool_pages: u32,
    max_pool_pages: u32,
    /// One cull per request (a technique, or each band of a chain).
    culls: Vec<cull::Cull>,
    requests: Vec<ListRequest>,
    stats: WorldStats,
    budget_bytes: u64,
    /// With the occlusion cull on: the previous frame's depth pyramid.
    pyramid: Option<hiz::DepthPyramid>,
    /// What the culls bind without one.
    no_pyramid: [wgpu::TextureView; 2],
    /// The tiles wanted around the eye's tile (`None` before the first frame, or after one
    /// that failed).
    wanted: Option<Wanted>,
    /// Whether a wanted tile may be missing: set when the wanted tiles change or a tile is
    /// evicted, cleared by a frame that finds every wanted tile resident. While clear, a
    /// frame asks for nothing.
    asking: bool,
    /// The producer's queue still holds tiles that are no longer wanted (its lock was busy).
    cancel_due: bool,
    /// The run records of a cull, kept between frames (no allocation per frame).
    runs_scratch: Vec<cull::GpuRun>,
    /// The changes to `resident` since the last frame's snapshot, in order (the tile, and
    /// whether it was inserted or evicted): what [`Wanted::snap`] applies.
    changed: Vec<(TileKey, bool)>,
    /// The eye's last position (horizontal): how far it moves per frame paces the ring.
    last_eye: Option<Vec2>,
    /// How far a tree's crown sphere may reach beyond its tile's square, horizontally
    /// (metres): a tile that near the range may hold trees the cull draws.
    overhang: f32,
    /// With [`World::set_pop_audit`] on: the pop audit.
    pops: Option<pops::PopAudit>,
    /// What the culls bind without it.
    no_audit: wgpu::Buffer,
}

/// The tiles within reach of any point of the eye's tile: made again only when the eye
/// enters another tile (or the reach changes), so a frame's requests cost nothing per tile
/// while the eye stays in one. Up to a tile wider than the reach from the eye itself: the
/// prefetch ring gains up to a tile on the side the eye moves away from.
struct Wanted {
    eye_tile: TileKey,
    reach: f32,
    /// Nearest the eye's tile first.
    tiles: Vec<TileKey>,
    set: std::collections::HashSet<TileKey>,
    /// The resident ones among `tiles`, as the per-pass tile cull reads them: one contiguous
    /// copy (not a hash look-up and three heap vectors per tile per frame), made when the
    /// wanted tiles change and then kept up to date tile by tile as tiles are inserted or
    /// evicted (in `tiles`' order when made; an inserted tile goes last).
    snapshot: Vec<SnapTile>,
    /// The snapshot's species counts and runs of consecutive pages (`passes`, `row` 0), tile
    /// after tile (an evicted tile's stay, unreferenced, until the snapshot is made again).
    snap_species: Vec<u32>,
    snap_runs: Vec<cull::GpuRun>,
    /// Whether the snapshot was made.
    snapped: bool,
}

/// A resident tile in [`Wanted::snapshot`].
struct SnapTile {
    key: TileKey,
    min: Vec3,
    max: Vec3,
    count: u32,
    species: std::ops::Range<usize>,
    runs: std::ops::Range<usize>,
}

impl Wanted {
    fn new(eye_tile: TileKey, reach: f32, tiles: Vec<TileKey>) -> Self {
        Self {
            eye_tile,
            reach,
            set: tiles.iter().copied().collect(),
            tiles,
            snapshot: Vec::new(),
            snap_species: Vec::new(),
            snap_runs: Vec::new(),
            snapped: false,
        }
    }

    /// Brings the snapshot up to date with `changed` (the residents' changes since the last
    /// call, which it empties): a tile at a time, or all again the first time and when the
    /// evicted tiles' records outnumber the live ones (so a frame that inserts a tile does
    /// not pay for every tile in range).
    fn snap(&mut self, resident: &HashMap<TileKey, Resident>, changed: &mut Vec<(TileKey, bool)>) {
        let live: usize = self.snapshot.iter().map(|t| t.runs.len()).sum();
        if !self.snapped || self.snap_runs.len() - live > live + 64 {
            self.snapped = true;
            changed.clear();
            self.snapshot.clear();
            self.snap_species.clear();
            self.snap_runs.clear();
            for i in 0..self.tiles.len() {
                let key = self.tiles[i];
                if let Some(r) = resident.get(&key) {
                    self.push(key, r);
                }
            }
            return;
        }
        for (key, inserted) in changed.drain(..) {
            if !self.set.contains(&key) {
                continue;
            }
            match inserted {
                true => {
                    // (Evicted again later in the log: its eviction finds it.)
                    if let Some(r) = resident.get(&key) {
                        self.push(key, r);
                    }
                }
                false => {
                    if let Some(i) = self.snapshot.iter().position(|t| t.key == key) {
                        self.snapshot.swap_remove(i);
                    }
                }
            }
        }
    }

    /// Appends resident tile `key` to the snapshot.
    fn push(&mut self, key: TileKey, r: &Resident) {
        let species = self.snap_species.len();
        self.snap_species.extend(&r.species_counts);
        let runs = self.snap_runs.len();
        // Only a tile's last page is partial, so consecutive pages make one run.
        for run in page_runs(&r.pages) {
            let first = run.start as u32 * PAGE;
            self.snap_runs.push(cull::GpuRun {
                first: r.pages[run.start] * PAGE,
                count: (r.count - first).min(run.len() as u32 * PAGE),
                passes: 0,
                row: 0,
            });
        }
        self.snapshot.push(SnapTile {
            key,
            min: r.min,
            max: r.max,
            count: r.count,
            species: species..self.snap_species.len(),
            runs: runs..self.snap_runs.len(),
        });
    }
}

impl World {
    /// A world over `scene`'s terrain and trees (`source`, shared with the ground cover);
    /// starts the tile workers. Nothing is produced until the first frame.
    pub(crate) fn new(
        gpu: &Gpu,
        scene: &Scene,
        source: Arc<Source>,
        requests: &[ListRequest],
        gpu_seeds: bool,
    ) -> Result<Self, RenderError> {
        let bounds = &source.bounds;
        let settings = scene.world;
        // The crown sphere's horizontal reach from the trunk base per metre of plant height,
        // for the tallest tree of the scene (the cull's spheres: box centre, half diagonal).
        let tallest = scene.trees.iter().map(|t| t.height).fold(
            scene.seeded.as_ref().map_or(0.0, |f| f.tallest_m()),
            f32::max,
        );
        let overhang = bounds
            .iter()
            .map(|b| {
                let c = (b.min + b.max) * 0.5;
                (Vec2::new(c.x, c.z).length() + (b.max - b.min).length() * 0.5) / b.max.y.max(1e-3)
            })
            .fold(0.0f32, f32::max)
            * tallest;
        let tile_m = settings.tile_m;
        let tiles = scene
            .terrain
            .size
            .map(|s| ((s / tile_m).ceil() as i32).max(1));
        let threads = worker_threads();
        let limits = gpu.device.limits();
        let binding = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let max_pool_pages = (binding / (TREE_BYTES * PAGE as u64)) as u32;
        // Sized up front for the trees expected within reach (the range, the ring and a tile's
        // diagonal), so that growing — a copy of the whole pool — does not hitch a flight.
        let reach = settings.tree_distance_m + settings.prefetch_m + tile_m * 1.5;
        let area = (std::f64::consts::PI * (reach as f64).powi(2))
            .min(scene.terrain.size[0] as f64 * scene.terrain.size[1] as f64);
        let world_area = scene.terrain.size[0] as f64 * scene.terrain.size[1] as f64;
        let expected = scene.trees.len() as f64
            + scene
                .seeded
                .as_ref()
                .map_or(0.0, |f| f.estimated_trees() * area / world_area.max(1.0));
        let budget_pages = settings.cache_mib as u64 * (1 << 20) / (PAGE as u64 * TREE_BYTES);
        let pool_pages = ((expected * 1.25 / PAGE as f64).ceil() as u64)
            .clamp(64, budget_pages.max(64))
            .min(max_pool_pages as u64) as u32;
        let pool = pool_buffer(gpu, pool_pages);
        let culls = requests
            .iter()
            .map(|r| cull::Cull::new(gpu, bounds, r.layout, binding))
            .collect::<Result<Vec<_>, _>>()?;
        let seeds = match (&source.seeded, gpu_seeds) {
            (Some(forest), true) => {
                seed::GpuSeeds::new(gpu, forest, &source.terrain, bounds, tile_m)
            }
            _ => None,
        };
        let worker_source = source.clone();
        Ok(Self {
            // The cache holds what the budget allows and the pool's one binding can address.
            budget_bytes: (settings.cache_mib as u64 * (1 << 20))
                .min(max_pool_pages as u64 * PAGE as u64 * TREE_BYTES),
            settings,
            tiles,
            producer: Producer::new(
                Arc::new(move |k| worker_source.produce(k)),
                threads,
                "tiles",
            ),
            seeds,
            seeding: Vec::new(),
            source,
            resident: HashMap::new(),
            arrived: Vec::new(),
            free_pages: (0..pool_pages).rev().collect(),
            pool,
            pool_pages,
            max_pool_pages,

            culls,
            requests: requests.to_vec(),
            stats: WorldStats::default(),
            pyramid: None,
            no_pyramid: hiz::placeholder(gpu),
            wanted: None,
            asking: true,
            cancel_due: false,
            runs_scratch: Vec::new(),
            changed: Vec::new(),
            last_eye: None,
            overhang,
            pops: None,
            no_audit: crate::technique::common::storage(
                gpu,
                "cull_no_audit",
                wgpu::BufferUsages::empty(),
                256,
            ),
        })
    }

    /// Turns the camera pass's occlusion cull on or off (off by default): with it, each frame
    /// drops the trees hidden behind what the previous frame drew (its depth reduced by
    /// `reduce_depth`, which the renderer calls).
    pub fn set_occlusion(&mut self, gpu: &Gpu, on: bool) {
        match (on, &self.pyramid) {
            (true, None) => self.pyramid = Some(hiz::DepthPyramid::new(gpu)),
            (false, Some(_)) => self.pyramid = None,
            _ => {}
        }
    }

    /// With the occlusion cull on: records the reduction of the frame's depth (Sylvan's own
    /// reversed-Z main target, `size` pixels, drawn from `eye` with `view_proj`) into the
    /// pyramid the next frame's cull tests against.
    pub(crate) fn reduce_depth(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        depth: &wgpu::TextureView,
        size: [u32; 2],
        view_proj: glam::Mat4,
        eye: Vec3,
    ) -> Result<(), RenderError> {
        match &mut self.pyramid {
            Some(p) => p.reduce(gpu, encoder, depth, size, view_proj, eye),
            None => Ok(()),
        }
    }

    /// Turns the pop audit on or off (off by default; see [`PopCounts`]): each frame counts
    /// the trees inside the view that appeared, vanished or jumped in presence since the last
    /// (in [`WorldStats::pops`], read back after the frame — a wait).
    pub fn set_pop_audit(&mut self, gpu: &Gpu, on: bool) {
        match (on, &self.pops) {
            (true, None) => {
                let spheres = self
                    .culls
                    .first()
                    .map_or([[0.0; 4]; cull::MAX_SPECIES], cull::Cull::species_spheres);
                self.pops = Some(pops::PopAudit::new(gpu, self.pool_pages * PAGE, spheres));
            }
            (false, Some(_)) => self.pops = None,
            _ => {}
        }
    }

    /// Last frame's statistics.
    pub fn stats(&self) -> WorldStats {
        self.stats
    }

    /// The lists and draw arguments of the last [`World::prepare`], one per request, for the
    /// techniques' draws.
    /// This frame's presence window of each request (in [`World::new`]'s order; extra or
    /// missing entries are ignored).
    pub(crate) fn set_windows(&mut self, windows: &[[f32; 4]]) {
        for (r, &w) in self.requests.iter_mut().zip(windows) {
            r.window = w;
        }
    }

    pub(crate) fn culled(&self) -> Vec<Culled<'_>> {
        self.culls.iter().map(cull::Cull::culled).collect()
    }

    /// GPU bytes held (pool, lists, arguments).
    pub fn bytes(&self) -> u64 {
        self.pool.size()
            + self.culls.iter().map(cull::Cull::bytes).sum::<u64>()
            + self.pyramid.as_ref().map_or(0, hiz::DepthPyramid::bytes)
            + self.seeds.as_ref().map_or(0, seed::GpuSeeds::bytes)
    }

    /// Per frame: requests, receives, waits for and evicts tiles, then records the cull of
    /// every tree in the tiles each pass may see into `encoder`, and the indirect arguments of
    /// `draws` (per pass).
    pub(crate) fn prepare(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        view: &WorldView<'_>,
    ) -> Result<(), RenderError> {
        let eye = Vec2::new(view.eye.x, view.eye.z);
        let range = self.settings.tree_distance_m.min(view.far);
        let mut stats = WorldStats::default();
        // 1. Ask for every tile within range plus the ring, nearest first; forget the rest.
        // Tiles the GPU can seed are planned here instead (nearest first). Only while a
        // wanted tile may be missing: once all are resident a frame asks for nothing.
        let t = self.settings.tile_m;
        // (Tiles whose trees' crowns may reach into range are within range + overhang.)
        let reach = range + self.settings.prefetch_m.max(self.overhang);
        let eye_tile = TileKey::of(eye.x, eye.y, t);
        let mut wanted = match self.wanted.take() {
            Some(w) if w.eye_tile == eye_tile && w.reach == reach => w,
            _ => {
                let tiles = tiles_around(eye_tile, reach, t, self.tiles);
                self.asking = true;
                self.cancel_due = true;
                Wanted::new(eye_tile, reach, tiles)
            }
        };
        let mut gpu_tiles = Vec::new();
        if self.asking {
            let in_flight: std::collections::HashSet<TileKey> = (self.arrived.iter())
                .map(|a| a.key)
                .chain(self.seeding.iter().flat_map(|b| b.keys.iter().copied()))
                .collect();
            let mut cpu_tiles = Vec::new();
            let mut missing = false;
            for &key in &wanted.tiles {
                if self.resident.contains_key(&key) {
                    continue;
                }
                missing = true;
                if in_flight.contains(&key) {
                    continue;
                }
                let d = key.distance(eye, t);
                match self.gpu_seeds(key) {
                    true => gpu_tiles.push((d, key)),
                    false => cpu_tiles.push((d, key)),
                }
            }
            gpu_tiles.sort_by(|a, b| a.0.total_cmp(&b.0));
            cpu_tiles.sort_by(|a, b| a.0.total_cmp(&b.0));
            self.producer.request(cpu_tiles);
            self.asking = missing;
        }
        if self.cancel_due {
            self.cancel_due = !self.producer.cancel(|k| wanted.set.contains(&k));
        }
        // 2. What arrived; then wait for tiles in range that a drawn pass sees.
        let fresh = self.producer.finished();
        stats.tiles_produced = fresh.len() as u32;
        self.arrived.extend(fresh);
        // (None missing when the frame asks for nothing: every wanted tile is resident.)
        // The first frame waits for the prefetch ring too: startup ends with every wanted tile
        // resident, so the frames after it stream nothing until the eye moves.
        let first = self.last_eye.is_none();
        let visible: std::collections::HashSet<TileKey> = match self.asking {
            true => (wanted.tiles.iter())
                .filter(|&&k| {
                    !self.resident.contains_key(&k)
                        && (first
                            || k.distance(eye, t) <= range + self.overhang
                                && self.tile_may_be_seen(k, view))
                })
                .copied()
                .collect(),
            false => Default::default(),
        };
        let must: Vec<TileKey> = visible
            .iter()
            .copied()
            .filter(|&k| !self.arrived.iter().any(|a| a.key == k))
            .collect();
        stats.tiles_waited = must.len() as u32;
        if !must.is_empty() {
            let waited = self.producer.wait_for(&must);
            stats.tiles_produced += waited.len() as u32;
            self.arrived.extend(waited);
        }
        let resident = &self.resident;
        self.arrived
            .retain(|t| wanted.set.contains(&t.key) && !resident.contains_key(&t.key));
        // 3. This frame inserts every arrived tile a pass sees, and others (the ring) nearest
        // first at the pace the eye's speed asks for, so a burst of arrivals (a ring row when
        // the eye enters a tile) is spread over the frames before the eye can reach it.
        let step = self.last_eye.map_or(0.0, |p| p.distance(eye));
        self.last_eye = Some(eye);
        let reach_now = range + self.overhang;
        let take = due(
            &mut self.arrived,
            |a| visible.contains(&a.key),
            |a| {
                let slack = a.key.distance(eye, t) - reach_now;
                (slack, page_bytes(a.trees.len() as u32))
            },
            step,
            REST_BYTES,
        );
        let incoming = (self.arrived[..take].iter())
            .map(|a| page_bytes(a.trees.len() as u32))
            .sum();
        stats.tiles_evicted = self.evict(eye, range, incoming);
        let batch: Vec<TileTrees> = self.arrived.drain(..take).collect();
        stats.tiles_inserted = batch.len() as u32;
        for tile in batch {
            self.insert(gpu, tile)?;
        }
        // 3b. GPU seeds: ring batches the GPU has finished; every planned tile a pass sees
        // (waited for), and the nearest of the ring (read in a later frame).
        stats.tiles_seeded = self.collect_seeded(gpu, false)?;
        // (Planned only when dispatched: the ring beyond this frame's share costs nothing.)
        let (seen, ring): (Vec<_>, Vec<_>) = gpu_tiles.into_iter().partition(|&(d, k)| {
            first || d <= range + self.overhang && self.tile_may_be_seen(k, view)
        });
        let plan = |tiles: &mut dyn Iterator<Item = (f32, TileKey)>, seeds: &seed::GpuSeeds| {
            tiles.map(|(_, k)| seeds.plan(k)).collect::<Vec<_>>()
        };
        if !seen.is_empty() {
            let seeds = self
                .seeds
                .as_ref()
                .expect("GPU tiles need the seed producer");
            let plans = plan(&mut seen.into_iter(), seeds);
            stats.tiles_waited += plans.len() as u32;
            stats.tiles_evicted += self.seed(gpu, eye, range, plans)?;
            stats.tiles_seeded += self.collect_seeded(gpu, true)?;
        }
        if !ring.is_empty() && self.seeding.len() < SEED_BATCHES_IN_FLIGHT {
            let seeds = self
                .seeds
                .as_ref()
                .expect("GPU tiles need the seed producer");
            let plans = plan(&mut ring.into_iter().take(SEED_TILES_PER_FRAME), seeds);
            stats.tiles_evicted += self.seed(gpu, eye, range, plans)?;
        }
        stats.tiles_produced += stats.tiles_seeded;
        stats.tiles_inserted += stats.tiles_seeded;
        // 4. Tiles per pass → pages and list capacities (per request: the tiles reaching
        // into its band); the GPU culls the trees.
        let fade_start = if self.settings.tree_distance_m.is_finite() {
            range * (1.0 - TREE_DISTANCE_FADE)
        } else {
            f32::INFINITY
        };
        wanted.snap(&self.resident, &mut self.changed);
        let mut seen: Vec<(&SnapTile, u32, f32, f32)> = Vec::new();
        for r in &wanted.snapshot {
            // The tile's trees' spheres against the range, as the cull tests each tree (its
            // square's distance would drop trees whose crowns reach into range).
            if box_distance(view.eye, r.min, r.max) >= range {
                continue;
            }
            let mut mask = 0u32;
            for (p, f) in view.frustums.iter().enumerate() {
                let Some(f) = f else { continue };
                let centre = (r.min + r.max) * 0.5;
                let radius = (r.max - r.min).length() * 0.5;
                let needed = match (p, view.casters) {
                    (0, _) => box_distance(view.eye, r.min, r.max) < range,
                    (_, Some(c)) => c.keeps(p - 1, centre, radius),
                    (_, None) => true,
                };
                if f.intersects_box(r.min, r.max) && needed {
                    mask |= 1 << p;
                }
            }
            if mask == 0 {
                continue;
            }
            if mask & 1 != 0 {
                stats.trees_considered += r.count as u64;
            }
            let near = box_distance(view.eye, r.min, r.max);
            let far = (r.max - r.min).length() + near;
            seen.push((r, mask, near, far));
        }
        let pyramid = match &self.pyramid {
            Some(p) => p.for_frame(view.eye),
            None => hiz::PyramidUse::none([&self.no_pyramid[0], &self.no_pyramid[1]]),
        };
        if let Some(p) = &mut self.pops {
            p.resize(gpu, encoder, self.pool_pages * PAGE);
        }
        let audit = match &self.pops {
            Some(p) => (&p.drawn, true),
            None => (&self.no_audit, false),
        };
        for (request, cull) in self.requests.iter().zip(&mut self.culls) {
            let [w0, _, _, w3] = request.window;
            let groups = cull.groups();
            let mut runs = std::mem::take(&mut self.runs_scratch);
            runs.clear();
            let mut rows = 0;
            let mut capacity = vec![0u32; PASSES * groups];
            for &(r, mask, near, far) in &seen {
                if far < w0 || near > w3 {
                    continue;
                }
                for p in (0..PASSES).filter(|p| mask & (1 << p) != 0) {
                    for (s, &n) in wanted.snap_species[r.species.clone()].iter().enumerate() {
                        let group = if groups == 1 { 0 } else { s };
                        capacity[p * groups + group] += n;
                    }
                }
                for &run in &wanted.snap_runs[r.runs.clone()] {
                    runs.push(cull::GpuRun {
                        passes: mask,
                        row: rows,
                        ..run
                    });
                    rows += run.count.div_ceil(PAGE);
                }
            }
            cull.record(
                gpu,
                encoder,
                &self.pool,
                &cull::FrameCull {
                    eye: view.eye,
                    far: range,
                    fade_start,
                    window: request.window,
                    frustums: view.frustums,
                    casters: view.casters,
                    runs: &runs,
                    rows,
                    pool_generation: self.pool_pages as u64,
                    capacity: &capacity,
                    draws: &request.draws,
                    pyramid: &pyramid,
                    audit,
                    field_end: request
                        .field_end
                        .map_or([0.0; 4], |e| e.gpu_row(view.pixels_per_metre)),
                },
            )?;
            self.runs_scratch = runs;
        }
        if let Some(p) = &mut self.pops {
            // The narrowest fade a tree's presence follows: the tree distance's, or a band's
            // ramp.
            let mut fade = range * TREE_DISTANCE_FADE;
            for r in &self.requests {
                let [w0, w1, w2, w3] = r.window;
                for width in [w1 - w0, w3 - w2] {
                    if width > 0.0 && width < 1e29 {
                        fade = fade.min(width);
                    }
                }
            }
            let camera = view.frustums[0].as_ref().map(|f| (f, view.eye));
            p.record(gpu, encoder, &self.pool, camera, fade);
        }
        self.wanted = Some(wanted);
        stats.tiles_resident = self.resident.len() as u32;
        stats.tiles_queued = self.arrived.len() as u32;
        stats.tiles_pending = self.producer.pending() as u32;
        stats.trees_resident = self.resident.values().map(|r| r.count as u64).sum();
        stats.gpu_bytes = self.bytes();
        self.stats = stats;
        Ok(())
    }

    /// After the frame's submission has completed: reads the lists' counts back.
    pub(crate) fn finish_frame(&mut self, gpu: &Gpu) -> Result<(), RenderError> {
        self.stats.trees_drawn = [0; PASSES];
        self.stats.trees_dropped = 0;
        self.stats.trees_occluded = 0;
        for cull in &mut self.culls {
            let groups = cull.groups();
            let counts = cull.read_counts(gpu)?;
            for (i, &(n, cap)) in counts.iter().enumerate() {
                self.stats.trees_drawn[i / groups] += n.min(cap);
                self.stats.trees_dropped += n.saturating_sub(cap);
            }
            self.stats.trees_occluded += cull.occluded();
        }
        if let Some(p) = &mut self.pops {
            self.stats.pops = Some(p.finish(gpu)?);
        }
        Ok(())
    }

    /// Lists per pass of request `request`.
    pub(crate) fn groups(&self, request: usize) -> usize {
        self.culls[request].groups()
    }

    /// Trees listed in (pass, group) of request `request` in the last frame (after
    /// [`World::finish_frame`]).
    pub(crate) fn listed(&self, request: usize, pass: usize, group: usize) -> u32 {
        let cull = &self.culls[request];
        cull.listed()[pass * cull.groups() + group]
    }

    fn tile_may_be_seen(&self, key: TileKey, view: &WorldView<'_>) -> bool {
        // The tile's column, from below the lowest terrain to above the tallest tree, widened
        // by the crowns' overhang: a conservative box until its trees are known.
        let t = self.settings.tile_m;
        let pad = Vec3::splat(self.overhang.max(50.0));
        let min = Vec3::new(key.x as f32 * t, -1e5, key.z as f32 * t) - pad;
        let max = Vec3::new((key.x + 1) as f32 * t, 1e5, (key.z + 1) as f32 * t) + pad;
        view.frustums
            .iter()
            .flatten()
            .any(|f| f.intersects_box(min, max))
    }

    /// Whether the GPU seeds tile `key`: a `wang` forest, no placed trees in the tile and no
    /// fixed tree near it.
    fn gpu_seeds(&self, key: TileKey) -> bool {
        self.seeds
            .as_ref()
            .is_some_and(|s| !self.source.placed.contains_key(&key) && s.accepts(key))
    }

    /// Seeds `plans` on the GPU: room for their candidates (evicting), pages, one dispatch
    /// ([`World::collect_seeded`] makes them resident). Returns the tiles evicted.
    fn seed(
        &mut self,
        gpu: &Gpu,
        eye: Vec2,
        range: f32,
        plans: Vec<seed::SeedPlan>,
    ) -> Result<u32, RenderError> {
        let incoming = plans.iter().map(|p| page_bytes(p.candidates)).sum();
        let evicted = self.evict(eye, range, incoming);
        let mut pages = Vec::with_capacity(plans.len());
        for p in &plans {
            pages.push(self.alloc_pages(gpu, p.candidates)?);
        }
        let seeds = self
            .seeds
            .as_ref()
            .expect("plans come from the seed producer");
        let pending = seeds.dispatch(gpu, &self.pool, &plans, &pages);
        self.seeding.push(SeedBatch {
            keys: plans.iter().map(|p| p.key).collect(),
            pages,
            pending,
        });
        Ok(evicted)
    }

    /// Makes the tiles of finished seed batches resident (every batch, waiting for the GPU,
    /// when `wait`), freeing the pages their trees did not fill; returns how many.
    fn collect_seeded(&mut self, gpu: &Gpu, wait: bool) -> Result<u32, RenderError> {
        let mut n = 0;
        let mut i = 0;
        while i < self.seeding.len() {
            let results = match wait {
                true => Some(self.seeding[i].pending.finish(gpu)?),
                false => self.seeding[i].pending.poll(gpu)?,
            };
            let Some(results) = results else {
                i += 1;
                continue;
            };
            let batch = self.seeding.remove(i);
            for ((key, mut pages), r) in batch.keys.into_iter().zip(batch.pages).zip(results) {
                self.free_pages
                    .extend(pages.drain(r.count.div_ceil(PAGE) as usize..).rev());
                self.changed.push((key, true));
                self.resident.insert(
                    key,
                    Resident {
                        pages,
                        count: r.count,
                        species_counts: r.species_counts,
                        min: r.min,
                        max: r.max,
                    },
                );
                n += 1;
            }
        }
        Ok(n)
    }

    /// Pages for `n` trees (growing the pool if it must).
    fn alloc_pages(&mut self, gpu: &Gpu, n: u32) -> Result<Vec<u32>, RenderError> {
        let need = n.div_ceil(PAGE) as usize;
        while self.free_pages.len() < need {
            self.grow_pool(gpu, need)?;
        }
        Ok(take_pages(&mut self.free_pages, need))
    }

    fn insert(&mut self, gpu: &Gpu, tile: TileTrees) -> Result<(), RenderError> {
        if self.resident.contains_key(&tile.key) {
            return Ok(());
        }
        let n = tile.trees.len() as u32;
        let pages = self.alloc_pages(gpu, n)?;
        // One write per run of consecutive pages (usually the whole tile).
        for run in page_runs(&pages) {
            let chunk =
                &tile.trees[run.start * PAGE as usize..(run.end * PAGE as usize).min(n as usize)];
            gpu.queue.write_buffer(
                &self.pool,
                pages[run.start] as u64 * PAGE as u64 * TREE_BYTES,
                bytemuck::cast_slice(chunk),
            );
        }
        self.changed.push((tile.key, true));
        self.resident.insert(
            tile.key,
            Resident {
                pages,
                count: n,
                species_counts: tile.species_counts,
                min: tile.min,
                max: tile.max,
            },
        );
        Ok(())
    }

    /// Doubles the pool (or more, for `need` free pages), copying what it holds.
    fn grow_pool(&mut self, gpu: &Gpu, need: usize) -> Result<(), RenderError> {
        let want = (self.pool_pages * 2).max(self.pool_pages + need as u32);
        let pages = want.min(self.max_pool_pages);
        if pages <= self.pool_pages {
            return Err(RenderError::Gpu(sylvan_gpu::GpuError::Limit {
                what: "tree pool (trees resident at once)".into(),
                needed: (self.pool_pages as u64 + need as u64) * PAGE as u64 * TREE_BYTES,
                limit: self.max_pool_pages as u64 * PAGE as u64 * TREE_BYTES,
                fix: "lower [world] tree_distance_m or the density".into(),
            }));
        }
        let bigger = pool_buffer(gpu, pages);
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("pool_grow"),
            });
        enc.copy_buffer_to_buffer(&self.pool, 0, &bigger, 0, self.pool.size());
        // Submitted now: writes queued before it land in the old pool and are copied; later
        // writes go to the new one.
        gpu.queue.submit([enc.finish()]);
        self.free_pages.extend((self.pool_pages..pages).rev());
        self.pool = bigger;
        self.pool_pages = pages;
        Ok(())
    }

    fn resident_bytes(&self) -> u64 {
        (self.pool_pages - self.free_pages.len() as u32) as u64 * PAGE as u64 * TREE_BYTES
    }

    /// Evicts the farthest tiles out of `range` until `incoming` more bytes fit the pool as it
    /// is (so the pool grows — a copy of all of it, a hitch — only for tiles in range), and
    /// never past the budget.
    fn evict(&mut self, eye: Vec2, range: f32, incoming: u64) -> u32 {
        let limit = self
            .budget_bytes
            .min(self.pool_pages as u64 * PAGE as u64 * TREE_BYTES);
        if self.resident_bytes() + incoming <= limit {
            return 0;
        }
        let t = self.settings.tile_m;
        let mut far: Vec<(f32, TileKey)> = self
            .resident
            .keys()
            .map(|&k| (k.distance(eye, t), k))
            .filter(|&(d, _)| d > range + self.overhang)
            .collect();
        far.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut evicted = 0;
        for (_, key) in far {
            if self.resident_bytes() + incoming <= limit {
                break;
            }
            if let Some(r) = self.resident.remove(&key) {
                self.free_pages.extend(r.pages);
                self.changed.push((key, false));
                evicted += 1;
            }
        }
        // An evicted tile may still be wanted (the prefetch ring): ask again.
        self.asking |= evicted > 0;
        evicted
    }
}

/// Orders `arrived` for this frame — those a pass `needed` now first, then the ring nearest
/// first by the `slack` (how far the eye is from needing it, and its bytes) — and says how
/// many of them to take: every one needed now, and the ring's at [`ring_inserts`]' pace.
/// Shared by the world's tiles and the ground cover's.
pub(crate) fn due<T>(
    arrived: &mut [T],
    needed: impl Fn(&T) -> bool,
    slack: impl Fn(&T) -> (f32, u64),
    step_m: f32,
    rest_bytes: u64,
) -> usize {
    arrived.sort_by_cached_key(|a| (!needed(a), ordered(slack(a).0)));
    let now = arrived.iter().take_while(|a| needed(a)).count();
    let ring: Vec<(f32, u64)> = arrived[now..].iter().map(&slack).collect();
    now + ring_inserts(&ring, step_m, rest_bytes)
}

/// An `f32` as a key that sorts as the number does (`total_cmp`'s order).
fn ordered(x: f32) -> i32 {
    let b = x.to_bits() as i32;
    b ^ (((b >> 31) as u32) >> 1) as i32
}

/// How many of the prefetch ring's arrived tiles a frame inserts: `queue[i]` is how far the
/// eye is from making the `i`-th (nearest first) a tile a pass sees and its bytes, `step_m`
/// how far the eye moved since the last frame. While it moves: the least constant pace that
/// inserts each [`RING_MARGIN`] times sooner than the eye could reach it, at least one a frame
/// — the row that arrives when the eye enters a tile is spread over the frames it takes to
/// cross that tile instead of landing in a few (each tile is a copy of its trees to the GPU,
/// ~40 µs on this machine: BENCHMARKS "Streaming"). At rest: `rest_bytes` a frame.
pub(crate) fn ring_inserts(queue: &[(f32, u64)], step_m: f32, rest_bytes: u64) -> usize {
    if step_m <= 0.0 {
        let mut bytes = 0;
        let n = (queue.iter())
            .take_while(|q| {
                bytes += q.1;
                bytes <= rest_bytes
            })
            .count();
        return n.max(1).min(queue.len());
    }
    let mut take = 1;
    for (i, &(slack, _)) in queue.iter().enumerate() {
        // Frames before the eye may reach the tile, at this pace, by the margin. A tile in
        // reach already that no pass sees (behind the camera, at the start or after a jump)
        // is needed when the camera turns: within a few frames.
        let frames = match slack > 0.0 {
            true => slack / (RING_MARGIN * step_m),
            false => SOON_FRAMES,
        };
        take = take.max(((i + 1) as f32 / frames.max(1.0)).ceil() as usize);
    }
    take.min(queue.len())
}

/// The tiles of a `tiles[0] × tiles[1]` grid of `tile_m` squares within `reach`
/// (horizontal) of some point of tile `at`, nearest `at`'s centre first.
fn tiles_around(at: TileKey, reach: f32, tile_m: f32, tiles: [i32; 2]) -> Vec<TileKey> {
    let r = (reach / tile_m).min(1e6).ceil() as i32;
    let mut out = Vec::new();
    for z in (at.z - r).max(0)..=(at.z + r).min(tiles[1] - 1) {
        for x in (at.x - r).max(0)..=(at.x + r).min(tiles[0] - 1) {
            // The gap between the two squares along each axis.
            let gap = |a: i32, b: i32| ((a - b).abs() - 1).max(0) as f32 * tile_m;
            let d = Vec2::new(gap(x, at.x), gap(z, at.z)).length();
            if d <= reach {
                let c = Vec2::new((x - at.x) as f32, (z - at.z) as f32);
                out.push((c.length_squared(), TileKey { x, z }));
            }
        }
    }
    out.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    out.into_iter().map(|(_, k)| k).collect()
}

/// The runs of consecutive page numbers in `pages` (index ranges into it), in order.
fn page_runs(pages: &[u32]) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
    let mut i = 0;
    std::iter::from_fn(move || {
        if i >= pages.len() {
            return None;
        }
        let start = i;
        i += 1;
        while i < pages.len() && pages[i] == pages[i - 1] + 1 {
            i += 1;
        }
        Some(start..i)
    })
}

/// Tile workers per producer: the cores but one (the render thread's), 1 to 8.
pub(crate) fn worker_threads() -> usize {
    std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .saturating_sub(1)
        .clamp(1, 8)
}

/// Takes `need` pages from `free` (any order), consecutive where it can: the lowest run of at
/// least `need` consecutive free pages, else the lowest pages. A tile in consecutive pages is
/// one upload; scattered over the holes evictions leave, it was one per run, and the frame's
/// CPU time grew with the fragmentation (up to 29 writes and 4 ms for a tile).
fn take_pages(free: &mut Vec<u32>, need: usize) -> Vec<u32> {
    if need == 0 {
        return Vec::new();
    }
    // Descending, so the lowest pages are at the end (popped first).
    free.sort_unstable_by(|a, b| b.cmp(a));
    let n = free.len();
    // Runs are maximal stretches of consecutive values (descending in `free`).
    let mut end = n;
    while end > 0 {
        let mut start = end - 1;
        while start > 0 && free[start - 1] == free[start] + 1 {
            start -= 1;
        }
        if end - start >= need {
            // The lowest `need` pages of this run: free[end - need..end], ascending once reversed.
            let mut taken: Vec<u32> = free.drain(end - need..end).collect();
            taken.reverse();
            return taken;
        }
        end = start;
    }
    (0..need)
        .map(|_| free.pop().expect("enough pages"))
        .collect()
}

fn pool_buffer(gpu: &Gpu, pages: u32) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("tree_pool"),
        size: (pages.max(1) as u64) * PAGE as u64 * TREE_BYTES,
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

/// Pool bytes of `n` trees in whole pages.
fn page_bytes(n: u32) -> u64 {
    n.div_ceil(PAGE) as u64 * PAGE as u64 * TREE_BYTES
}

/// Distance from `p` to the box (0 inside).
fn box_distance(p: Vec3, min: Vec3, max: Vec3) -> f32 {
    (p.clamp(min, max) - p).length()
}

#[cfg(test)]
mod tests {
    use super::{
        REST_BYTES, Resident, TileKey, Wanted, page_runs, ring_inserts, take_pages, tiles_around,
    };
    use glam::{Vec2, Vec3};
    use std::collections::HashMap;

    /// A snapshot's tile as the cull reads it: key, trees, species counts, runs.
    type Snapped = (TileKey, u32, Vec<u32>, Vec<(u32, u32)>);

    /// The snapshot as the cull reads it, in key order.
    fn snapshot_of(w: &Wanted) -> Vec<Snapped> {
        let mut v: Vec<_> = (w.snapshot.iter())
            .map(|t| {
                let runs = w.snap_runs[t.runs.clone()].iter();
                (
                    t.key,
                    t.count,
                    w.snap_species[t.species.clone()].to_vec(),
                    runs.map(|r| (r.first, r.count)).collect(),
                )
            })
            .collect();
        v.sort_by_key(|t| (t.0.x, t.0.z));
        v
    }

    #[test]
    fn the_snapshot_kept_tile_by_tile_is_the_one_made_again() {
        let tiles: Vec<TileKey> = (0..64).map(|i| TileKey { x: i % 8, z: i / 8 }).collect();
        let mut kept = Wanted::new(tiles[0], 1000.0, tiles.clone());
        let mut resident: HashMap<TileKey, Resident> = HashMap::new();
        let mut changed = Vec::new();
        // A deterministic walk of inserts and evictions (some of tiles not wanted, some
        // inserted and evicted between two frames), a snapshot after each frame.
        let mut state = 12345u32;
        let mut next_page = 0u32;
        for frame in 0..300 {
            for _ in 0..(frame % 5) {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let key = TileKey {
                    x: (state >> 8) as i32 % 9,
                    z: (state >> 16) as i32 % 8,
                };
                if resident.remove(&key).is_some() {
                    changed.push((key, false));
                } else {
                    let count = 1 + (state >> 4) % 900;
                    let pages: Vec<u32> = (0..count.div_ceil(super::PAGE))
                        .map(|i| next_page + if i == 1 { 7 } else { i })
                        .collect();
                    next_page += 16;
                    let r = Resident {
                        pages,
                        count,
                        species_counts: vec![count / 2, count - count / 2],
                        min: Vec3::ZERO,
                        max: Vec3::ONE,
                    };
                    resident.insert(key, r);
                    changed.push((key, true));
                }
            }
            kept.snap(&resident, &mut changed);
            assert!(changed.is_empty());
            let mut fresh = Wanted::new(tiles[0], 1000.0, tiles.clone());
            fresh.snap(&resident, &mut Vec::new());
            assert_eq!(snapshot_of(&kept), snapshot_of(&fresh), "frame {frame}");
        }
        // Stale records are dropped once they outnumber the live ones.
        let live: usize = kept.snapshot.iter().map(|t| t.runs.len()).sum();
        assert!(kept.snap_runs.len() <= 2 * live + 64 + 16);
    }

    #[test]
    fn the_ring_is_inserted_before_the_eye_reaches_it_and_spread_over_the_frames() {
        // At rest: 2 MiB a frame, at least one.
        assert_eq!(ring_inserts(&[(300.0, 200 << 10); 29], 0.0, REST_BYTES), 10);
        assert_eq!(ring_inserts(&[(300.0, 4 << 20); 3], 0.0, REST_BYTES), 1);
        assert_eq!(ring_inserts(&[], 10.0, REST_BYTES), 0);
        // In reach already but not seen (behind the camera): over a few frames.
        assert_eq!(ring_inserts(&[(-5.0, 1); 24], 10.0, REST_BYTES), 3);
        // A row of 29 arriving 240–490 m ahead, every few frames, at 10 and 100 m a frame:
        // no tile is reached before it is inserted, and no frame inserts much more than the
        // average.
        for step in [10.0f32, 100.0] {
            let mut queue: Vec<(f32, u64)> = Vec::new();
            let (mut most, mut total, frames) = (0, 0, 400);
            for frame in 0..frames {
                if frame % (256.0 / step).ceil() as usize == 0 {
                    queue.extend((0..29).map(|i| (240.0 + 250.0 * i as f32 / 28.0, 1)));
                }
                let take = ring_inserts(&queue, step, REST_BYTES);
                queue.drain(..take);
                most = most.max(take);
                total += take;
                for (s, _) in &mut queue {
                    *s -= step;
                    assert!(*s > 0.0, "reached before inserted at {step} m a frame");
                }
            }
            let mean = total as f32 / frames as f32;
            assert!(
                (most as f32) < 3.0 * mean.max(1.0),
                "{most} vs {mean} at {step} m a frame"
            );
        }
    }

    #[test]
    fn the_tiles_around_the_eye_s_tile_hold_every_tile_within_reach_of_the_eye() {
        let (t, grid, reach) = (256.0, [40, 30], 1100.0);
        let at = TileKey { x: 3, z: 20 };
        let around = tiles_around(at, reach, t, grid);
        let set: std::collections::HashSet<TileKey> = around.iter().copied().collect();
        assert_eq!(set.len(), around.len(), "no tile twice");
        assert_eq!(around[0], at, "the eye's tile first");
        // Eyes over the tile (corners, edges, inside): every tile within reach of one is there.
        let mut widest = 0.0f32;
        for i in 0..=8 {
            for j in 0..=8 {
                let eye = Vec2::new(3.0 + i as f32 / 8.0, 20.0 + j as f32 / 8.0) * t;
                for z in 0..grid[1] {
                    for x in 0..grid[0] {
                        let k = TileKey { x, z };
                        let d = k.distance(eye, t);
                        if d <= reach {
                            assert!(set.contains(&k), "{k:?} at {d} m of {eye}");
                        }
                    }
                }
            }
        }
        // And nothing farther than reach from every point of the tile.
        for k in &around {
            let d = (0..=8)
                .flat_map(|i| (0..=8).map(move |j| (i, j)))
                .map(|(i, j)| {
                    k.distance(
                        Vec2::new(3.0 + i as f32 / 8.0, 20.0 + j as f32 / 8.0) * t,
                        t,
                    )
                })
                .fold(f32::INFINITY, f32::min);
            assert!(d <= reach + 1e-3, "{k:?} is {d} m from the tile");
            widest = widest.max(d);
        }
        assert!(widest > reach - t, "the reach is used");
        // Clipped to the grid.
        assert!(
            around
                .iter()
                .all(|k| k.x >= 0 && k.z >= 0 && k.x < 40 && k.z < 30)
        );
    }

    #[test]
    fn page_runs_split_where_pages_stop_being_consecutive() {
        let runs: Vec<_> = page_runs(&[4, 5, 6, 9, 2, 3, 8]).collect();
        assert_eq!(runs, vec![0..3, 3..4, 4..6, 6..7]);
        assert_eq!(page_runs(&[]).count(), 0);
    }

    #[test]
    fn pages_are_taken_consecutive_where_a_run_is_long_enough() {
        // Holes of 2, 3 and 5 pages.
        let mut free = vec![9, 1, 20, 2, 21, 22, 30, 31, 32, 33, 34];
        assert_eq!(take_pages(&mut free, 3), vec![20, 21, 22]);
        assert_eq!(take_pages(&mut free, 4), vec![30, 31, 32, 33]);
        // No run of 4 left: the lowest pages.
        assert_eq!(take_pages(&mut free, 4), vec![1, 2, 9, 34]);
        assert!(free.is_empty());
        assert!(take_pages(&mut free, 0).is_empty());
    }
}
