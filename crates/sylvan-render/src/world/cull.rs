//! The GPU cull: per frame, the run table (runs of consecutive pool pages of the tiles a pass
//! may see), the (pass, species) list layout and the uniforms are uploaded; one dispatch (a
//! workgroup row per page, each finding its run) culls every tree of those runs into the
//! lists, a second writes each indirect draw's arguments, and the lists' counts are copied
//! for reading back once the frame is done.

use super::{PASSES, PoolTree, TREE_BYTES};
use crate::RenderError;
use crate::frame::{CasterCull, Frustum};
use crate::instances::SpeciesBounds;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use sylvan_gpu::Gpu;

/// Most species the cull's uniform holds.
pub const MAX_SPECIES: usize = 64;

/// Distance buckets of the back-to-front counting sort (each 1/4096 of the log distance range:
/// trees within ~0.25 % of each other's distance may swap).
pub const SORT_BUCKETS: u32 = 4096;
/// Nearest distance the sort tells apart (metres).
const SORT_NEAR_M: f32 = 0.5;

/// How a technique wants its trees listed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ListLayout {
    /// One list per (pass, species); else one per pass holding every species, each record's
    /// `rot.z` being species + tint seed.
    pub per_species: bool,
    /// The camera list sorted back to front (blended impostors; needs `per_species` off).
    pub sort_camera: bool,
}

impl Default for ListLayout {
    fn default() -> Self {
        Self {
            per_species: true,
            sort_camera: false,
        }
    }
}

/// What a GPU-driven technique (or one band of a chain) asks of the cull: its lists, the draws
/// it makes from them, and the distance window it serves.
#[derive(Debug, Clone, PartialEq)]
pub struct ListRequest {
    /// The technique's registry name (for statistics).
    pub technique: &'static str,
    /// How its trees are listed.
    pub layout: ListLayout,
    /// Its draws per pass.
    pub draws: Vec<IndirectDraw>,
    /// Presence by distance from the eye to the trunk base: rises over `[w0, w1]` and falls
    /// over `[w2, w3]` (an equal pair is a step); [`ListRequest::ALL`] for every distance.
    pub window: [f32; 4],
    /// In a chain that ends in a forest field: how each tree ends into it (its own distance,
    /// by its height in pixels; set by the chain).
    pub field_end: Option<crate::technique::FieldEnd>,
}

impl ListRequest {
    /// The window of a technique drawing every distance.
    pub const ALL: [f32; 4] = [-1e30, -1e30, 1e30, 1e30];
}

/// The window inside both `a` and `b`: the later rise and the earlier fall (exact where one
/// of them is [`ListRequest::ALL`] or they do not overlap; a close bound where both fade at
/// the same place).
pub fn intersect_windows(a: [f32; 4], b: [f32; 4]) -> [f32; 4] {
    [
        a[0].max(b[0]),
        a[1].max(b[1]),
        a[2].min(b[2]),
        a[3].min(b[3]),
    ]
}

/// One draw a technique makes from each pass's list of a group (its species, or 0 for a
/// mixed list): an index range drawn once per listed tree, or `vertices` non-indexed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IndirectDraw {
    /// The group whose list it draws.
    pub group: u32,
    /// Indices per instance (0: a non-indexed draw of `first_index` vertices).
    pub index_count: u32,
    /// First index (vertices per instance when `index_count` is 0).
    pub first_index: u32,
}

impl IndirectDraw {
    /// `count` indices from `first` per tree of group `group`.
    pub fn indexed(group: u32, count: u32, first: u32) -> Self {
        Self {
            group,
            index_count: count,
            first_index: first,
        }
    }

    /// `vertices` non-indexed vertices per tree of group `group`.
    pub fn vertices(group: u32, vertices: u32) -> Self {
        Self {
            group,
            index_count: 0,
            first_index: vertices,
        }
    }

