//! BN12 §4's GPU seed producer: the trees of a `wang` forest's terrain tile, thinned on the GPU
//! straight into the tile's pool pages (`seed.wgsl`). The CPU lists the tile's candidate runs
//! ([`SeededForest::candidate_runs`], a few dozen per tile), counts the candidates to allocate
//! pages, and reads back per tile the count, the count per species and the bounds the tile cull
//! needs; the per-tree work (hashing, density lookups, thinning, heights) runs on the GPU and
//! gives the CPU producer's records, in its order ([`super::produce::Source::produce`]; equal up
//! to f32 rounding of the bilinear lookups and `sin`/`cos`).
//!
//! Deviations from BN12 §4: the candidates are Poisson-disk Wang tiles' points thinned by
//! hashed numbers (the CPU's `wang` placement) rather than BN12's precomputed seed textures;
//! tiles with placed trees, or near a fixed tree the seeds must keep clear of, stay on the CPU
//! producer (a spatial query the shader does not make). The results of tiles a pass sees are
//! read back in their frame (one short wait); ring tiles' a frame or two later, without waiting
//! ([`Pending::poll`]). [`crate::Seeds::Auto`] uses it on hardware adapters only: on a software
//! rasteriser the compute pass shares the tile workers' cores (BENCHMARKS "A real GPU").

use super::{PAGE, TileKey};
use crate::RenderError;
use crate::instances::SpeciesBounds;
use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};
use std::sync::Arc;
use sylvan_gpu::Gpu;
use sylvan_scene::{CandidateRun, Density, SeededForest, Terrain};
use wgpu::util::DeviceExt;

