//! `hbt`'s GPU-driven frame: MNP01 §4's level selection and §4.1's direction look-ups and
//! reconstruction weights as compute passes (`select.wgsl`) over the world cull's
//! per-(pass, species) lists, writing the billboard lists (the camera's sorted back to front
//! by object distance) and the lists of trees drawn as their meshes, with every draw's
//! indirect arguments. The CPU's work per frame is per (pass, species): a uniform, five
//! dispatches and the draws. Same structure as `boxtree`'s traversal (`boxtree/gpu.rs`):
//! output lists grow from the counts read back a frame late; [`HbtGpuFrame::finish`] says when
//! a frame drew less than it listed, so `Renderer::render` draws it again.
//!
//! What it draws is the CPU loop's for the options it supports ([`supports`]): a tree opens
//! as a whole (not branch by branch), without small branches, facing projection, sun from the
//! cascades, without the scene-level cube-maps ([`HbtDrawParams::scene_visibility`]: built per
//! placed tree they grow with the world; off by default, measured closer to the reference
//! without them): a tree's own visibility is 1, its main branches keep their baked
//! cube-maps' sky term.

use super::gpu::GpuHbtInstance;
use super::prepare::PlantDraw;
use crate::RenderError;
use crate::directions::{DIRECTIONS_WGSL, DirectionLut};
use crate::frame::CASCADES;
use crate::technique::FrameInput;
use crate::technique::common::{LateReadback, parked_lists, storage};
use crate::technique::hbt::{HbtDrawParams, HbtProjection, HbtShadows};
use crate::world::Culled;
use bytemuck::{Pod, Zeroable};
use sylvan_gpu::{Gpu, layout};
use wgpu::util::DeviceExt;

const PASSES: usize = 1 + CASCADES;
const MAX_LISTS: usize = 320;
const BUCKETS: u32 = 4096;
const BB_SEGS: u32 = BUCKETS + CASCADES as u32;
const C_SEG: u32 = 336;
const A_BB: u64 = 12;
const A_MESH: u64 = 32;
const SPECIES_ROWS: usize = 5;
const SORT_NEAR_M: f32 = 0.5;
const SORT_FAR_M: f32 = 1e5;
const TREE_BYTES: u64 = 32;
const BB_BYTES: u64 = std::mem::size_of::<GpuHbtInstance>() as u64;

/// The selection's WGSL as compiled: `select.wgsl`, then the direction look-up.
pub(crate) fn select_source() -> String {
    format!("{}\n{DIRECTIONS_WGSL}", include_str!("select.wgsl"))
}

/// Why the GPU-driven frame cannot draw `hbt` with these options (`None`: it can).
pub(in crate::technique::hbt) fn supports(p: &HbtDrawParams, small: bool) -> Option<&'static str> {
    if p.mesh_per_branch {
        Some("hbt.mesh_per_branch")
    } else if p.projection != HbtProjection::Facing {
        Some("hbt.projection=cross")
    } else if p.shadows != HbtShadows::Cascades {
        Some("hbt.shadows=cubemaps")
    } else if p.scene_visibility {
        Some("hbt.scene_visibility=true")
    } else if small {
        Some("hbt's small-branch level")
    } else {
        None
    }
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    eye: [f32; 4],
    sun: [f32; 4],
    light: [f32; 4],
    far: [f32; 4],
    info: [u32; 4],
    caps: [u32; 4],
    sort: [f32; 4],
    dirs: [[u32; 4]; 4],
    lists: [[u32; 4]; MAX_LISTS],
}

/// The last counts read back.
#[derive(Default)]
struct Counts {
    billboards: [u32; PASSES],
    /// Per (pass, species) trees drawn as meshes.
    meshes: Vec<u32>,
    opened: u32,
    meshed: u32,
}