    /// Triangles per tree.
    pub fn triangles(&self) -> u64 {
        if self.index_count == 0 {
            self.first_index as u64 / 3
        } else {
            self.index_count as u64 / 3
        }
    }
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct GpuRun {
    /// First tree in the pool.
    pub first: u32,
    /// Trees (consecutive in the pool).
    pub count: u32,
    /// Bit p: pass p sees them.
    pub passes: u32,
    /// The run's first workgroup row: the rows of the runs before it (one per
    /// [`super::PAGE`] trees).
    pub row: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuList {
    offset: u32,
    capacity: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuDraw {
    list: u32,
    index_count: u32,
    first_index: u32,
    _pad: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuParams {
    planes: [[f32; 4]; 6 * PASSES],
    eye_far: [f32; 4],
    info: [u32; 4],
    fade: [f32; 4],
    sort: [f32; 4],
    band: [f32; 4],
    species: [[f32; 4]; MAX_SPECIES],
    /// The caster cull ([`CasterCull::gpu_rows`]; all zero without one: casters kept).
    casters: [[f32; 4]; CasterCull::GPU_ROWS],
    /// The occlusion cull ([`super::hiz::PyramidUse`]).
    hiz_view_proj: [[f32; 4]; 4],
    hiz_info: [f32; 4],
    hiz_offsets: [[u32; 4]; super::hiz::MAX_LEVELS / 4],
    /// The request's [`crate::technique::FieldEnd::gpu_row`] (zero: no field).
    field_end: [f32; 4],
    /// Per species its model top (plant units; 4 a row): a tree's height is it × its scale.
    tops: [[f32; 4]; MAX_SPECIES / 4],
}

/// What one frame culls.
pub(crate) struct FrameCull<'a> {
    pub eye: Vec3,
    /// Trees whose sphere is this far or farther are not drawn in the camera pass.
    pub far: f32,
    /// Where their presence starts falling to 0 at `far` (infinite: no fade).
    pub fade_start: f32,
    /// The band window (see [`ListRequest::window`]).
    pub window: [f32; 4],
    pub frustums: &'a [Option<Frustum>; PASSES],
    /// With shadows: which casters each cascade needs.
    pub casters: Option<&'a CasterCull>,
    /// Runs of pool trees to cull, and their workgroup rows in all.
    pub runs: &'a [GpuRun],
    pub rows: u32,
    /// Changes whenever the pool buffer is replaced (grown).
    pub pool_generation: u64,
    /// Per (pass, group) list: the most trees it can receive.
    pub capacity: &'a [u32],
    pub draws: &'a [IndirectDraw],
    /// The previous frame's depth pyramid for the camera pass's occlusion test.
    pub pyramid: &'a super::hiz::PyramidUse<'a>,
    /// The pop audit's per-slot presence buffer, and whether it is on (else a placeholder).
    pub audit: (&'a wgpu::Buffer, bool),
    /// How the request's trees end into a forest field
    /// ([`crate::technique::FieldEnd::gpu_row`]; zero: no field).
    pub field_end: [f32; 4],
}

/// The last frame's lists, as the techniques draw them.
pub struct Culled<'a> {
    trees: &'a wgpu::Buffer,
    args: &'a wgpu::Buffer,
    offsets: &'a [u32],
    capacity: &'a [u32],
    listed: &'a [u32],
    groups: usize,
    draws_per_pass: usize,
}

impl Culled<'_> {
    /// Bind this as vertex buffer slot 1 for (pass, group): the list's records from 0.
    pub fn instances(&self, pass: usize, group: usize) -> Option<wgpu::BufferSlice<'_>> {
        let i = pass * self.groups + group;
        if self.capacity[i] == 0 {
            return None;
        }
        let start = self.offsets[i] as u64 * TREE_BYTES;
        Some(
            self.trees
                .slice(start..start + self.capacity[i] as u64 * TREE_BYTES),
        )
    }

    /// The (pass, group) list's first record in [`Culled::trees_buffer`] and its capacity.
    pub fn list(&self, pass: usize, group: usize) -> (u32, u32) {
        let i = pass * self.groups + group;
        (self.offsets[i], self.capacity[i])
    }

    /// Every list's records (see [`Culled::list`]), for a technique's compute passes.
    pub fn trees_buffer(&self) -> &wgpu::Buffer {
        self.trees
    }

    /// The indirect arguments of every draw (see [`Culled::args`]; the instance count is
    /// the second word), for a technique's compute passes.
    pub fn args_buffer(&self) -> &wgpu::Buffer {
        self.args
    }

    /// Trees in the (pass, group) list in the last frame read back (for statistics).
    pub fn listed(&self, pass: usize, group: usize) -> u32 {
        self.listed[pass * self.groups + group]
    }

    /// The indirect arguments buffer and the byte offset of draw `k` (of the technique's
    /// [`IndirectDraw`] list) in `pass`.
    pub fn args(&self, pass: usize, k: usize) -> (&wgpu::Buffer, u64) {
        (self.args, ((pass * self.draws_per_pass + k) * 20) as u64)
    }
}

/// Pipelines and buffers of the cull.
pub(crate) struct Cull {
    layout: wgpu::BindGroupLayout,
    cull: wgpu::ComputePipeline,
    args_pipeline: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    species_spheres: [[f32; 4]; MAX_SPECIES],
    tops: [[f32; 4]; MAX_SPECIES / 4],
    layout_of_lists: ListLayout,
    groups: usize,
    sort_scan: wgpu::ComputePipeline,
    sort_scatter: wgpu::ComputePipeline,
    parked: Storage,
    runs: Storage,
    lists: Storage,
    counters: Storage,
    trees: Storage,
    draws: Storage,
    args: Storage,
    readback: wgpu::Buffer,
    readback_len: usize,
    offsets: Vec<u32>,
    capacity: Vec<u32>,
    listed: Vec<u32>,
    draws_per_pass: usize,
    max_binding: u64,
    /// The bind group of the buffers above, with the pool and pyramid generations it binds.
    bind: Option<(wgpu::BindGroup, (u64, u64), wgpu::Buffer)>,
    /// Trees the camera pass's occlusion test dropped in the frame last read back.
    occluded: u32,
}

/// A storage buffer that grows (never shrinks).
struct Storage {
    buffer: wgpu::Buffer,
    label: &'static str,
    usage: wgpu::BufferUsages,
}

impl Storage {
    fn new(gpu: &Gpu, label: &'static str, usage: wgpu::BufferUsages, bytes: u64) -> Self {
        let usage = usage | wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        Self {
            buffer: make(gpu, label, usage, bytes),
            label,
            usage,
        }
    }

