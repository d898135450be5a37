//! `boxtree`'s GPU-driven frame: LCV04 §4.1–§4.2's per-tree traversal as compute passes
//! (`traverse.wgsl`) over the world cull's per-(pass, species) lists, writing the impostor
//! lists (the camera's sorted back to front by box distance) and the opened boxes' instance
//! lists with every draw's indirect arguments. The CPU's work per frame is per (pass,
//! species): a uniform, a bind group, five dispatches and the draws.
//!
//! Output sizes are known only on the GPU: the lists live in buffers with capacities that
//! grow from the counts read back a frame late (no stall); a frame that needed more than the
//! capacity draws what fitted, and [`GpuTraversal::finish`] (the offline render path, after
//! the frame completed) says so, so `Renderer::render` draws that frame again.

use super::bake::BakedBox;
use super::draw::GpuImpostor;
use crate::RenderError;
use crate::frame::CASCADES;
use crate::technique::FrameInput;
use crate::technique::common::{LateReadback, parked_lists, storage};
use crate::world::Culled;
use bytemuck::{Pod, Zeroable};
use sylvan_gpu::{Gpu, layout};
use wgpu::util::DeviceExt;

const PASSES: usize = 1 + CASCADES;
/// Most input lists (passes × species) the uniform holds.
const MAX_LISTS: usize = 320;
/// Deepest box tree the traversal's per-depth stack holds.
pub(super) const MAX_DEPTH: u32 = 64;
const BUCKETS: u32 = 4096;
const IMP_SEGS: u32 = BUCKETS + CASCADES as u32;
const C_SEG: u32 = 328;
const A_IMP: u64 = 12;
const A_RES: u64 = 32;

/// The multi-draw runs' first word in the dispatch buffer (after three workgroup counts).
const D_MDI: u64 = 9;

/// Words of the dispatch buffer: three workgroup counts, then per (pass, mesh) the opened
/// boxes' draws compacted in species runs (traverse.wgsl, `scan_segments`).
fn dispatch_words(boxes: u32) -> u64 {
    D_MDI + 10 * PASSES as u64 * boxes as u64
}

/// Nearest bucketed distance and the farthest, for the camera's sort (metres).
const SORT_NEAR_M: f32 = 0.5;
const SORT_FAR_M: f32 = 1e5;
const TREE_BYTES: u64 = 32;
const IMPOSTOR_BYTES: u64 = std::mem::size_of::<GpuImpostor>() as u64;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    eye_band: [f32; 4],
    views: [[f32; 4]; PASSES],
    info: [u32; 4],
    caps: [u32; 4],
    sort: [f32; 4],
    lists: [[u32; 4]; MAX_LISTS],
}

/// One species as the traversal sees it.
pub(super) struct SpeciesBoxes<'a> {
    pub boxes: &'a [BakedBox],
    pub box_base: u32,
    pub bake_wood: bool,
}

/// The last counts read back.
#[derive(Default)]
struct Counts {
    impostors: [u32; PASSES],
    /// Per (pass, global box) opened trees.
    residual: Vec<u32>,
}

/// The traversal's pipelines and buffers.
pub(super) struct GpuTraversal {
    layout: wgpu::BindGroupLayout,
    prep: wgpu::ComputePipeline,
    traverse: wgpu::ComputePipeline,
    scan: wgpu::ComputePipeline,
    scatter_imp: wgpu::ComputePipeline,
    scatter_res: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    /// Workgroup counts the GPU writes for the traversal and the scatters.
    dispatch: wgpu::Buffer,
    dispatch_bind: wgpu::BindGroup,
    tables: wgpu::Buffer,
    counters: wgpu::Buffer,
    args: wgpu::Buffer,
    parked_imp: wgpu::Buffer,
    parked_res: wgpu::Buffer,
    /// The impostors (vertex slot 1 of the impostor pipelines).
    pub out_imp: wgpu::Buffer,
    /// The opened boxes' trees (vertex slot 1 of the mesh pipelines).
    pub out_res: wgpu::Buffer,
    /// Capacities (records) of the impostor and residual lists.
    caps: [u32; 2],
    /// The traversal's bind group, with the cull's trees and arguments buffers it binds
    /// (made again when one of them, or a list of ours, was replaced).
    bind: Option<(wgpu::BindGroup, wgpu::Buffer, wgpu::Buffer)>,
    boxes: u32,
    /// Per species, its global boxes `[box_base, box_base + n)` (its multi-draw runs).
    species_boxes: Vec<(u32, u32)>,
    /// First row of those runs in the tables.
    runs_row: u32,
    vertices: u32,
    readback: LateReadback,
    counts: Counts,
    /// Times a frame's lists outgrew their buffers (which then grew).
    pub reallocations: u32,
    /// Records that did not fit in the last frame read back.
    pub dropped: u64,
}