/// Most species layouts the shader's uniform holds.
const MAX_LAYOUTS: usize = 64;
/// Wang tiles (`WangSet` has 16).
const WANG_TILES: usize = 16;
/// u32s per job result: count, min xyz, max xyz, then one count per layout.
const RESULT_HEAD: usize = 7;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuLayout {
    info: [u32; 4],
    density_height: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuParams {
    seed_info: [u32; 4],
    rho_size: [f32; 4],
    terrain: [f32; 4],
    terrain_info: [u32; 4],
    tile_start: [u32; 20],
    layouts: [GpuLayout; MAX_LAYOUTS],
    spheres: [[f32; 4]; MAX_LAYOUTS],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuJob {
    info: [u32; 4],
    rect: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuRun {
    info: [u32; 4],
    hash_origin: [u32; 4],
}

/// A tile the GPU will seed: its candidate runs and how many candidates lie in it.
pub(crate) struct SeedPlan {
    pub key: TileKey,
    runs: Vec<CandidateRun>,
    min: Vec2,
    max: Vec2,
    /// Candidates in the tile (an upper bound of its trees: pages to allocate).
    pub candidates: u32,
}

/// What the GPU made of one tile.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Seeded {
    pub count: u32,
    pub species_counts: Vec<u32>,
    pub min: Vec3,
    pub max: Vec3,
}

/// The seed producer's pipeline and the forest's static data on the GPU.
pub(crate) struct GpuSeeds {
    forest: Arc<SeededForest>,
    tile_m: f32,
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    points: wgpu::Buffer,
    data: wgpu::Buffer,
    /// Species of each layout (the result's per-layout counts are summed per species).
    layout_species: Vec<usize>,
    species: usize,
    bytes: u64,
}

impl GpuSeeds {
    /// The producer for `forest` over `terrain`, or `None` when its trees cannot be seeded on
    /// the GPU (not `wang`, more than [`MAX_LAYOUTS`] layouts, or data over a binding).
    pub fn new(
        gpu: &Gpu,
        forest: &Arc<SeededForest>,
        terrain: &Terrain,
        bounds: &[SpeciesBounds],
        tile_m: f32,
    ) -> Option<Self> {
        let set = forest.wang()?;
        let layouts = forest.layouts();
        if layouts.is_empty()
            || layouts.len() > MAX_LAYOUTS
            || layouts.iter().any(|l| l.species as usize >= bounds.len())
        {
            return None;
        }
        let mut points: Vec<[f32; 2]> = Vec::new();
        let mut tile_start = [0u32; 20];
        for (t, start) in tile_start.iter_mut().take(WANG_TILES).enumerate() {
            *start = points.len() as u32;
            points.extend(set.points(t).iter().map(|p| [p.x, p.y]));
        }
        tile_start[WANG_TILES] = points.len() as u32;
        let mut data: Vec<f32> = Vec::new();
        let mut gl = [GpuLayout::zeroed(); MAX_LAYOUTS];
        let mut spheres = [[0.0f32; 4]; MAX_LAYOUTS];
        for (i, l) in layouts.iter().enumerate() {
            let b = &bounds[l.species as usize];
            let (first, cols, rows, scale) = match &l.density {
                Density::PerHectare(d) => (0, 0, 0, d * 1e-4),
                Density::Map { map, max_per_ha } => {
                    let first = data.len() as u32;
                    data.extend_from_slice(&map.values);
                    let [c, r] = map.resolution;
                    (first, c.max(1), r.max(1), max_per_ha * 1e-4)
                }
            };
            // `Density::per_m2`: a map of one row or column is its first value everywhere;
            // else bilinear over at least 2 × 2 samples.
            let (cols, rows) = if cols == 1 || rows == 1 {
                (1, 1)
            } else {
                (cols, rows)
            };
            let maxy = b.max.y.max(1e-3);
            gl[i] = GpuLayout {
                info: [l.species, first, cols, rows],
                density_height: [scale, l.height_m[0], l.height_m[1], 1.0 / maxy],
            };
            let c = (b.min + b.max) * 0.5;
            spheres[i] = [c.x, c.y, c.z, (b.max - b.min).length() * 0.5];
        }
        let heights_first = data.len() as u32;
        data.extend_from_slice(&terrain.heights);
        let binding = gpu
            .device
            .limits()
            .max_storage_buffer_binding_size
            .min(gpu.device.limits().max_buffer_size);
        if (data.len() * 4) as u64 > binding || (points.len() * 8) as u64 > binding {
            return None;
        }
        let seed = forest.seed();
        let size = forest.size();
        let params = GpuParams {
            seed_info: [
                seed as u32,
                (seed >> 32) as u32,
                layouts.len() as u32,
                (RESULT_HEAD + layouts.len()) as u32,
            ],
            rho_size: [forest.pattern_density() as f32, 0.0, size[0], size[1]],
            terrain: [terrain.size[0], terrain.size[1], 0.0, 0.0],
            terrain_info: [
                terrain.resolution[0],
                terrain.resolution[1],
                heights_first,
                0,
            ],
            tile_start,
            layouts: gl,
            spheres,
        };
        let device = &gpu.device;
        let init = |label: &str, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let params = init(
            "seed_params",
            bytemuck::bytes_of(&params),
            wgpu::BufferUsages::UNIFORM,
        );
        let points = init("seed_points", bytemuck::cast_slice(&points), storage);
        let data = init("seed_data", bytemuck::cast_slice(&data), storage);
        use sylvan_gpu::layout;
        let c = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("seed_layout"),
            entries: &[
                layout::uniform(0, c),
                layout::storage(1, c),
                layout::storage(2, c),
                layout::storage(3, c),
                layout::storage(4, c),
                layout::storage(5, c),
                layout::storage_rw(6, c),
                layout::storage_rw(7, c),
            ],
        });
        let module = sylvan_gpu::shader(gpu, "seed", include_str!("seed.wgsl"));
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("seed_pipeline_layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("seed"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("produce"),
            compilation_options: Default::default(),
            cache: None,
        });
        let bytes = params.size() + points.size() + data.size();
        Some(Self {
            forest: forest.clone(),
            tile_m,
            layout,
            pipeline,
            params,
            points,
            data,
            layout_species: layouts.iter().map(|l| l.species as usize).collect(),
            species: bounds.len(),
            bytes,
        })
    }

    /// GPU bytes of the forest's static data (points, maps, heights).
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// Tile `key`'s rectangle.
    fn rect(&self, key: TileKey) -> (Vec2, Vec2) {
        let min = Vec2::new(key.x as f32, key.z as f32) * self.tile_m;
        (min, min + Vec2::splat(self.tile_m))
    }

    /// Whether the GPU can seed tile `key`: no fixed tree within the pattern radius of it
    /// (the CPU producer keeps the trees clear of those).
    pub fn accepts(&self, key: TileKey) -> bool {
        let (min, max) = self.rect(key);
        !self.forest.blocked_near(min, max)
    }

    /// The plan of tile `key` (one [`GpuSeeds::accepts`]).
    pub fn plan(&self, key: TileKey) -> SeedPlan {
        let (min, max) = self.rect(key);
        let mut runs = Vec::new();
        let (min, max) = self.forest.candidate_runs(min, max, &mut runs);
        let mut candidates = 0u32;
        for r in &runs {
            let pts = &self.forest.tile_points(r.tile as usize)[r.first as usize..r.end as usize];
            candidates += pts
                .iter()
                .filter(|p| {
                    let x = r.origin.x + p.x;
                    x >= min.x && x < max.x
                })
                .count() as u32;
        }
        SeedPlan {
            key,
            runs,
            min,
            max,
            candidates,
        }
    }

    /// Seeds `plans` into `pool`, plan `i` into the pages `pages[i]` (at least
    /// `plans[i].candidates.div_ceil(PAGE)` of them), submits, and reads the results back
    /// (waiting for the GPU).
    #[cfg(test)]
    pub fn run(
        &self,
        gpu: &Gpu,
        pool: &wgpu::Buffer,
        plans: &[SeedPlan],
        pages: &[Vec<u32>],
    ) -> Result<Vec<Seeded>, RenderError> {
        let pending = self.dispatch(gpu, pool, plans, pages);
        pending.finish(gpu)
    }

    /// [`GpuSeeds::run`] without waiting: submits the dispatch and a copy of its results to a
    /// mapped buffer; the results are read once the GPU is done ([`Pending::poll`]).
    pub fn dispatch(
        &self,
        gpu: &Gpu,
        pool: &wgpu::Buffer,
        plans: &[SeedPlan],
        pages: &[Vec<u32>],
    ) -> Pending {
        let stride = RESULT_HEAD + self.layout_species.len();
        let mut jobs = Vec::with_capacity(plans.len());
        let mut runs = Vec::new();
        let mut table = Vec::new();
        for (i, (p, pg)) in plans.iter().zip(pages).enumerate() {
            debug_assert!(pg.len() as u32 >= p.candidates.div_ceil(PAGE));
            jobs.push(GpuJob {
                info: [
                    runs.len() as u32,
                    p.runs.len() as u32,
                    table.len() as u32,
                    i as u32,
                ],
                rect: [p.min.x, p.max.x, p.min.y, p.max.y],
            });
            table.extend_from_slice(pg);
            for r in &p.runs {
                let h = (r.tx as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
                    ^ (r.ty as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
                runs.push(GpuRun {
                    info: [r.tile, r.first, r.end, 0],
                    hash_origin: [
                        h as u32,
                        (h >> 32) as u32,
                        r.origin.x.to_bits(),
                        r.origin.y.to_bits(),
                    ],
                });
            }
        }
        // Results: count 0, min at the top of the order, max at the bottom.
        let mut init = vec![0u32; stride * plans.len()];
        for r in init.chunks_mut(stride) {
            r[1..4].fill(u32::MAX);
        }
        let device = &gpu.device;
        let storage = |label: &str, bytes: &[u8], extra| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: if bytes.is_empty() { &[0; 16] } else { bytes },
                usage: wgpu::BufferUsages::STORAGE | extra,
            })
        };
        let none = wgpu::BufferUsages::empty();
        let jobs_buf = storage("seed_jobs", bytemuck::cast_slice(&jobs), none);
        let runs_buf = storage("seed_runs", bytemuck::cast_slice(&runs), none);
        let table_buf = storage("seed_pages", bytemuck::cast_slice(&table), none);
        let results = storage(
            "seed_results",
            bytemuck::cast_slice(&init),
            wgpu::BufferUsages::COPY_SRC,
        );
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("seed_results_read"),
            size: results.size(),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let entries: Vec<wgpu::BindGroupEntry> = [
            &self.params,
            &self.points,
            &self.data,
            &jobs_buf,
            &runs_buf,
            &table_buf,
            pool,
            &results,
        ]
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("seed_bind"),
            layout: &self.layout,
            entries: &entries,
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("seed"),
        });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("seed"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(plans.len() as u32, 1, 1);
        }
        encoder.copy_buffer_to_buffer(&results, 0, &staging, 0, results.size());
        gpu.queue.submit([encoder.finish()]);
        let done = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let flag = done.clone();
        staging.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            // A failed map leaves `done` false; `finish` then reports the device's error.
            if r.is_ok() {
                flag.store(true, std::sync::atomic::Ordering::Release);
            }
        });
        Pending {
            staging,
            done,
            jobs: plans.len(),
            stride,
            layout_species: self.layout_species.clone(),
            species: self.species,
        }
    }
}