/// The selection's pipelines and buffers.
pub(super) struct HbtGpuFrame {
    layout: wgpu::BindGroupLayout,
    prep: wgpu::ComputePipeline,
    select: wgpu::ComputePipeline,
    scan: wgpu::ComputePipeline,
    scatter_bb: wgpu::ComputePipeline,
    scatter_mesh: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    dispatch: wgpu::Buffer,
    dispatch_bind: wgpu::BindGroup,
    tables: wgpu::Buffer,
    dirs: [[u32; 4]; 4],
    counters: wgpu::Buffer,
    args: wgpu::Buffer,
    parked_bb: wgpu::Buffer,
    parked_mesh: wgpu::Buffer,
    /// The billboards (vertex slot 1 of the billboard pipelines).
    pub out_bb: wgpu::Buffer,
    /// The trees drawn as meshes (vertex slot 1 of the mesh pipelines).
    pub out_mesh: wgpu::Buffer,
    caps: [u32; 2],
    bind: Option<(wgpu::BindGroup, wgpu::Buffer, wgpu::Buffer)>,
    species: u32,
    readback: LateReadback,
    counts: Counts,
    /// Times a frame's lists outgrew their buffers (which then grew).
    pub reallocations: u32,
    /// Records that did not fit in the last frame read back.
    pub dropped: u64,
}

fn f(x: f32) -> u32 {
    x.to_bits()
}