impl GpuTraversal {
    /// The tables of every species' box tree (pre-order, with depths and subtree sizes) and
    /// the pipelines. `vertices`: impostor vertices per box (planes × 6).
    pub fn new(
        gpu: &Gpu,
        species: &[SpeciesBoxes<'_>],
        vertices: u32,
    ) -> Result<Self, RenderError> {
        if !gpu
            .device
            .features()
            .contains(wgpu::Features::INDIRECT_FIRST_INSTANCE)
        {
            return Err(RenderError::Option(format!(
                "{}: boxtree's GPU-driven frame needs the INDIRECT_FIRST_INSTANCE feature, which this device lacks — pass --cpu-driven, or open the device with it",
                gpu.adapter_label()
            )));
        }
        let need = 9;
        let have = gpu.device.limits().max_storage_buffers_per_shader_stage;
        if have < need {
            return Err(RenderError::Option(format!(
                "{}: boxtree's GPU traversal needs {need} storage buffers per shader stage, the adapter allows {have} — pass --cpu-driven",
                gpu.adapter_label()
            )));
        }
        let boxes: u32 = species.iter().map(|s| s.boxes.len() as u32).sum();
        let (rows, box_rows) = tables(species)?;
        let device = &gpu.device;
        let c = wgpu::ShaderStages::COMPUTE;
        let rw = |b| layout::storage_rw(b, c);
        let bind_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("boxtree_traverse_layout"),
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
            label: Some("boxtree_dispatch_layout"),
            entries: &[rw(0)],
        });
        let module = sylvan_gpu::shader(gpu, "boxtree_traverse", include_str!("traverse.wgsl"));
        let layouts = [
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("boxtree_traverse_pipeline_layout"),
                bind_group_layouts: &[Some(&bind_layout)],
                immediate_size: 0,
            }),
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("boxtree_dispatch_pipeline_layout"),
                bind_group_layouts: &[Some(&bind_layout), Some(&dispatch_layout)],
                immediate_size: 0,
            }),
        ];
        // Three workgroup counts (x, y, z), then the multi-draw runs: the opened boxes' draws
        // compacted per (pass, mesh, species) (traverse.wgsl `D_MDI`).
        let dispatch = storage(
            gpu,
            "boxtree_dispatch",
            wgpu::BufferUsages::INDIRECT,
            dispatch_words(boxes) * 4,
        );
        let dispatch_bind = crate::technique::common::bind_group(
            gpu,
            "boxtree_dispatch_bind",
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
        let segs = IMP_SEGS + PASSES as u32 * boxes;
        let counter_words = (C_SEG + 2 * segs) as u64;
        let mut tables_rows = rows;
        tables_rows.extend(box_rows);
        // The species' box runs (first global box, boxes), after the boxes' rows.
        let runs_row = tables_rows.len() as u32;
        let species_boxes: Vec<(u32, u32)> = species
            .iter()
            .map(|s| (s.box_base, s.boxes.len() as u32))
            .collect();
        tables_rows.extend(species_boxes.iter().map(|&(b, n)| [b, n, 0, 0]));
        // Placeholder buffers: capacity 0 until the first frame sizes the lists.
        let caps = [0u32, 0];
        let (parked_imp, out_imp) =
            parked_lists(gpu, "boxtree", "impostors", 0, 32, IMPOSTOR_BYTES);
        let (parked_res, out_res) = parked_lists(gpu, "boxtree", "residual", 0, 16, TREE_BYTES);
        Ok(Self {
            prep: compute("prep", true),
            traverse: compute("traverse", false),
            scan: compute("scan_segments", true),
            scatter_imp: compute("scatter_imp", false),
            scatter_res: compute("scatter_res", false),
            dispatch,
            dispatch_bind,
            layout: bind_layout,
            params: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("boxtree_traverse_params"),
                size: std::mem::size_of::<Params>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            tables: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("boxtree_traverse_tables"),
                contents: bytemuck::cast_slice(&tables_rows),
                usage: wgpu::BufferUsages::STORAGE,
            }),
            counters: storage(
                gpu,
                "boxtree_counters",
                wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                counter_words * 4,
            ),
            args: storage(
                gpu,
                "boxtree_args",
                wgpu::BufferUsages::INDIRECT,
                (A_RES + 5 * 2 * (PASSES as u64) * boxes as u64) * 4,
            ),
            parked_imp,
            parked_res,
            out_imp,
            out_res,
            caps,
            bind: None,
            boxes,
            species_boxes,
            runs_row,
            vertices,
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
            &self.parked_imp,
            &self.parked_res,
            &self.out_imp,
            &self.out_res,
            &self.readback.buffer,
        ]
        .iter()
        .map(|b| b.size())
        .sum()
    }

    /// Records the frame's traversal. `culled`: the world's lists for this technique (one
    /// indirect draw per species, in species order, whose instance count is the list's).
    pub fn record(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        culled: &Culled<'_>,
        input: &FrameInput<'_>,
        species: usize,
        draw: &super::BoxTreeDrawParams,
    ) -> Result<(), RenderError> {
        let (texel_pixels, band) = (draw.texel_pixels, draw.band);
        if let Some(words) = self.readback.poll() {
            self.absorb(gpu, &words)?;
        }
        let mut lists = [[0u32; 4]; MAX_LISTS];
        let mut n = 0;
        let mut upper = 0u64;
        for pass in 0..PASSES {
            for s in 0..species {
                let (first, capacity) = culled.list(pass, s);
                if capacity == 0 {
                    continue;
                }
                if n == MAX_LISTS {
                    return Err(RenderError::Option(format!(
                        "{species} species: boxtree's GPU traversal takes at most {} — pass --cpu-driven",
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
            // First frame: room for one impostor per listed tree; later frames grow from the
            // counts read back.
            let want = match draw.initial_lists {
                0 => [upper.min(u32::MAX as u64 - 4096) as u32 + 4096, 1 << 14],
                n => [n, n],
            };
            self.grow(gpu, want)?;
        }
        let ppm = input.pixels_per_metre / texel_pixels;
        let mut views = [[ppm, 0.0, 0.0, 0.0]; PASSES];
        for (p, v) in views.iter_mut().enumerate().skip(1) {
            // As the CPU traversal (draw.rs): cascade c's receivers lie between the previous
            // cascade's far distance and its own (+10 %); outside, no box opens finer than the
            // cascade texels' PCF footprint.
            v[1] =
                input.shadow_texel_m[p - 1] * super::draw::SHADOW_FOOTPRINT_TEXELS / texel_pixels;
            v[2] = if p == 1 {
                0.0
            } else {
                input.cascade_far[p - 2]
            };
            v[3] = input.cascade_far[p - 1] * 1.1;
        }
        let params = Params {
            eye_band: input.eye.extend(band).to_array(),
            views,
            info: [n as u32, 0, self.boxes, self.vertices],
            caps: [
                self.caps[0],
                self.caps[1],
                self.runs_row,
                self.species_boxes.len() as u32,
            ],
            sort: [
                SORT_NEAR_M,
                BUCKETS as f32 / (SORT_FAR_M / SORT_NEAR_M).log2(),
                0.0,
                0.0,
            ],
            lists,
        };
        let mut params = params;
        params.info[1] = self.box_row();
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
                "boxtree_traverse_bind",
                &self.layout,
                &[
                    self.params.as_entire_binding(),
                    trees.as_entire_binding(),
                    world_args.as_entire_binding(),
                    self.tables.as_entire_binding(),
                    self.counters.as_entire_binding(),
                    self.parked_imp.as_entire_binding(),
                    self.parked_res.as_entire_binding(),
                    self.out_imp.as_entire_binding(),
                    self.out_res.as_entire_binding(),
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
                label: Some("boxtree_traverse"),
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
        step(encoder, &self.traverse, false, Some(0));
        step(encoder, &self.scan, true, None);
        step(encoder, &self.scatter_imp, false, Some(12));
        step(encoder, &self.scatter_res, false, Some(24));
        self.readback.copy(encoder, &self.counters);
        Ok(())
    }

    /// The first row of the per-box tables (the species' runs follow them).
    fn box_row(&self) -> u32 {
        self.runs_row - 2 * self.boxes
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
        let (imp, res) = (words[0], words[1]);
        let seg = |i: u32| words.get((C_SEG + i) as usize).copied().unwrap_or(0);
        self.counts.impostors[0] = (0..BUCKETS).map(seg).sum();
        for p in 1..PASSES {
            self.counts.impostors[p] = seg(BUCKETS + p as u32 - 1);
        }
        self.counts.residual = (0..PASSES as u32 * self.boxes)
            .map(|s| seg(IMP_SEGS + s))
            .collect();
        self.dropped =
            imp.saturating_sub(self.caps[0]) as u64 + res.saturating_sub(self.caps[1]) as u64;
        let over = imp > self.caps[0] || res > self.caps[1];
        if over {
            self.reallocations += 1;
            let more = |n: u32, cap: u32| {
                if n > cap {
                    n.saturating_add(n / 4)
                } else {
                    cap
                }
            };
            self.grow(gpu, [more(imp, self.caps[0]), more(res, self.caps[1])])?;
        }
        Ok(over)
    }

    /// Makes room for `want` impostors and opened trees (powers of two, within one binding).
    fn grow(&mut self, gpu: &Gpu, want: [u32; 2]) -> Result<(), RenderError> {
        let binding = gpu.device.limits().max_storage_buffer_binding_size;
        let fit = |n: u32, bytes: u64| -> u32 {
            (n.max(256).next_power_of_two() as u64).min(binding / bytes) as u32
        };
        let imp = fit(want[0], IMPOSTOR_BYTES);
        let res = fit(want[1], TREE_BYTES);
        if imp > self.caps[0] {
            (self.parked_imp, self.out_imp) =
                parked_lists(gpu, "boxtree", "impostors", imp, 32, IMPOSTOR_BYTES);
            self.caps[0] = imp;
            self.bind = None;
        }
        if res > self.caps[1] {
            (self.parked_res, self.out_res) =
                parked_lists(gpu, "boxtree", "residual", res, 16, TREE_BYTES);
            self.caps[1] = res;
            self.bind = None;
        }
        Ok(())
    }

    /// The indirect arguments and the byte offset of pass `pass`'s impostor draw.
    pub fn impostor_args(&self, pass: usize) -> (&wgpu::Buffer, u64) {
        (&self.args, (A_IMP + 4 * pass as u64) * 4)
    }

    /// The draws of species `s`'s opened boxes in `pass` for its wood or `leaves`, compacted on
    /// the GPU (those of boxes no tree opened are at the run's end and draw nothing) — (buffer,
    /// offset of the first, draws): one `multi_draw_indexed_indirect` (#15: one indirect draw
    /// per (species, mesh, pass) instead of one per box).
    pub fn residual_run(&self, pass: usize, s: usize, leaves: bool) -> (&wgpu::Buffer, u64, u32) {
        let (base, n) = self.species_boxes[s];
        let run = (pass as u64 * 2 + leaves as u64) * self.boxes as u64 + base as u64;
        (&self.dispatch, (D_MDI + 5 * run) * 4, n)
    }

    /// Impostors drawn in `pass` in the last frame read back.
    pub fn impostors(&self, pass: usize) -> u32 {
        self.counts.impostors[pass]
    }

    /// Trees whose global box `gbox` was opened in `pass`, in the last frame read back.
    pub fn opened(&self, pass: usize, gbox: u32) -> u32 {
        self.counts
            .residual
            .get(pass * self.boxes as usize + gbox as usize)
            .copied()
            .unwrap_or(0)
    }
}

/// Rows of the traversal's tables.
type Rows = Vec<[u32; 4]>;

/// The traversal's tables: per species (first node row, nodes); the nodes in pre-order
/// (global box, depth, subtree size, has residual geometry); then per box (centre, metres
/// per texel) and (wood first, wood count, leaf first, leaf count).
fn tables(species: &[SpeciesBoxes<'_>]) -> Result<(Rows, Rows), RenderError> {
    let mut rows: Vec<[u32; 4]> = vec![[0; 4]; species.len()];
    let mut box_rows = Vec::new();
    for (s, sp) in species.iter().enumerate() {
        let first = rows.len() as u32;
        // Pre-order walk from the root, with each node's subtree size filled in on the way
        // back.
        let mut stack = vec![(0u32, 0u32, false)];
        let mut at: Vec<usize> = Vec::new();
        while let Some((b, depth, done)) = stack.pop() {
            if done {
                let row = at.pop().expect("pushed on the way down");
                rows[row][2] = (rows.len() - row) as u32;
                continue;
            }
            if depth >= MAX_DEPTH {
                return Err(RenderError::Plant(format!(
                    "species {s}: a box tree deeper than {MAX_DEPTH} levels — raise boxtree.volume_threshold, or pass --cpu-driven"
                )));
            }
            let bx = &sp.boxes[b as usize];
            let wood = if sp.bake_wood {
                bx.residual_wood.clone()
            } else {
                0..0
            };
            let has = !wood.is_empty() || !bx.residual_leaves.is_empty();
            at.push(rows.len());
            rows.push([sp.box_base + b, depth, 1, has as u32]);
            stack.push((b, depth, true));
            for &c in bx.children.iter().rev() {
                stack.push((c, depth + 1, false));
            }
        }
        rows[s] = [first, rows.len() as u32 - first, 0, 0];
        for bx in sp.boxes {
            let c = (glam::Vec3::from(bx.min) + glam::Vec3::from(bx.max)) * 0.5;
            box_rows.push([
                c.x.to_bits(),
                c.y.to_bits(),
                c.z.to_bits(),
                bx.metres_per_texel.to_bits(),
            ]);
            let wood = if sp.bake_wood {
                bx.residual_wood.clone()
            } else {
                0..0
            };
            box_rows.push([
                wood.start,
                wood.len() as u32,
                bx.residual_leaves.start,
                bx.residual_leaves.len() as u32,
            ]);
        }
    }
    Ok((rows, box_rows))
}