/// A dispatched batch of tiles whose results are not read yet.
pub(crate) struct Pending {
    staging: wgpu::Buffer,
    done: Arc<std::sync::atomic::AtomicBool>,
    jobs: usize,
    stride: usize,
    layout_species: Vec<usize>,
    species: usize,
}

impl Pending {
    /// The results if the GPU has finished the batch (polls the device without waiting).
    pub fn poll(&self, gpu: &Gpu) -> Result<Option<Vec<Seeded>>, RenderError> {
        gpu.device
            .poll(wgpu::PollType::Poll)
            .map_err(|e| sylvan_gpu::GpuError::Wgpu(e.to_string()))?;
        if !self.done.load(std::sync::atomic::Ordering::Acquire) {
            return Ok(None);
        }
        Ok(Some(self.read()?))
    }

    /// The results, waiting for the GPU.
    pub fn finish(&self, gpu: &Gpu) -> Result<Vec<Seeded>, RenderError> {
        gpu.wait()?;
        if !self.done.load(std::sync::atomic::Ordering::Acquire) {
            return Err(RenderError::Gpu(sylvan_gpu::GpuError::Wgpu(
                "the seed producer's results could not be mapped".into(),
            )));
        }
        self.read()
    }

    fn read(&self) -> Result<Vec<Seeded>, RenderError> {
        let slice = self.staging.slice(..);
        let words: Vec<u32> = {
            let view = slice
                .get_mapped_range()
                .map_err(|e| sylvan_gpu::GpuError::Wgpu(e.to_string()))?;
            bytemuck::cast_slice(&view).to_vec()
        };
        self.staging.unmap();
        let unorder = |b: u32| {
            f32::from_bits(if b & 0x8000_0000 != 0 {
                b & 0x7FFF_FFFF
            } else {
                !b
            })
        };
        Ok(words
            .chunks(self.stride)
            .take(self.jobs)
            .map(|r| {
                let mut species_counts = vec![0u32; self.species];
                for (l, &s) in self.layout_species.iter().enumerate() {
                    species_counts[s] += r[RESULT_HEAD + l];
                }
                let (min, max) = if r[0] == 0 {
                    (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN))
                } else {
                    (
                        Vec3::new(unorder(r[1]), unorder(r[2]), unorder(r[3])),
                        Vec3::new(unorder(r[4]), unorder(r[5]), unorder(r[6])),
                    )
                };
                Seeded {
                    count: r[0],
                    species_counts,
                    min,
                    max,
                }
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::super::produce::Source;
    use super::super::{PoolTree, TREE_BYTES};
    use super::*;
    use sylvan_scene::PlacementMethod;
    use sylvan_scene::{DensityMap, SpeciesLayout, TreeInstance};

    fn gpu() -> Gpu {
        Gpu::new().unwrap_or_else(|e| panic!("{e}\n{}", sylvan_gpu::INSTALL_HINT))
    }

    /// A `wang` forest of three species (two from maps, one constant) on hills, with one fixed
    /// tree the seeds must keep clear of.
    fn source(fixed: &[TreeInstance], tile_m: f32) -> Source {
        let size = [700.0, 600.0];
        let terrain = Terrain::procedural(3, size, 40.0);
        let map = |f: fn(f32, f32) -> f32| DensityMap {
            resolution: [17, 13],
            values: (0..13)
                .flat_map(|r| (0..17).map(move |c| f(c as f32 / 16.0, r as f32 / 12.0)))
                .collect(),
        };
        let layouts = vec![
            SpeciesLayout {
                species: 1,
                height_m: [12.0, 20.0],
                density: Density::Map {
                    map: map(|x, z| (x * 3.0).sin().abs() * z),
                    max_per_ha: 500.0,
                },
            },
            SpeciesLayout {
                species: 0,
                height_m: [5.0, 9.0],
                density: Density::PerHectare(120.0),
            },
            SpeciesLayout {
                species: 2,
                height_m: [0.8, 2.2],
                density: Density::Map {
                    map: map(|x, z| 1.0 - x * z),
                    max_per_ha: 300.0,
                },
            },
        ];
        let forest =
            SeededForest::with_method(size, &layouts, 77, PlacementMethod::Wang, fixed).unwrap();
        let bounds = vec![
            SpeciesBounds {
                min: Vec3::new(-2.0, 0.0, -2.5),
                max: Vec3::new(2.5, 7.0, 2.0),
            },
            SpeciesBounds {
                min: Vec3::new(-4.0, -0.5, -4.0),
                max: Vec3::new(4.0, 16.0, 4.5),
            },
            SpeciesBounds {
                min: Vec3::new(-1.0, 0.0, -1.0),
                max: Vec3::new(1.0, 1.5, 1.0),
            },
        ];
        Source::new(terrain, forest.map(Arc::new), fixed, bounds, tile_m)
    }

    /// The GPU's records of every tile are the CPU producer's, in its order (positions to
    /// 1e-4 m, heights to 1e-2 m; at most one candidate in 10⁵ thinned differently, from f32
    /// rounding of the density lookups), with the same counts per species and bounds.
    #[test]
    fn gpu_seeds_are_the_cpu_trees() {
        let gpu = gpu();
        let tile_m = 128.0;
        let src = source(&[], tile_m);
        let forest = src.seeded.clone().unwrap();
        let seeds = GpuSeeds::new(&gpu, &forest, &src.terrain, &src.bounds, tile_m)
            .expect("a wang forest seeds on the GPU");
        // Every tile, the partial ones at the far edges too, and one outside the terrain.
        let keys: Vec<TileKey> = (0..5)
            .flat_map(|z| (0..6).map(move |x| TileKey { x, z }))
            .chain([TileKey { x: 9, z: 9 }])
            .collect();
        assert!(keys.iter().all(|&k| seeds.accepts(k)));
        let plans: Vec<SeedPlan> = keys.iter().map(|&k| seeds.plan(k)).collect();
        // Pages handed out back to front and interleaved, as a used pool would.
        let total: u32 = plans.iter().map(|p| p.candidates.div_ceil(PAGE)).sum();
        let mut free: Vec<u32> = (0..total).collect();
        free.reverse();
        let pages: Vec<Vec<u32>> = plans
            .iter()
            .map(|p| {
                (0..p.candidates.div_ceil(PAGE))
                    .map(|_| free.pop().unwrap())
                    .collect()
            })
            .collect();
        let pool = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("test_pool"),
            size: (total.max(1) as u64) * PAGE as u64 * TREE_BYTES,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let results = seeds.run(&gpu, &pool, &plans, &pages).unwrap();
        let bytes = sylvan_gpu::read_buffer_bytes(&gpu, &pool).unwrap();
        let records: &[PoolTree] = bytemuck::cast_slice(&bytes);
        let (mut trees, mut mismatched, mut candidates) = (0usize, 0usize, 0u64);
        for ((plan, pg), r) in plans.iter().zip(&pages).zip(&results) {
            let cpu = src.produce(plan.key);
            let before = mismatched;
            candidates += plan.candidates as u64;
            assert!(r.count <= plan.candidates);
            let gpu_trees: Vec<PoolTree> = (0..r.count)
                .map(|i| records[(pg[(i / PAGE) as usize] * PAGE + i % PAGE) as usize])
                .collect();
            // Walk both in order; a differently thinned candidate shows as a skip on one side.
            let (mut a, mut b) = (0, 0);
            while a < cpu.trees.len() && b < gpu_trees.len() {
                let (c, g) = (&cpu.trees[a], &gpu_trees[b]);
                let same_place = (c.base_scale[0] - g.base_scale[0]).abs() < 1e-4
                    && (c.base_scale[2] - g.base_scale[2]).abs() < 1e-4;
                if !same_place {
                    mismatched += 1;
                    // Skip the one that comes first in the CPU's order of candidates.
                    if cpu.trees[a..].iter().any(|t| {
                        (t.base_scale[0] - g.base_scale[0]).abs() < 1e-4
                            && (t.base_scale[2] - g.base_scale[2]).abs() < 1e-4
                    }) {
                        a += 1;
                    } else {
                        b += 1;
                    }
                    continue;
                }
                assert!(
                    (c.base_scale[1] - g.base_scale[1]).abs() < 1e-2,
                    "{c:?} {g:?}"
                );
                assert!(
                    (c.base_scale[3] - g.base_scale[3]).abs() < 1e-4,
                    "{c:?} {g:?}"
                );
                assert!((c.rot[0] - g.rot[0]).abs() < 1e-4 && (c.rot[1] - g.rot[1]).abs() < 1e-4);
                assert_eq!(c.rot[2], g.rot[2], "tint seed");
                assert_eq!(c.rot[3].to_bits(), g.rot[3].to_bits(), "species");
                trees += 1;
                a += 1;
                b += 1;
            }
            mismatched += (cpu.trees.len() - a) + (gpu_trees.len() - b);
            if mismatched == before {
                assert_eq!(r.species_counts, cpu.species_counts, "{:?}", plan.key);
                assert!(
                    (r.min - cpu.min).abs().max_element() < 1e-2,
                    "{:?}",
                    plan.key
                );
                assert!(
                    (r.max - cpu.max).abs().max_element() < 1e-2,
                    "{:?}",
                    plan.key
                );
            }
        }
        eprintln!("{trees} trees of {candidates} candidates, {mismatched} thinned differently");
        assert!(trees > 5_000, "{trees}");
        assert!(
            mismatched as u64 * 100_000 <= candidates.max(100_000),
            "{mismatched} of {candidates}"
        );
        assert_eq!(results.last().unwrap().count, 0, "outside the terrain");
    }

    /// Tiles near a fixed tree (and only those) stay on the CPU producer.
    #[test]
    fn tiles_near_fixed_trees_are_not_gpu_seeded() {
        let gpu = gpu();
        let fixed = [TreeInstance {
            position: Vec3::new(130.0, 0.0, 300.0),
            height: 10.0,
            rotation: 0.0,
            species: 0,
            seed: 0,
        }];
        let src = source(&fixed, 128.0);
        let seeds = GpuSeeds::new(
            &gpu,
            src.seeded.as_ref().unwrap(),
            &src.terrain,
            &src.bounds,
            128.0,
        )
        .unwrap();
        assert!(!seeds.accepts(TileKey { x: 1, z: 2 }));
        assert!(
            !seeds.accepts(TileKey { x: 0, z: 2 }),
            "within r of the edge"
        );
        assert!(seeds.accepts(TileKey { x: 3, z: 2 }));
        assert!(seeds.accepts(TileKey { x: 1, z: 0 }));
    }
}