    /// Makes room for `bytes` (contents are not kept); whether the buffer was replaced.
    fn reserve(&mut self, gpu: &Gpu, bytes: u64) -> bool {
        if bytes > self.buffer.size() {
            self.buffer = make(gpu, self.label, self.usage, bytes.next_power_of_two());
            return true;
        }
        false
    }
}

fn make(gpu: &Gpu, label: &str, usage: wgpu::BufferUsages, bytes: u64) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(256).next_multiple_of(256),
        usage,
        mapped_at_creation: false,
    })
}

impl Cull {
    pub fn new(
        gpu: &Gpu,
        bounds: &[SpeciesBounds],
        list_layout: ListLayout,
        max_binding: u64,
    ) -> Result<Self, RenderError> {
        let need = 10; // and the depth pyramid's two sampled textures
        let have = gpu.device.limits().max_storage_buffers_per_shader_stage;
        if have < need {
            return Err(RenderError::Option(format!(
                "{}: the GPU cull needs {need} storage buffers per shader stage, the adapter allows {have} — use a technique that is not GPU-driven, or another adapter",
                gpu.adapter_label()
            )));
        }
        if bounds.len() > MAX_SPECIES {
            return Err(RenderError::Option(format!(
                "{} species: the GPU cull holds at most {MAX_SPECIES} — merge species that share a plant",
                bounds.len()
            )));
        }
        let device = &gpu.device;
        use sylvan_gpu::layout;
        let c = wgpu::ShaderStages::COMPUTE;
        let rw = |binding| layout::storage_rw(binding, c);
        let pyramid = |binding| {
            let unfiltered = wgpu::TextureSampleType::Float { filterable: false };
            layout::texture(binding, c, unfiltered, wgpu::TextureViewDimension::D2)
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cull_layout"),
            entries: &[
                layout::uniform(0, c),
                layout::storage(1, c),
                layout::storage(2, c),
                layout::storage(3, c),
                rw(4),
                rw(5),
                layout::storage(6, c),
                rw(7),
                rw(8),
                pyramid(9),
                pyramid(10),
                rw(11),
            ],
        });
        let module = sylvan_gpu::shader(gpu, "cull", include_str!("cull.wgsl"));
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("cull_pipeline_layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let compute = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let mut species_spheres = [[0.0; 4]; MAX_SPECIES];
        for (s, b) in species_spheres.iter_mut().zip(bounds) {
            let c = (b.min + b.max) * 0.5;
            *s = [c.x, c.y, c.z, (b.max - b.min).length() * 0.5];
        }
        let mut tops = [[0.0; 4]; MAX_SPECIES / 4];
        for (s, b) in bounds.iter().enumerate() {
            tops[s / 4][s % 4] = b.max.y;
        }
        let groups = if list_layout.per_species {
            bounds.len().max(1)
        } else {
            1
        };
        let n_lists = PASSES * groups;
        let u = wgpu::BufferUsages::empty();
        Ok(Self {
            cull: compute("cull"),
            args_pipeline: compute("write_args"),
            sort_scan: compute("sort_scan"),
            sort_scatter: compute("sort_scatter"),
            parked: Storage::new(gpu, "cull_parked", u, 256),
            layout_of_lists: list_layout,
            groups,
            layout,
            params: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("cull_params"),
                size: std::mem::size_of::<GpuParams>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            species_spheres,
            tops,
            runs: Storage::new(gpu, "cull_runs", u, 4096),
            lists: Storage::new(gpu, "cull_lists", u, n_lists as u64 * 8),
            counters: Storage::new(
                gpu,
                "cull_counters",
                wgpu::BufferUsages::COPY_SRC,
                (n_lists as u64 + 2 * SORT_BUCKETS as u64 + 1) * 4,
            ),
            trees: Storage::new(gpu, "cull_lists_trees", wgpu::BufferUsages::VERTEX, 1 << 16),
            draws: Storage::new(gpu, "cull_draws", u, 256),
            args: Storage::new(gpu, "cull_args", wgpu::BufferUsages::INDIRECT, 256),
            readback: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("cull_readback"),
                size: (n_lists as u64 * 4 + 4).next_multiple_of(256),
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            readback_len: n_lists,
            offsets: vec![0; n_lists],
            capacity: vec![0; n_lists],
            listed: vec![0; n_lists],
            draws_per_pass: 0,
            max_binding,
            bind: None,
            occluded: 0,
        })
    }

