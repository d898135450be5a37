//! Tree instances on the GPU: per frame, trees are culled against the view and each shadow
//! cascade on the CPU and written, grouped by pass and species, into one persistent buffer.
//! Nothing is allocated per frame: the CPU staging vector and the buffer are sized once.

use crate::frame::{CASCADES, Cascade, CasterCull, Frustum};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::ops::Range;
use sylvan_gpu::Gpu;
use sylvan_scene::TreeInstance;

/// One tree as the vertex shader sees it (`PlantIn` locations 4 and 5).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug, PartialEq)]
pub struct GpuTreeInstance {
    /// xyz: trunk base; w: uniform scale from plant units to metres.
    pub base_scale: [f32; 4],
    /// x: cos(rotation); y: sin(rotation); z: tint seed in [0, 1); w: presence in [0, 1]
    /// (1 = whole; less during a level-of-detail transition).
    pub rot: [f32; 4],
}

impl GpuTreeInstance {
    /// The per-instance vertex layout, locations 4 and 5.
    pub const LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<GpuTreeInstance>() as u64,
        step_mode: wgpu::VertexStepMode::Instance,
        attributes: &wgpu::vertex_attr_array![4 => Float32x4, 5 => Float32x4],
    };
}

/// A tree's tint seed in [0, 1) from its [`TreeInstance::seed`] (a Knuth multiplicative hash,
/// so neighbouring seeds get unrelated tints).
pub fn tint_seed(seed: u32) -> f32 {
    (seed.wrapping_mul(2_654_435_761) >> 8) as f32 / (1u32 << 24) as f32
}

/// Tree `t`'s world bounding sphere (centre, radius) for a species with model bounds `b`, the
/// plant scaled from its height to the tree's (the GPU cull computes the same in `cull.wgsl`).
pub(crate) fn tree_sphere(t: &TreeInstance, b: &SpeciesBounds) -> (Vec3, f32) {
    let scale = t.height / b.max.y.max(1e-3);
    let local_centre = (b.min + b.max) * 0.5 * scale;
    let radius = (b.max - b.min).length() * 0.5 * scale;
    let (s, c) = t.rotation.sin_cos();
    let centre = t.position
        + Vec3::new(
            c * local_centre.x + s * local_centre.z,
            local_centre.y,
            -s * local_centre.x + c * local_centre.z,
        );
    (centre, radius)
}

/// A tree prepared for culling: GPU record plus world bounding sphere.
#[derive(Clone, Copy, Debug)]
struct Placed {
    gpu: GpuTreeInstance,
    centre: Vec3,
    radius: f32,
    species: usize,
}

/// The per-frame instance lists: `ranges[pass][species]` into one buffer, pass 0 the camera view
/// and pass `1 + c` shadow cascade `c`.
pub struct Instances {
    placed: Vec<Placed>,
    staging: Vec<GpuTreeInstance>,
    /// Per staged record, the index of its tree in [`Instances::placed_trees`].
    ids: Vec<u32>,
    buffer: wgpu::Buffer,
    /// `ranges[pass][species]`: instance range in the buffer.
    pub ranges: Vec<Vec<Range<u32>>>,
    species_count: usize,
}

/// Per-species model-space bounds, for the culling spheres and scaling.
#[derive(Debug, Clone, Copy)]
pub struct SpeciesBounds {
    /// Model-space bbox min.
    pub min: Vec3,
    /// Model-space bbox max.
    pub max: Vec3,
}