impl HbtGpuFrame {
    /// The tables of every species (its plant `plants[species_plant[s]]`), the direction
    /// tables and the pipelines.
    pub fn new(
        gpu: &Gpu,
        plants: &[PlantDraw],
        species_plant: &[usize],
        dirs: [&DirectionLut; 4],
        draw: &HbtDrawParams,
    ) -> Result<Self, RenderError> {
        if !gpu
            .device
            .features()
            .contains(wgpu::Features::INDIRECT_FIRST_INSTANCE)
        {
            return Err(RenderError::Option(format!(
                "{}: hbt's GPU-driven frame needs the INDIRECT_FIRST_INSTANCE feature, which this device lacks — pass --cpu-driven, or open the device with it",
                gpu.adapter_label()
            )));
        }
        let need = 10;
        let have = gpu.device.limits().max_storage_buffers_per_shader_stage;
        if have < need {
            return Err(RenderError::Option(format!(
                "{}: hbt's GPU-driven frame needs {need} storage buffers per shader stage, the adapter allows {have} — pass --cpu-driven",
                gpu.adapter_label()
            )));
        }
        let species = species_plant.len() as u32;
        // Species rows, then placements, then the direction tables.
        let mut rows: Vec<[u32; 4]> = vec![[0; 4]; SPECIES_ROWS * species_plant.len()];
        for (s, &pi) in species_plant.iter().enumerate() {
            let plant = &plants[pi];
            let first = rows.len() as u32;
            for pl in &plant.placements {
                let pp = &pl.placed;
                let m = pp.to_parent.matrix3;
                let t = pp.to_parent.translation;
                rows.push([f(m.x_axis.x), f(m.y_axis.x), f(m.z_axis.x), f(t.x)]);
                rows.push([f(m.x_axis.y), f(m.y_axis.y), f(m.z_axis.y), f(t.y)]);
                rows.push([f(m.x_axis.z), f(m.y_axis.z), f(m.z_axis.z), f(t.z)]);
                rows.push([f(pp.centre.x), f(pp.centre.y), f(pp.centre.z), pp.set]);
                let sky = super::gpu::pack8(pp.sky);
                rows.push([f(pp.scale), f(pp.radius), sky[0], sky[1]]);
            }
            let open = super::select::Switch::new(draw.open_texel_pixels, draw.band);
            let mesh = super::select::Switch::new(plant.mesh_pixels, draw.band);
            let centre = (plant.min + plant.max) * 0.5;
            let counts = plant.meshes.as_ref().map_or([0, 0], |m| {
                [
                    m.wood.as_ref().map_or(0, |w| w.index_count),
                    m.leaves.as_ref().map_or(0, |l| l.index_count),
                ]
            });
            let r = SPECIES_ROWS * s;
            rows[r] = [
                plant.tree_set,
                first,
                plant.placements.len() as u32,
                plant.meshes.is_some() as u32,
            ];
            rows[r + 1] = [f(plant.texel), f(plant.mesh_texel), f(plant.radius), 0];
            rows[r + 2] = [f(open.lo), f(open.hi), f(mesh.lo), f(mesh.hi)];
            rows[r + 3] = [f(centre.x), f(centre.y), f(centre.z), 0];
            rows[r + 4] = [counts[0], counts[1], 0, 0];
        }
        let mut dir_rows = [[0u32; 4]; 4];
        for (k, lut) in dirs.iter().enumerate() {
            let texels = rows.len() as u32;
            rows.extend(bytemuck::cast_slice::<u8, [u32; 4]>(lut.as_bytes()));
            let faces = rows.len() as u32;
            rows.extend(lut.set().gpu_faces().iter().map(|fc| fc.indices));
            let samples = rows.len() as u32;
            rows.extend(
                lut.set()
                    .gpu_samples()
                    .iter()
                    .map(|s| s.direction.map(f32::to_bits)),
            );
            dir_rows[k] = [texels, lut.resolution(), faces, samples];
        }
        let device = &gpu.device;
        let c = wgpu::ShaderStages::COMPUTE;
        let rw = |b| layout::storage_rw(b, c);
        let bind_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hbt_select_layout"),
            entries: &[
                layout::uniform(0, c),
                layout::storage(1, c),
                layout::storage(2, c),
                layout::storage(3, c),
                rw(4),
                rw(5),
                rw(6),
                rw(7),
                rw(8),
                rw(9),
            ],
        });
        let dispatch_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hbt_dispatch_layout"),
            entries: &[rw(0)],
        });
        let module = sylvan_gpu::shader(gpu, "hbt_select", &select_source());
        let layouts = [
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("hbt_select_pipeline_layout"),
                bind_group_layouts: &[Some(&bind_layout)],
                immediate_size: 0,
            }),
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("hbt_dispatch_pipeline_layout"),
                bind_group_layouts: &[Some(&bind_layout), Some(&dispatch_layout)],
                immediate_size: 0,
            }),
        ];
        let dispatch = storage(gpu, "hbt_dispatch", wgpu::BufferUsages::INDIRECT, 36);
        let dispatch_bind = crate::technique::common::bind_group(
            gpu,
            "hbt_dispatch_bind",
            &dispatch_layout,
            &[dispatch.as_entire_binding()],
        );
        let compute = |entry: &str, writes_dispatch: bool| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&layouts[writes_dispatch as usize]),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let segs = BB_SEGS + PASSES as u32 * species;
        let (parked_bb, out_bb) =
            parked_lists(gpu, "hbt", "billboards", 0, BB_BYTES + 16, BB_BYTES);
        let (parked_mesh, out_mesh) = parked_lists(gpu, "hbt", "meshes", 0, 16, TREE_BYTES);
        Ok(Self {
            prep: compute("prep", true),
            select: compute("select_levels", false),
            scan: compute("scan_segments", true),
            scatter_bb: compute("scatter_bb", false),
            scatter_mesh: compute("scatter_mesh", false),
            dispatch,
            dispatch_bind,
            layout: bind_layout,
            params: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("hbt_select_params"),
                size: std::mem::size_of::<Params>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            tables: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("hbt_select_tables"),
                contents: bytemuck::cast_slice(&rows),
                usage: wgpu::BufferUsages::STORAGE,
            }),
            dirs: dir_rows,
            counters: storage(
                gpu,
                "hbt_counters",
                wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                (C_SEG + 2 * segs) as u64 * 4,
            ),
            args: storage(
                gpu,
                "hbt_args",
                wgpu::BufferUsages::INDIRECT,
                (A_MESH + 5 * 2 * (PASSES as u64) * species as u64) * 4,
            ),
            parked_bb,
            parked_mesh,
            out_bb,
            out_mesh,
            caps: [0, 0],
            bind: None,
            species,
            readback: LateReadback::new(gpu, (C_SEG + segs) as u64 * 4),
            counts: Counts::default(),
            reallocations: 0,
            dropped: 0,
        })
    }

    /// GPU bytes held.
    pub fn bytes(&self) -> u64 {
        [
            &self.params,
            &self.dispatch,
            &self.tables,
            &self.counters,
            &self.args,
            &self.parked_bb,
            &self.parked_mesh,
            &self.out_bb,
            &self.out_mesh,
            &self.readback.buffer,
        ]
        .iter()
        .map(|b| b.size())
        .sum()
    }

    /// Records the frame's selection. `culled`: the world's lists for this technique (one
    /// indirect draw per species, in species order, whose instance count is the list's).
    pub fn record(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        culled: &Culled<'_>,
        input: &FrameInput<'_>,
        draw: &HbtDrawParams,
    ) -> Result<(), RenderError> {
        if let Some(words) = self.readback.poll() {
            self.absorb(gpu, &words)?;
        }
        let mut lists = [[0u32; 4]; MAX_LISTS];
        let mut n = 0;
        let mut upper = 0u64;
        for pass in 0..PASSES {
            for s in 0..self.species as usize {
                let (first, capacity) = culled.list(pass, s);
                if capacity == 0 {
                    continue;
                }
                if n == MAX_LISTS {
                    return Err(RenderError::Option(format!(
                        "{} species: hbt's GPU-driven frame takes at most {} — pass --cpu-driven",
                        self.species,
                        MAX_LISTS / PASSES
                    )));
                }
                let (_, offset) = culled.args(pass, s);
                lists[n] = [first, (offset / 4) as u32 + 1, pass as u32, s as u32];
                upper += capacity as u64;
                n += 1;
            }
        }
        if self.caps[0] == 0 {
            // First frame: room for one billboard per listed tree; later frames grow from the
            // counts read back.
            self.grow(
                gpu,
                [upper.min(u32::MAX as u64 - 4096) as u32 + 4096, 1 << 12],
            )?;
        }
        let light = draw
            .fixed_light
            .map_or(input.sun_dir, |l| glam::Vec3::from(l).normalize());
        let mut far = [0.0; 4];
        far.copy_from_slice(&input.cascade_far[..4]);
        let params = Params {
            eye: input.eye.extend(0.0).to_array(),
            sun: input.sun_dir.extend(draw.min_weight).to_array(),
            light: light.extend(input.pixels_per_metre).to_array(),
            far,
            info: [n as u32, self.species, (draw.levels >= 3) as u32, 0],
            caps: [self.caps[0], self.caps[1], 0, 0],
            sort: [
                SORT_NEAR_M,
                BUCKETS as f32 / (SORT_FAR_M / SORT_NEAR_M).log2(),
                0.0,
                0.0,
            ],
            dirs: self.dirs,
            lists,
        };
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let (trees, world_args) = (culled.trees_buffer(), culled.args_buffer());
        if self
            .bind
            .as_ref()
            .is_none_or(|b| &b.1 != trees || &b.2 != world_args)
        {
            let bind = crate::technique::common::bind_group(
                gpu,
                "hbt_select_bind",
                &self.layout,
                &[
                    self.params.as_entire_binding(),
                    trees.as_entire_binding(),
                    world_args.as_entire_binding(),
                    self.tables.as_entire_binding(),
                    self.counters.as_entire_binding(),
                    self.parked_bb.as_entire_binding(),
                    self.parked_mesh.as_entire_binding(),
                    self.out_bb.as_entire_binding(),
                    self.out_mesh.as_entire_binding(),
                    self.args.as_entire_binding(),
                ],
            );
            self.bind = Some((bind, trees.clone(), world_args.clone()));
        }
        let bind = &self.bind.as_ref().expect("made above").0;
        encoder.clear_buffer(&self.counters, 0, None);
        // One compute pass per step: a pass that bound the dispatch buffer for writing must
        // not be the one reading it as indirect arguments.
        let step = |encoder: &mut wgpu::CommandEncoder,
                    pipeline: &wgpu::ComputePipeline,
                    writes_dispatch: bool,
                    indirect: Option<u64>| {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("hbt_select"),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind, &[]);
            if writes_dispatch {
                pass.set_bind_group(1, &self.dispatch_bind, &[]);
            }
            match indirect {
                Some(offset) => pass.dispatch_workgroups_indirect(&self.dispatch, offset),
                None => pass.dispatch_workgroups(1, 1, 1),
            }
        };
        step(encoder, &self.prep, true, None);
        step(encoder, &self.select, false, Some(0));
        step(encoder, &self.scan, true, None);
        step(encoder, &self.scatter_bb, false, Some(12));
        step(encoder, &self.scatter_mesh, false, Some(24));
        self.readback.copy(encoder, &self.counters);
        Ok(())
    }

    /// After the frame's submission completed: reads this frame's counts (waiting if needed)
    /// and grows the lists that overflowed; true when the frame drew less than it listed.
    pub fn finish(&mut self, gpu: &Gpu) -> Result<bool, RenderError> {
        match self.readback.finish(gpu)? {
            Some(words) => self.absorb(gpu, &words),
            None => Ok(false),
        }
    }

    /// Takes a frame's counts; grows what overflowed. True when something did not fit.
    fn absorb(&mut self, gpu: &Gpu, words: &[u32]) -> Result<bool, RenderError> {
        let (bb, mesh) = (words[0], words[1]);
        let seg = |i: u32| words.get((C_SEG + i) as usize).copied().unwrap_or(0);
        self.counts.billboards[0] = (0..BUCKETS).map(seg).sum();
        for p in 1..PASSES {
            self.counts.billboards[p] = seg(BUCKETS + p as u32 - 1);
        }
        self.counts.meshes = (0..PASSES as u32 * self.species)
            .map(|s| seg(BB_SEGS + s))
            .collect();
        self.counts.opened = words[3];
        self.counts.meshed = words[4];
        self.dropped =
            bb.saturating_sub(self.caps[0]) as u64 + mesh.saturating_sub(self.caps[1]) as u64;
        let over = bb > self.caps[0] || mesh > self.caps[1];
        if over {
            self.reallocations += 1;
            let more = |n: u32, cap: u32| {
                if n > cap {
                    n.saturating_add(n / 4)
                } else {
                    cap
                }
            };
            self.grow(gpu, [more(bb, self.caps[0]), more(mesh, self.caps[1])])?;
        }
        Ok(over)
    }

    /// Makes room for `want` billboards and meshed trees (powers of two, within one binding).
    fn grow(&mut self, gpu: &Gpu, want: [u32; 2]) -> Result<(), RenderError> {
        let binding = gpu.device.limits().max_storage_buffer_binding_size;
        let fit = |n: u32, bytes: u64| -> u32 {
            (n.max(256).next_power_of_two() as u64).min(binding / bytes) as u32
        };
        let bb = fit(want[0], BB_BYTES + 16);
        let mesh = fit(want[1], TREE_BYTES);
        if bb > self.caps[0] {
            (self.parked_bb, self.out_bb) =
                parked_lists(gpu, "hbt", "billboards", bb, BB_BYTES + 16, BB_BYTES);
            self.caps[0] = bb;
            self.bind = None;
        }
        if mesh > self.caps[1] {
            (self.parked_mesh, self.out_mesh) =
                parked_lists(gpu, "hbt", "meshes", mesh, 16, TREE_BYTES);
            self.caps[1] = mesh;
            self.bind = None;
        }
        Ok(())
    }

    /// The indirect arguments and the byte offset of pass `pass`'s billboard draw.
    pub fn billboard_args(&self, pass: usize) -> (&wgpu::Buffer, u64) {
        (&self.args, (A_BB + 4 * pass as u64) * 4)
    }

    /// The indirect arguments and the byte offset of the draw of species `s`'s wood
    /// (`leaves` false) or leaves in `pass`.
    pub fn mesh_args(&self, pass: usize, s: usize, leaves: bool) -> (&wgpu::Buffer, u64) {
        let seg = (pass * self.species as usize + s) as u64;
        (&self.args, (A_MESH + 5 * (2 * seg + leaves as u64)) * 4)
    }

    /// Billboards drawn in `pass` in the last frame read back.
    pub fn billboards(&self, pass: usize) -> u32 {
        self.counts.billboards[pass]
    }

    /// Trees of species `s` drawn as meshes in `pass`, in the last frame read back.
    pub fn meshes(&self, pass: usize, s: usize) -> u32 {
        self.counts
            .meshes
            .get(pass * self.species as usize + s)
            .copied()
            .unwrap_or(0)
    }

    /// Trees opened (into branches or meshes) and drawn as meshes in the last frame read back's
    /// camera pass.
    pub fn opened_meshed(&self) -> (u32, u32) {
        (self.counts.opened, self.counts.meshed)
    }
}