    /// Each species' bounding sphere in plant units (xyz centre, w radius), as the shader has
    /// them.
    pub fn species_spheres(&self) -> [[f32; 4]; MAX_SPECIES] {
        self.species_spheres
    }

    /// GPU bytes.
    pub fn bytes(&self) -> u64 {
        [
            &self.runs,
            &self.lists,
            &self.counters,
            &self.trees,
            &self.draws,
            &self.args,
            &self.parked,
        ]
        .iter()
        .map(|s| s.buffer.size())
        .sum::<u64>()
            + self.readback.size()
            + self.params.size()
    }

    pub fn culled(&self) -> Culled<'_> {
        Culled {
            trees: &self.trees.buffer,
            args: &self.args.buffer,
            offsets: &self.offsets,
            capacity: &self.capacity,
            listed: &self.listed,
            groups: self.groups,
            draws_per_pass: self.draws_per_pass,
        }
    }

    pub fn listed(&self) -> &[u32] {
        &self.listed
    }

    /// Trees the occlusion test dropped from the camera list in the frame last read back.
    pub fn occluded(&self) -> u32 {
        self.occluded
    }

    /// Lists per pass.
    pub fn groups(&self) -> usize {
        self.groups
    }

    /// Uploads the frame's tables and records the two dispatches and the counts' copy.
    pub fn record(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        pool: &wgpu::Buffer,
        f: &FrameCull<'_>,
    ) -> Result<(), RenderError> {
        // List layout: (pass, species) lists back to back, each as long as the trees of the
        // tiles that pass sees; what does not fit one storage binding is cut (and counted).
        let limit = (self.max_binding / TREE_BYTES) as u32;
        let mut at = 0u32;
        for (i, &cap) in f.capacity.iter().enumerate() {
            let cap = cap.min(limit - at);
            self.offsets[i] = at;
            self.capacity[i] = cap;
            at += cap;
        }
        let lists: Vec<GpuList> = self
            .offsets
            .iter()
            .zip(&self.capacity)
            .map(|(&offset, &capacity)| GpuList { offset, capacity })
            .collect();
        self.draws_per_pass = f.draws.len();
        let groups = self.groups;
        let draws: Vec<GpuDraw> = (0..PASSES)
            .flat_map(|p| {
                f.draws.iter().map(move |d| GpuDraw {
                    list: (p * groups) as u32 + d.group,
                    index_count: d.index_count,
                    first_index: d.first_index,
                    _pad: 0,
                })
            })
            .collect();
        // The bind group is made again only when a buffer it binds was replaced.
        let generations = (f.pool_generation, f.pyramid.generation);
        let mut stale = self
            .bind
            .as_ref()
            .is_none_or(|b| b.1 != generations || &b.2 != f.audit.0);
        stale |= self.trees.reserve(gpu, at as u64 * TREE_BYTES);
        stale |= self.runs.reserve(gpu, std::mem::size_of_val(f.runs) as u64);
        stale |= self
            .draws
            .reserve(gpu, std::mem::size_of_val(draws.as_slice()) as u64);
        stale |= self.args.reserve(gpu, draws.len() as u64 * 20);
        let sorted = self.layout_of_lists.sort_camera && !self.layout_of_lists.per_species;
        let sorted_capacity = if sorted { self.capacity[0] } else { 0 };
        stale |= self.parked.reserve(gpu, sorted_capacity as u64 * 16);
        let mut params = GpuParams {
            planes: [[0.0; 4]; 6 * PASSES],
            eye_far: [f.eye.x, f.eye.y, f.eye.z, f.far],
            info: [
                self.groups as u32,
                f.runs.len() as u32,
                draws.len() as u32,
                self.layout_of_lists.per_species as u32,
            ],
            fade: [f.fade_start, f.audit.1 as u32 as f32, 0.0, 0.0],
            sort: [
                sorted as u32 as f32,
                SORT_NEAR_M,
                SORT_BUCKETS as f32 / (f.far.min(1e7) / SORT_NEAR_M).max(2.0).log2(),
                sorted_capacity as f32,
            ],
            band: f.window,
            species: self.species_spheres,
            casters: f
                .casters
                .map_or([[0.0; 4]; CasterCull::GPU_ROWS], CasterCull::gpu_rows),
            hiz_view_proj: f.pyramid.view_proj.to_cols_array_2d(),
            hiz_info: f.pyramid.info,
            hiz_offsets: f.pyramid.offsets,
            field_end: f.field_end,
            tops: self.tops,
        };
        for (p, frustum) in f.frustums.iter().enumerate() {
            if let Some(fr) = frustum {
                for (k, plane) in fr.planes().iter().enumerate() {
                    params.planes[p * 6 + k] = plane.to_array();
                }
            }
        }
        let q = &gpu.queue;
        q.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        if !f.runs.is_empty() {
            q.write_buffer(&self.runs.buffer, 0, bytemuck::cast_slice(f.runs));
        }
        q.write_buffer(&self.lists.buffer, 0, bytemuck::cast_slice(&lists));
        if !draws.is_empty() {
            q.write_buffer(&self.draws.buffer, 0, bytemuck::cast_slice(&draws));
        }
        if stale {
            let bind = crate::technique::common::bind_group(
                gpu,
                "cull_bind",
                &self.layout,
                &[
                    self.params.as_entire_binding(),
                    pool.as_entire_binding(),
                    self.runs.buffer.as_entire_binding(),
                    self.lists.buffer.as_entire_binding(),
                    self.counters.buffer.as_entire_binding(),
                    self.trees.buffer.as_entire_binding(),
                    self.draws.buffer.as_entire_binding(),
                    self.args.buffer.as_entire_binding(),
                    self.parked.buffer.as_entire_binding(),
                    wgpu::BindingResource::TextureView(f.pyramid.views[0]),
                    wgpu::BindingResource::TextureView(f.pyramid.views[1]),
                    f.audit.0.as_entire_binding(),
                ],
            );
            self.bind = Some((bind, generations, f.audit.0.clone()));
        }
        let bind = &self.bind.as_ref().expect("made above").0;
        encoder.clear_buffer(&self.counters.buffer, 0, None);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("cull"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, bind, &[]);
            if f.rows > 0 {
                pass.set_pipeline(&self.cull);
                // One workgroup row per page of a run: the pool's binding limit keeps pages
                // far below the 65,535 rows a dispatch allows (16.7M trees).
                pass.dispatch_workgroups(super::PAGE / 64, f.rows, 1);
            }
            if sorted_capacity > 0 {
                pass.set_pipeline(&self.sort_scan);
                pass.dispatch_workgroups(1, 1, 1);
                pass.set_pipeline(&self.sort_scatter);
                let groups = sorted_capacity.div_ceil(64);
                pass.dispatch_workgroups(groups.min(65_535), groups.div_ceil(65_535), 1);
            }
            if !draws.is_empty() {
                pass.set_pipeline(&self.args_pipeline);
                pass.dispatch_workgroups((draws.len() as u32).div_ceil(64), 1, 1);
            }
        }
        let bytes = (self.readback_len * 4) as u64;
        encoder.copy_buffer_to_buffer(&self.counters.buffer, 0, &self.readback, 0, bytes);
        let occluded_at = bytes + 2 * SORT_BUCKETS as u64 * 4;
        encoder.copy_buffer_to_buffer(&self.counters.buffer, occluded_at, &self.readback, bytes, 4);
        Ok(())
    }

    /// The lists' counts and capacities of the frame just completed (blocks until mapped:
    /// call once the frame's work is done, as the renderer does after its timer).
    pub fn read_counts(&mut self, gpu: &Gpu) -> Result<Vec<(u32, u32)>, RenderError> {
        let slice = self.readback.slice(..(self.readback_len * 4 + 4) as u64);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        gpu.wait()?;
        rx.recv()
            .map_err(|_| RenderError::Option("cull counts: map callback dropped".into()))?
            .map_err(|e| RenderError::Option(format!("cull counts: {e}")))?;
        let mut counts: Vec<u32> = {
            let data = slice
                .get_mapped_range()
                .map_err(|e| RenderError::Option(format!("cull counts: {e}")))?;
            bytemuck::cast_slice(&data).to_vec()
        };
        self.occluded = counts.pop().unwrap_or(0);
        self.readback.unmap();
        for (l, (&n, &cap)) in self
            .listed
            .iter_mut()
            .zip(counts.iter().zip(&self.capacity))
        {
            *l = n.min(cap);
        }
        Ok(counts
            .into_iter()
            .zip(self.capacity.iter().copied())
            .collect())
    }
}

const _: () = assert!(std::mem::size_of::<PoolTree>() == 32);

#[cfg(test)]
mod tests {
    #[test]
    fn the_shader_s_page_is_the_pool_s() {
        let line = format!("const PAGE: u32 = {}u;", super::super::PAGE);
        assert!(
            include_str!("cull.wgsl").contains(&line),
            "cull.wgsl: {line}"
        );
    }
}