impl Instances {
    /// Places every tree (scale from plant height to tree height) and sizes the buffer for the
    /// worst case: every tree in the view and in every cascade.
    pub fn new(gpu: &Gpu, trees: &[TreeInstance], bounds: &[SpeciesBounds]) -> Self {
        let placed: Vec<Placed> = trees
            .iter()
            .filter(|t| (t.species as usize) < bounds.len())
            .map(|t| {
                let b = bounds[t.species as usize];
                let scale = t.height / b.max.y.max(1e-3);
                let (s, c) = t.rotation.sin_cos();
                let (centre, radius) = tree_sphere(t, &b);
                let seed = tint_seed(t.seed);
                Placed {
                    gpu: GpuTreeInstance {
                        base_scale: [t.position.x, t.position.y, t.position.z, scale],
                        rot: [c, s, seed, 1.0],
                    },
                    centre,
                    radius,
                    species: t.species as usize,
                }
            })
            .collect();
        let capacity = (placed.len().max(1) * (1 + CASCADES)) as u64;
        let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("tree_instances"),
            size: capacity * std::mem::size_of::<GpuTreeInstance>() as u64,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            staging: Vec::with_capacity(capacity as usize),
            ids: Vec::with_capacity(capacity as usize),
            placed,
            buffer,
            ranges: vec![vec![0..0; bounds.len()]; 1 + CASCADES],
            species_count: bounds.len(),
        }
    }

    /// Culls against the view frustum and, with shadows, each cascade (and the caster cull,
    /// when given), and uploads the survivors.
    pub fn update(
        &mut self,
        gpu: &Gpu,
        frustum: &Frustum,
        eye: Vec3,
        far: f32,
        cascades: Option<&[Cascade; CASCADES]>,
        casters: Option<&CasterCull>,
    ) {
        self.staging.clear();
        self.ids.clear();
        for species in 0..self.species_count {
            let start = self.staging.len() as u32;
            for (i, p) in self.placed.iter().enumerate() {
                if p.species == species
                    && p.centre.distance(eye) - p.radius < far
                    && frustum.intersects_sphere(p.centre, p.radius)
                {
                    self.staging.push(p.gpu);
                    self.ids.push(i as u32);
                }
            }
            self.ranges[0][species] = start..self.staging.len() as u32;
        }
        for c in 0..CASCADES {
            let clip = cascades.map(|all| Frustum::from_matrix(all[c].view_proj));
            for species in 0..self.species_count {
                let start = self.staging.len() as u32;
                if let Some(clip) = &clip {
                    for (i, p) in self.placed.iter().enumerate() {
                        if p.species == species
                            && clip.intersects_sphere(p.centre, p.radius)
                            && casters.is_none_or(|k| k.keeps(c, p.centre, p.radius))
                        {
                            self.staging.push(p.gpu);
                            self.ids.push(i as u32);
                        }
                    }
                }
                self.ranges[1 + c][species] = start..self.staging.len() as u32;
            }
        }
        gpu.queue
            .write_buffer(&self.buffer, 0, bytemuck::cast_slice(&self.staging));
    }

    /// An empty list for `species_count` species, filled each frame from another list by
    /// [`Instances::fill_from`] (one band of a level-of-detail chain). Its buffer holds
    /// `capacity` records, the master list's worst case.
    pub fn derived(gpu: &Gpu, capacity: usize, species_count: usize) -> Self {
        let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("tree_instances_band"),
            size: (capacity.max(1) * std::mem::size_of::<GpuTreeInstance>()) as u64,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            placed: Vec::new(),
            staging: Vec::with_capacity(capacity),
            ids: Vec::with_capacity(capacity),
            buffer,
            ranges: vec![vec![0..0; species_count]; 1 + CASCADES],
            species_count,
        }
    }

    /// Refills this list from `master`: every record for which `presence(record, species)` is
    /// above 0 is kept with that presence in `rot.w` (multiplied into the master's), per pass
    /// and species, and uploaded.
    pub fn fill_from(
        &mut self,
        gpu: &Gpu,
        master: &Instances,
        mut presence: impl FnMut(&GpuTreeInstance, usize) -> f32,
    ) {
        self.staging.clear();
        self.ids.clear();
        for pass in 0..=CASCADES {
            for species in 0..self.species_count.min(master.species_count) {
                let start = self.staging.len() as u32;
                for (rec, &id) in master
                    .records(pass, species)
                    .iter()
                    .zip(master.ids(pass, species))
                {
                    let p = presence(rec, species);
                    if p > 0.0 {
                        let mut r = *rec;
                        r.rot[3] *= p;
                        self.staging.push(r);
                        self.ids.push(id);
                    }
                }
                self.ranges[pass][species] = start..self.staging.len() as u32;
            }
        }
        gpu.queue
            .write_buffer(&self.buffer, 0, bytemuck::cast_slice(&self.staging));
    }

    /// Placed trees' capacity over all passes (for derived lists).
    pub fn capacity(&self) -> usize {
        self.placed.len().max(1) * (1 + CASCADES)
    }

    /// This frame's instances of `species` in `pass` (0 the camera, `1 + c` cascade `c`), as
    /// uploaded.
    pub fn records(&self, pass: usize, species: usize) -> &[GpuTreeInstance] {
        let r = &self.ranges[pass][species];
        &self.staging[r.start as usize..r.end as usize]
    }

    /// The tree index (into [`Instances::placed_trees`]) of each of [`Instances::records`].
    pub fn ids(&self, pass: usize, species: usize) -> &[u32] {
        let r = &self.ranges[pass][species];
        &self.ids[r.start as usize..r.end as usize]
    }

    /// Every placed tree, in id order: (species, record with presence 1). Empty for a derived
    /// list (its ids are its master's).
    pub fn placed_trees(&self) -> impl Iterator<Item = (usize, GpuTreeInstance)> + '_ {
        self.placed.iter().map(|p| (p.species, p.gpu))
    }

    /// Number of species.
    pub fn species_count(&self) -> usize {
        self.species_count
    }

    /// The instance buffer (bind as vertex buffer slot 1).
    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }

    /// Total trees placed.
    pub fn total(&self) -> usize {
        self.placed.len()
    }

    /// Trees drawn in the camera view.
    pub fn drawn(&self) -> u32 {
        self.ranges[0].iter().map(|r| r.end - r.start).sum()
    }
}
