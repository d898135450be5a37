//! The frame: culling, shadow cascades, main pass, resolve, timing.

use crate::RenderError;
use crate::bake::{BakeReport, CachePolicy};
use crate::frame::{self, CASCADES, DebugView, FrameResources, Frustum, GpuFrame, View};
use crate::instances::{Instances, SpeciesBounds};
use crate::pipeline::{HDR_FORMAT, MainTarget};
use crate::sky::SkyPass;
use crate::technique::{
    BakeProgress, BandRange, BuildContext, DrawContext, DrawCounts, FrameInput, Technique, registry,
};
use crate::terrain::TerrainPass;
use crate::world::cover::{CoverSettings, GroundCover};
use crate::world::{ListRequest, Source, World, WorldView};
use glam::{Mat4, Vec3};
use std::collections::BTreeMap;
use std::sync::Arc;
use sylvan_gpu::{FrameTimer, Gpu, OUTPUT_FORMAT, RenderTarget, Resolver, TimerKind};
use sylvan_plant::Plant;
use sylvan_scene::{Camera, PlantSource, Scene, Setting, Sun};

/// Most GPU memory the shadow cascades may take, depth and opacity (declared before
/// allocating): 1.25 GiB, four cascades of 8192².
pub const MAX_SHADOW_BYTES: u64 = 5 << 28;

/// Largest supersampling factor per axis (`--spp` up to 64).
pub const MAX_SPP: u32 = 64;

/// How to render.
#[derive(Debug, Clone)]
pub struct RenderOptions {
    /// Output width in pixels.
    pub width: u32,
    /// Output height in pixels.
    pub height: u32,
    /// Samples per pixel: a perfect square (1, 4, 9, 16, …); `√spp` supersampling per axis.
    pub spp: u32,
    /// The tree representation: a registry name (`geometry`, `boxtree`, `hbt`, `auto`, …).
    pub technique: String,
    /// Cascaded shadow maps on or off.
    pub shadows: bool,
    /// Shadow-map resolution per cascade.
    pub shadow_resolution: u32,
    /// Shadows are cast up to this distance from the eye (metres).
    pub shadow_distance: f32,
    /// Where the first cascade starts (metres from the eye; 0: at the eye). Receivers nearer
    /// are lit: a measurement setting that puts every shadow texel on one far band.
    pub shadow_near: f32,
    /// Exposure multiplier before tone mapping.
    pub exposure: f32,
    /// Time with the wall clock even where GPU timestamps exist.
    pub wall_timer: bool,
    /// Debug colouring (the viewer's debug views); [`DebugView::None`] for normal images.
    pub debug: DebugView,
    /// Technique parameters given on the command line (`--set`), applied over the scene's
    /// `[technique.NAME]` and `[[lod.band]]` tables.
    pub settings: Vec<Setting>,
    /// Where baked assets are cached.
    pub cache: CachePolicy,
    /// Feed even a GPU-driven technique from CPU-culled lists of every tree, placed before the
    /// first frame (the frame as it was before the tiled world; for comparisons).
    pub cpu_driven: bool,
    /// Draw into each cascade only the casters whose shadow can reach what the camera sees
    /// ([`frame::CasterCull`]); off: every caster in the cascade's box (for comparisons — the
    /// pictures are the same).
    pub caster_cull: bool,
    /// Where a `wang` forest's tiles are seeded: on the GPU ([`crate::world`]'s seed
    /// producer, BN12 §4) or by the CPU workers (the same trees either way).
    pub seeds: Seeds,
    /// Cull the camera pass's trees against the previous frame's depth pyramid
    /// ([`crate::world`]'s occlusion cull: GPU-driven frames into Sylvan's own target only;
    /// one frame late, so off by default).
    pub occlusion_cull: bool,
}

/// Where a `wang` forest's tiles are seeded ([`RenderOptions::seeds`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Seeds {
    /// On the GPU when the adapter is hardware; on the CPU workers on a software rasteriser,
    /// whose "GPU" is the same cores (measured: BENCHMARKS "GPU seeds").
    #[default]
    Auto,
    /// Always on the GPU.
    Gpu,
    /// Always on the CPU workers.
    Cpu,
}

impl Seeds {
    /// Whether the GPU seeds on `gpu`.
    pub fn on_gpu(self, gpu: &Gpu) -> bool {
        match self {
            Seeds::Auto => !gpu.is_software(),
            Seeds::Gpu => true,
            Seeds::Cpu => false,
        }
    }
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            width: 1280,
            height: 720,
            spp: 1,
            technique: "geometry".to_string(),
            shadows: true,
            shadow_resolution: 2048,
            shadow_distance: 1500.0,
            shadow_near: 0.0,
            exposure: 1.0,
            wall_timer: false,
            debug: DebugView::None,
            settings: Vec::new(),
            cache: CachePolicy::Default,
            cpu_driven: false,
            caster_cull: true,
            seeds: Seeds::Auto,
            occlusion_cull: false,
        }
    }
}

impl RenderOptions {
    /// Samples per axis, after checking `spp` is a perfect square in range.
    pub fn factor(&self) -> Result<u32, RenderError> {
        let f = (self.spp as f64).sqrt().round() as u32;
        if self.spp == 0 || f * f != self.spp || f > 8 || self.spp > MAX_SPP {
            return Err(RenderError::Option(format!(
                "--spp {}: samples per pixel must be a perfect square from 1 to {MAX_SPP} — use 1, 4, 9, 16, 25, 36, 49 or 64",
                self.spp
            )));
        }
        Ok(f)
    }
}

/// What one frame cost and drew.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameStats {
    /// Frame time in milliseconds (GPU timestamps, or wall clock).
    pub frame_ms: f64,
    /// The frame's parts in order, milliseconds (GPU timestamps between passes; empty with
    /// the wall clock): `prepare` (tile uploads, the GPU cull, the techniques' compute work),
    /// `shadows` (the cascades), `ground` (sky, terrain and the shader-map's far field),
    /// `trees` (every band's trees), `resolve` (tone mapping, downsampling).
    pub split_ms: Vec<(&'static str, f64)>,
    /// CPU milliseconds spent before recording: culling and the technique's per-frame work
    /// (level-of-detail traversal, instance uploads). Not part of `frame_ms`.
    pub cpu_ms: f64,
    /// Which clock measured `frame_ms`.
    pub timer: TimerKind,
    /// Trees in the scene.
    pub trees_total: usize,
    /// Trees drawn in the camera view, per technique name.
    pub trees_drawn: BTreeMap<String, u32>,
    /// Triangles submitted in the camera pass (trees + terrain).
    pub triangles: u64,
    /// Triangles submitted in all shadow passes.
    pub shadow_triangles: u64,
    /// Draw calls over all passes.
    pub draw_calls: u32,
    /// GPU bytes of the technique's assets (meshes, textures).
    pub asset_bytes: u64,
    /// GPU bytes of everything the renderer holds (assets, terrain, shadow maps, targets).
    pub gpu_bytes: u64,
    /// Each drawing technique's own statistics ([`Technique::stats`]), by technique name.
    pub technique_stats: BTreeMap<String, BTreeMap<String, f64>>,
}

/// A caller's camera for the embedding API: the view and projection matrices it draws its
/// own geometry with (right-handed, Y up, a perspective projection in either depth
/// convention, finite or infinite far plane), and the size of its attachments in pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraMatrices {
    /// World → view.
    pub view: Mat4,
    /// View → clip, depth in 0..1 as the renderer's [`MainTarget`] says.
    pub proj: Mat4,
    /// Attachment width in pixels.
    pub width: u32,
    /// Attachment height in pixels.
    pub height: u32,
}

/// What [`Renderer::draw`] records into a caller's pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layers {
    /// Sylvan's sky gradient and sun disc, at the far plane (record it first).
    pub sky: bool,
    /// Sylvan's terrain mesh of the scene (leave it off when the caller draws the ground).
    pub terrain: bool,
    /// The trees.
    pub trees: bool,
}

impl Layers {
    /// Sky, terrain and trees: what [`Renderer::render`] draws.
    pub const ALL: Layers = Layers {
        sky: true,
        terrain: true,
        trees: true,
    };
    /// Trees only, for a caller who draws its own sky and ground.
    pub const TREES: Layers = Layers {
        sky: false,
        terrain: false,
        trees: true,
    };
}

/// What [`Renderer::prepare`] recorded.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PreparedFrame {
    /// CPU milliseconds of the frame's preparation (culling, level of detail, uploads).
    pub cpu_ms: f64,
    /// Draw calls and triangles recorded in the shadow-cascade passes (triangles of
    /// GPU-driven lists are not known on the CPU and are not counted).
    pub shadow: DrawCounts,
}

/// The view a frame is drawn from: the [`View`] that shadow cascades and culling distances
/// are fitted to, the exact world → clip matrix the main pass uses (the caller's, when
/// embedded), and the level-of-detail scale.
struct FrameView {
    view: View,
    view_proj: Mat4,
    pixels_per_metre: f32,
}

/// Sylvan's own main pass into `hdr`: cleared (`clear`) or loading what an earlier main
/// pass of the frame stored.
fn main_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    hdr: &RenderTarget,
    far_depth: f32,
    clear: bool,
) -> wgpu::RenderPass<'e> {
    let (color, depth) = if clear {
        (
            wgpu::LoadOp::Clear(wgpu::Color::BLACK),
            wgpu::LoadOp::Clear(far_depth),
        )
    } else {
        (wgpu::LoadOp::Load, wgpu::LoadOp::Load)
    };
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("main_pass"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: &hdr.color_view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: color,
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: &hdr.depth_view,
            depth_ops: Some(wgpu::Operations {
                load: depth,
                store: wgpu::StoreOp::Store,
            }),
            stencil_ops: None,
        }),
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// Pixels covered by one metre at one metre's distance, for a vertical field of view of
/// `fov_y` radians over `height` pixels.
fn pixels_per_metre(fov_y: f32, height: u32) -> f32 {
    height as f32 / (2.0 * (fov_y * 0.5).tan())
}

struct Targets {
    hdr: RenderTarget,
    output: RenderTarget,
    resolve_source: wgpu::BindGroup,
    factor: u32,
}

/// Renders a scene with one technique. Create once; call [`Renderer::render`] per frame.
pub struct Renderer {
    options: RenderOptions,
    frame: FrameResources,
    sky: SkyPass,
    terrain: TerrainPass,
    technique: Box<dyn Technique>,
    bake_reports: Vec<BakeReport>,
    instances: Instances,
    /// The tiled world, for a GPU-driven technique (its trees never reach `instances`).
    world: Option<World>,
    /// The ground cover (BN12's coverage and density, for the ground's and trees' sky).
    cover: GroundCover,
    /// What the technique asks of the GPU cull (one per band of a chain).
    requests: Vec<ListRequest>,
    /// Trees in the whole world (expected count for a seeded forest).
    trees_in_world: usize,
    resolver: Resolver,
    timer: FrameTimer,
    /// Sylvan's own HDR and output targets; `None` when it draws into a caller's
    /// ([`Renderer::for_target`]).
    targets: Option<Targets>,
    /// Whether the frame being drawn has shadows (set by the frame's preparation).
    shadows_now: bool,
    scene_sky: sylvan_scene::Sky,
    fog_half: f32,
    far: f32,
    /// How far towards the sun casters may stand above the lowest receiver (terrain relief +
    /// tallest tree + 50 m): the cascades' depth, and with the sun's elevation the shadows'
    /// reach for the caster cull.
    caster_reach: f32,
    /// The largest tree's bounding radius (m): how far a receiver's shadow lookup may stray
    /// from its visible surface (the caster cull pads by it).
    receiver_pad: f32,
    /// The tallest tree (m), how far a tree reaches beside its trunk (m) and the terrain's
    /// steepest slope: with the sun's elevation, how far shadows fall ([`frame::shadow_reach`]).
    tallest: f32,
    crown: f32,
    slope: f32,
}

/// The frame split's label of each shadow cascade's pass.
const SHADOW_MARKS: [&str; CASCADES] = ["shadow0", "shadow1", "shadow2", "shadow3"];

/// Loads each species' plant (presets by name, files by path), in species order.
pub fn load_plants(scene: &Scene) -> Result<Vec<Plant>, RenderError> {
    let mut loaded: Vec<(PlantSource, Plant)> = Vec::new();
    let mut out = Vec::with_capacity(scene.species.len());
    for species in &scene.species {
        if let Some((_, p)) = loaded.iter().find(|(s, _)| *s == species.plant) {
            out.push(p.clone());
            continue;
        }
        let plant = match &species.plant {
            PlantSource::Preset(name) => sylvan_plant::preset(name),
            PlantSource::File(path) => sylvan_plant::load(path),
        }
        .map_err(|e| RenderError::Plant(e.to_string()))?;
        loaded.push((species.plant.clone(), plant.clone()));
        out.push(plant);
    }
    Ok(out)
}

impl Renderer {
    /// Prepares everything for `scene` drawn with `plants` (one per species); bakes what the
    /// technique needs (or reads it from the cache).
    pub fn new(
        gpu: &Gpu,
        scene: &Scene,
        plants: &[Plant],
        options: &RenderOptions,
    ) -> Result<Self, RenderError> {
        Self::with_progress(gpu, scene, plants, options, &mut |_, _, _| {})
    }

    /// A renderer that draws into a caller's attachments (the embedding API): every
    /// main-pass pipeline is built for `target`'s formats, sample count, depth convention
    /// and colour output, and no offscreen targets are made (`options.width`/`height` and
    /// `spp` are unused; the size comes with each frame's [`CameraMatrices`]). Record each
    /// frame with [`Renderer::prepare`] and [`Renderer::draw`]; [`Renderer::render`] refuses.
    ///
    /// On a caller's device ([`Gpu::from_parts`]) errors while building are caught with
    /// error scopes and returned; the caller's error handler never sees them.
    pub fn for_target(
        gpu: &Gpu,
        scene: &Scene,
        plants: &[Plant],
        options: &RenderOptions,
        target: MainTarget,
        progress: BakeProgress<'_>,
    ) -> Result<Self, RenderError> {
        target.check(gpu)?;
        gpu.scoped(|| Self::build(gpu, scene, plants, options, Some(target), progress))
    }

    /// [`Renderer::new`], reporting bake progress as (plant, done, total).
    pub fn with_progress(
        gpu: &Gpu,
        scene: &Scene,
        plants: &[Plant],
        options: &RenderOptions,
        progress: BakeProgress<'_>,
    ) -> Result<Self, RenderError> {
        gpu.scoped(|| Self::build(gpu, scene, plants, options, None, progress))
    }

    fn build(
        gpu: &Gpu,
        scene: &Scene,
        plants: &[Plant],
        options: &RenderOptions,
        caller_target: Option<MainTarget>,
        progress: BakeProgress<'_>,
    ) -> Result<Self, RenderError> {
        if plants.len() != scene.species.len() {
            return Err(RenderError::Plant(format!(
                "{} plants for {} species",
                plants.len(),
                scene.species.len()
            )));
        }
        let factor = options.factor()?;
        let max = gpu.device.limits().max_texture_dimension_2d;
        if !(256..=max).contains(&options.shadow_resolution) {
            return Err(RenderError::Option(format!(
                "--shadow-res {}: must be 256 to {max} (this adapter's largest texture) — use 2048",
                options.shadow_resolution
            )));
        }
        let res = options.shadow_resolution;
        let entry = registry::find(&options.technique)?;
        let settings: Vec<Setting> = scene
            .technique_params
            .iter()
            .chain(&options.settings)
            .cloned()
            .collect();
        // The cascades' translucent layer, where a technique (alone or a band) casts soft
        // shadows (`Entry::casts_translucent`).
        let members = match entry.kind {
            registry::Kind::Chain => crate::technique::lod::members(scene, &options.settings)?,
            _ => vec![(entry.name, settings.clone())],
        };
        let mut translucent = false;
        for (name, s) in &members {
            if let Some(casts) = registry::find(name)?.casts_translucent {
                translucent |= casts(s)?;
            }
        }
        let texel = crate::frame::shadow_texel_bytes(translucent);
        let shadow_bytes = CASCADES as u64 * res as u64 * res as u64 * texel;
        if shadow_bytes > MAX_SHADOW_BYTES {
            return Err(RenderError::Option(format!(
                "--shadow-res {res}: {CASCADES} cascades of {res}² depth{} take {:.1} GB, more than the {} MB allowed — use {} or less{}",
                if translucent {
                    " and translucent layers"
                } else {
                    ""
                },
                shadow_bytes as f64 / 1e9,
                MAX_SHADOW_BYTES >> 20,
                ((MAX_SHADOW_BYTES / (CASCADES as u64 * texel)) as f64).sqrt() as u32 & !255,
                if translucent {
                    " (or zfield.shadow_opacity=false: opaque casters, depth only)"
                } else {
                    ""
                }
            )));
        }
        let bounds: Vec<SpeciesBounds> = plants
            .iter()
            .map(|p| SpeciesBounds {
                min: Vec3::from(p.bbox_min),
                max: Vec3::from(p.bbox_max),
            })
            .collect();
        let source = Arc::new(Source::new(
            scene.terrain.clone(),
            scene.seeded.clone(),
            &scene.trees,
            bounds.clone(),
            scene.world.tile_m,
        ));
        let t = &scene.terrain;
        let (lo, hi) = t.min_max();
        let far = (t.size[0].hypot(t.size[1]) + (hi - lo) + 500.0).max(1000.0);
        let cover = GroundCover::new(
            gpu,
            source.clone(),
            t.size,
            &cover_settings(scene, &source, far),
        )?;
        let frame = FrameResources::new(
            gpu,
            res,
            caller_target.unwrap_or(MainTarget::OWN),
            &cover,
            translucent,
        );
        let resolver = Resolver::new(gpu);
        let targets = match caller_target {
            Some(_) => None,
            None => Some(Self::make_targets(
                gpu,
                &resolver,
                options.width,
                options.height,
                factor,
            )?),
        };
        // A GPU-driven technique draws the world tile by tile; any other gets every tree now.
        let gpu_driven = !options.cpu_driven
            && match entry.kind {
                registry::Kind::Chain => crate::technique::lod::gpu_driven(scene)?,
                _ => entry.gpu_driven,
            };
        let trees = if gpu_driven {
            Vec::new()
        } else {
            scene.all_trees().map_err(|e| {
                RenderError::Option(format!(
                    "{e}: technique `{}` places every tree before the first frame — lower the density, or use a GPU-driven technique ({})",
                    options.technique,
                    registry::REGISTRY
                        .iter()
                        .filter(|e| e.gpu_driven)
                        .map(|e| e.name)
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            })?
        };
        let instances = Instances::new(gpu, &trees, &bounds);
        registry::check_settings(&settings)?;
        for band in &scene.lod_bands {
            registry::check_settings(&band.params)?;
        }
        let built = (entry.build)(&mut BuildContext {
            gpu,
            frame: &frame,
            scene,
            plants,
            population: &instances,
            band: BandRange::ALL,
            field: None,
            settings: &settings,
            overrides: &options.settings,
            policy: &options.cache,
            progress,
        })?;
        let (technique, bake_reports) = (built.technique, built.reports);
        let tallest = trees.iter().chain(&scene.trees).map(|t| t.height).fold(
            scene.seeded.as_ref().map_or(0.0, |f| f.tallest_m()),
            f32::max,
        );
        let requests = technique.list_requests();
        if options.occlusion_cull && (!gpu_driven || caller_target.is_some()) {
            return Err(RenderError::Option(format!(
                "--occlusion-cull: {} — leave it off{}",
                if caller_target.is_some() {
                    "the occlusion cull reduces Sylvan's own depth target, and this renderer draws into the caller's"
                } else {
                    "the occlusion cull is part of the GPU-driven frame, and this one is CPU-driven"
                },
                if caller_target.is_none() && options.cpu_driven {
                    " or drop --cpu-driven"
                } else {
                    ""
                }
            )));
        }
        let world = match gpu_driven {
            true => {
                let mut world =
                    World::new(gpu, scene, source, &requests, options.seeds.on_gpu(gpu))?;
                world.set_occlusion(gpu, options.occlusion_cull);
                Some(world)
            }
            false => None,
        };
        let renderer = Self {
            sky: SkyPass::new(gpu, &frame),
            terrain: TerrainPass::new(gpu, &frame, t, technique.field()),
            frame,
            technique,
            bake_reports,
            instances,
            world,
            requests,
            trees_in_world: scene.estimated_trees().round() as usize,
            resolver,
            timer: FrameTimer::new(gpu, options.wall_timer),
            targets,
            shadows_now: false,
            scene_sky: scene.sky,
            fog_half: scene.fog.half_distance_m,
            far,
            cover,
            caster_reach: (hi - lo) + tallest + 50.0,
            receiver_pad: bounds
                .iter()
                .map(|b| (b.max - b.min).length() * 0.5 / b.max.y.max(1e-3) * tallest)
                .fold(1.0, f32::max),
            tallest,
            crown: bounds
                .iter()
                .map(|b| {
                    let side = b.min.abs().max(b.max.abs());
                    side.x.hypot(side.z) / b.max.y.max(1e-3) * tallest
                })
                .fold(0.0, f32::max),
            slope: t.max_slope(),
            options: options.clone(),
        };
        Ok(renderer)
    }

    fn make_targets(
        gpu: &Gpu,
        resolver: &Resolver,
        width: u32,
        height: u32,
        factor: u32,
    ) -> Result<Targets, RenderError> {
        if width == 0 || height == 0 {
            return Err(RenderError::Option(format!(
                "--size {width}x{height}: width and height must be at least 1"
            )));
        }
        let hdr = RenderTarget::new(
            gpu,
            "hdr_target",
            width * factor,
            height * factor,
            HDR_FORMAT,
        )?;
        let output = RenderTarget::new(gpu, "output_target", width, height, OUTPUT_FORMAT)?;
        Ok(Targets {
            resolve_source: resolver.bind_source(gpu, &hdr),
            hdr,
            output,
            factor,
        })
    }

    /// Changes the output size (targets are re-created only when it differs; a renderer
    /// drawing into a caller's target only records the size).
    pub fn resize(&mut self, gpu: &Gpu, width: u32, height: u32) -> Result<(), RenderError> {
        if (width, height) == (self.options.width, self.options.height) {
            return Ok(());
        }
        if let Some(t) = &self.targets {
            self.targets = Some(Self::make_targets(
                gpu,
                &self.resolver,
                width,
                height,
                t.factor,
            )?);
        }
        self.options.width = width;
        self.options.height = height;
        Ok(())
    }

    /// The view for `camera` at the current output size.
    pub fn view(&self, camera: &Camera) -> View {
        View {
            eye: camera.position,
            target: camera.look_at,
            fov_y: camera.fov_deg.clamp(1.0, 170.0).to_radians(),
            aspect: self.options.width as f32 / self.options.height.max(1) as f32,
            near: 0.25,
            far: self.far,
        }
    }

    /// Renders one frame from `camera` under `sun` into the output target and times it.
    /// When the technique's GPU-written lists outgrew their buffers (they grow from what the
    /// GPU counted), the frame is drawn again, so an offline picture is never missing trees.
    pub fn render(
        &mut self,
        gpu: &Gpu,
        camera: &Camera,
        sun: &Sun,
    ) -> Result<FrameStats, RenderError> {
        let mut tries = 0;
        loop {
            let (stats, again) = self.render_once(gpu, camera, sun)?;
            tries += 1;
            if !again || tries == 4 {
                return Ok(stats);
            }
        }
    }

    fn render_once(
        &mut self,
        gpu: &Gpu,
        camera: &Camera,
        sun: &Sun,
    ) -> Result<(FrameStats, bool), RenderError> {
        if self.targets.is_none() {
            return Err(RenderError::Option(
                "this renderer draws into a caller's target (Renderer::for_target): record each frame with prepare and draw".into(),
            ));
        }
        let view = self.view(camera);
        let frame_view = FrameView {
            view,
            view_proj: view.view_proj(),
            pixels_per_metre: pixels_per_metre(view.fov_y, self.options.height),
        };
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame"),
            });
        self.timer.begin(&mut encoder);
        let prepared = self.record_prepare(gpu, &mut encoder, &frame_view, sun)?;
        let Some(t) = &self.targets else {
            unreachable!("checked above")
        };
        // The main pass in two (same attachments, the second loads what the first stored), so
        // the timer can tell the ground and its far field from the trees.
        let far_depth = self.frame.target.far_depth();
        let ground = Layers {
            trees: false,
            ..Layers::ALL
        };
        let mut main_counts = self.draw(
            &mut main_pass(&mut encoder, &t.hdr, far_depth, true),
            ground,
        );
        self.timer.mark(&mut encoder, "ground");
        main_counts += self.draw(
            &mut main_pass(&mut encoder, &t.hdr, far_depth, false),
            Layers::TREES,
        );
        // The occlusion cull's pyramid for the next frame (timed with the trees it culls).
        if let Some(world) = &mut self.world {
            world.reduce_depth(
                gpu,
                &mut encoder,
                &t.hdr.depth_view,
                [t.hdr.width, t.hdr.height],
                frame_view.view_proj,
                view.eye,
            )?;
        }
        self.timer.mark(&mut encoder, "trees");
        self.resolver.encode(
            gpu,
            &mut encoder,
            &t.resolve_source,
            &t.output,
            t.factor,
            self.options.exposure,
        )?;
        self.timer.mark(&mut encoder, "resolve");
        self.timer.end(&mut encoder);
        gpu.queue.submit([encoder.finish()]);
        let frame_ms = self.timer.read_ms(gpu)?;
        let split_ms = self.timer.split_ms().to_vec();
        gpu.check()?;
        let again = self.technique.finish_frame(gpu)?;
        let mut shadow_counts = prepared.shadow;
        let mut world_stats = None;
        let mut trees_drawn_gpu = None;
        if self.world.is_some() {
            // The frame is done (the timer waited): its counts are ready without a stall.
            let (drawn, main_tris, shadow_tris) = self.read_world_counts(gpu)?;
            trees_drawn_gpu = Some(drawn);
            main_counts.triangles = main_tris;
            shadow_counts.triangles = shadow_tris;
            world_stats = self.world.as_ref().map(World::stats);
        }

        let asset_bytes = self.technique.bytes();
        let mut technique_stats: BTreeMap<String, BTreeMap<String, f64>> = self
            .technique
            .stats_by_technique()
            .into_iter()
            .filter(|(_, v)| !v.is_empty())
            .map(|(name, v)| {
                (
                    name.to_string(),
                    v.into_iter().map(|(k, x)| (k.to_string(), x)).collect(),
                )
            })
            .collect();
        if let Some(w) = &world_stats {
            technique_stats.insert("world".to_string(), w.named());
        }
        technique_stats.insert("ground_cover".to_string(), self.cover.named());
        let stats = FrameStats {
            technique_stats,
            frame_ms,
            split_ms,
            cpu_ms: prepared.cpu_ms,
            timer: self.timer.kind(),
            trees_total: match &self.world {
                Some(_) => self.trees_in_world,
                None => self.instances.total(),
            },
            trees_drawn: match trees_drawn_gpu {
                Some(d) => d,
                None => self.listed_trees_drawn(),
            },
            triangles: main_counts.triangles,
            shadow_triangles: shadow_counts.triangles,
            draw_calls: main_counts.draw_calls + shadow_counts.draw_calls + 1,
            asset_bytes,
            gpu_bytes: self.gpu_bytes(),
        };
        Ok((stats, again))
    }

    /// GPU bytes of everything the renderer holds (assets, terrain, shadow maps, own targets,
    /// instance and world buffers).
    pub fn gpu_bytes(&self) -> u64 {
        self.technique.bytes()
            + self.terrain.bytes()
            + self.cover.bytes()
            + self.frame.bytes()
            + self
                .targets
                .as_ref()
                .map_or(0, |t| t.hdr.bytes() + t.output.bytes())
            + self.instances.buffer().size()
            + self.world.as_ref().map_or(0, World::bytes)
    }

    /// Records everything of a frame that happens outside the main pass: tile uploads and
    /// the GPU cull (world), the technique's per-frame work, the frame uniforms and the
    /// shadow-cascade passes.
    fn record_prepare(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        fv: &FrameView,
        sun: &Sun,
    ) -> Result<PreparedFrame, RenderError> {
        let view = &fv.view;
        let sun_dir = sun.direction();
        let shadows = self.options.shadows && sun_dir.y > 0.0;
        self.shadows_now = shadows;
        let cascades = frame::fit_cascades(
            view,
            sun_dir,
            self.options.shadow_near,
            self.options.shadow_distance,
            self.caster_reach,
            self.frame.shadow_resolution,
        );
        let frustum = Frustum::from_matrix(fv.view_proj);
        let cpu_start = std::time::Instant::now();
        let mut frustums: [Option<Frustum>; 1 + CASCADES] = Default::default();
        frustums[0] = Some(frustum);
        for (f, c) in frustums[1..].iter_mut().zip(&cascades) {
            *f = shadows.then(|| Frustum::from_matrix(c.view_proj));
        }
        self.terrain.cull(&frustums);
        // Casters whose shadow cannot reach a receiver the camera sees are not drawn.
        let casters = (shadows && self.options.caster_cull).then(|| {
            frame::CasterCull::new(
                view,
                fv.view_proj,
                &cascades,
                sun_dir,
                frame::shadow_reach(
                    sun_dir,
                    self.tallest,
                    self.crown,
                    self.slope,
                    self.caster_reach,
                ),
                self.receiver_pad,
                self.frame.shadow_resolution,
            )
        });
        let cover_range = self.far.min(view.far);
        self.cover.prepare(gpu, view.eye, cover_range, &frustum);
        let windows = match self.world {
            Some(_) => self.technique.list_windows(fv.pixels_per_metre),
            None => None,
        };
        if let Some(world) = &mut self.world {
            if let Some(w) = &windows {
                world.set_windows(w);
            }
            let wv = WorldView {
                eye: view.eye,
                far: view.far,
                frustums: &frustums,
                casters: casters.as_ref(),
                pixels_per_metre: fv.pixels_per_metre,
            };
            world.prepare(gpu, encoder, &wv)?;
        } else {
            self.instances.update(
                gpu,
                &frustum,
                view.eye,
                view.far,
                shadows.then_some(&cascades),
                casters.as_ref(),
            );
        }

        let culled = self.world.as_ref().map(World::culled).unwrap_or_default();
        let input = FrameInput {
            culled: &culled,
            eye: view.eye,
            pixels_per_metre: fv.pixels_per_metre,
            sun_dir,
            instances: &self.instances,
            shadow_texel_m: cascades.map(|c| {
                let m = c.view_proj;
                // An orthographic cascade maps 2 / |row x| metres onto its resolution.
                let row_x = Vec3::new(m.x_axis.x, m.y_axis.x, m.z_axis.x).length();
                2.0 / row_x.max(1e-9) / self.frame.shadow_resolution as f32
            }),
            cascade_far: cascades.map(|c| c.far),
        };
        self.technique.prepare_frame(gpu, encoder, &input)?;
        let cpu_ms = cpu_start.elapsed().as_secs_f64() * 1e3;

        let raw = self.frame_uniforms(fv, sun, sun_dir, shadows, &cascades);
        gpu.queue
            .write_buffer(&self.frame.uniforms, 0, bytemuck::bytes_of(&raw));
        for (c, buffer) in cascades.iter().zip(&self.frame.cascade_uniforms) {
            let mut r = raw;
            r.view_proj = c.view_proj.to_cols_array_2d();
            gpu.queue.write_buffer(buffer, 0, bytemuck::bytes_of(&r));
        }

        let mut shadow = DrawCounts::default();
        // The compute work recorded so far (tile uploads, the GPU cull, the techniques'
        // per-frame passes) is the frame's first part; a no-op outside `render`.
        self.timer.mark(encoder, "prepare");
        // With shadows off the maps are never sampled (`sun_dir.w` = 0): skip the passes (each
        // cascade's mark is still taken, so every frame has the same parts).
        for (c, &mark) in SHADOW_MARKS.iter().enumerate() {
            if !shadows {
                self.timer.mark(encoder, mark);
                continue;
            }
            let translucent =
                self.frame
                    .translucent_views
                    .get(c)
                    .map(|view| wgpu::RenderPassColorAttachment {
                        view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color {
                                r: 0.0,
                                g: 0.0,
                                b: 0.0,
                                a: 1.0,
                            }),
                            store: wgpu::StoreOp::Store,
                        },
                    });
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("shadow_pass"),
                // The translucent casters' layer, if any: no optical depth, no front (depth 1).
                color_attachments: match translucent {
                    Some(_) => std::slice::from_ref(&translucent),
                    None => &[],
                },
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.frame.cascade_views[c],
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &self.frame.cascade_binds[c], &[]);
            let (calls, triangles) = self.terrain.draw(&mut pass, 1 + c);
            shadow.draw_calls += calls;
            shadow.triangles += triangles;
            let ctx = DrawContext {
                pass: 1 + c,
                frame_bind: &self.frame.cascade_binds[c],
                instances: &self.instances,
                ranges: &self.instances.ranges[1 + c],
                culled: &culled,
            };
            shadow += self.technique.draw(&mut pass, &ctx);
            drop(pass);
            self.timer.mark(encoder, mark);
        }
        Ok(PreparedFrame { cpu_ms, shadow })
    }

    /// After a frame's submission: trees drawn per technique, and the camera's and the
    /// shadow passes' triangles, from the GPU cull's counts (blocks until they are mapped).
    fn read_world_counts(
        &mut self,
        gpu: &Gpu,
    ) -> Result<(BTreeMap<String, u32>, u64, u64), RenderError> {
        let Some(world) = &mut self.world else {
            return Ok(Default::default());
        };
        world.finish_frame(gpu)?;
        let world = &*world;
        let tris = |pass: usize| -> u64 {
            let per_request = self.requests.iter().enumerate().map(|(r, req)| {
                req.draws
                    .iter()
                    .map(|d| world.listed(r, pass, d.group as usize) as u64 * d.triangles())
                    .sum::<u64>()
            });
            per_request.sum()
        };
        let mut drawn: BTreeMap<String, u32> = BTreeMap::new();
        for (r, req) in self.requests.iter().enumerate() {
            let n: u32 = (0..world.groups(r)).map(|g| world.listed(r, 0, g)).sum();
            *drawn.entry(req.technique.to_string()).or_default() += n;
        }
        let terrain =
            |p: usize| self.terrain.visible_triangles(p) + self.technique.own_triangles(p);
        let shadow = (1..=CASCADES)
            .filter(|_| self.shadows_now)
            .map(|p| terrain(p) + tris(p))
            .sum();
        Ok((drawn, terrain(0) + tris(0), shadow))
    }

    /// The last rendered frame as an sRGB image.
    pub fn read_image(&self, gpu: &Gpu) -> Result<image::RgbaImage, RenderError> {
        let Some(t) = &self.targets else {
            return Err(RenderError::Option(
                "this renderer draws into a caller's target: read the caller's attachment".into(),
            ));
        };
        Ok(sylvan_gpu::read_rgba8(gpu, &t.output.color)?)
    }

    /// The mean linear radiance (RGB, before exposure and tone mapping) of the last frame over
    /// the output-pixel rectangle `[x, y, w, h]`, read from the HDR target (all its supersamples
    /// inside the rectangle).
    pub fn radiance_mean(&self, gpu: &Gpu, rect: [u32; 4]) -> Result<[f32; 3], RenderError> {
        let Some(t) = &self.targets else {
            return Err(RenderError::Option(
                "this renderer draws into a caller's target: measure the caller's attachment"
                    .into(),
            ));
        };
        let [x, y, w, h] = rect;
        let (width, height) = (self.options.width, self.options.height);
        if w == 0 || h == 0 || x.saturating_add(w) > width || y.saturating_add(h) > height {
            return Err(RenderError::Option(format!(
                "--measure {x},{y},{w},{h}: the rectangle must be non-empty and inside the {width}x{height} image"
            )));
        }
        let bytes = sylvan_gpu::read_texture_bytes(gpu, &t.hdr.color)?;
        let halves: &[u16] = bytemuck::cast_slice(&bytes);
        let (f, row) = (t.factor as usize, (width * t.factor) as usize);
        let mut sum = [0.0f64; 3];
        for py in y as usize * f..(y + h) as usize * f {
            for px in x as usize * f..(x + w) as usize * f {
                let at = (py * row + px) * 4;
                for (c, v) in sum.iter_mut().enumerate() {
                    *v += crate::bake::f16_to_f32(halves[at + c]) as f64;
                }
            }
        }
        let n = (w as usize * f * h as usize * f) as f64;
        Ok(sum.map(|v| (v / n) as f32))
    }

    fn frame_uniforms(
        &self,
        fv: &FrameView,
        sun: &Sun,
        sun_dir: Vec3,
        shadows: bool,
        cascades: &[frame::Cascade; CASCADES],
    ) -> GpuFrame {
        let (view, view_proj) = (&fv.view, fv.view_proj);
        let v4 = |c: [f32; 3], w: f32| [c[0], c[1], c[2], w];
        // Below the horizon the sun fades out instead of lighting from underneath.
        let sun_strength = (sun_dir.y * 10.0).clamp(0.0, 1.0);
        let sun_color = sun.color.map(|c| c * sun_strength);
        GpuFrame {
            view_proj: view_proj.to_cols_array_2d(),
            inv_view_proj: view_proj.inverse().to_cols_array_2d(),
            cascade_view_proj: cascades.map(|c| c.view_proj.to_cols_array_2d()),
            camera: [view.eye.x, view.eye.y, view.eye.z, self.fog_half],
            sun_dir: [
                sun_dir.x,
                sun_dir.y,
                sun_dir.z,
                if shadows { 1.0 } else { 0.0 },
            ],
            sun_color: v4(sun_color, self.options.exposure),
            sky_zenith: v4(self.scene_sky.zenith, 0.0),
            sky_horizon: v4(self.scene_sky.horizon, 0.0),
            sky_ground: v4(self.scene_sky.ground, 0.0),
            cascade_far: cascades.map(|c| c.far),
            shadow_params: [
                1.0 / self.frame.shadow_resolution as f32,
                0.0,
                self.options.debug.code(),
                fv.pixels_per_metre,
            ],
            target: [
                self.frame.target.output.code(),
                self.frame.target.far_depth(),
                0.0,
                0.0,
            ],
            cover: self.cover.uniforms()[0],
            cover_extra: self.cover.uniforms()[1],
            cover_lod: self.cover.uniforms()[2],
        }
    }
}

// The embedding API: Sylvan's frame recorded into a caller's encoder and render pass.
impl Renderer {
    /// Records the part of a frame that must happen outside the caller's render pass, into
    /// the caller's `encoder`: tile uploads and the GPU cull, each technique's per-frame
    /// work, the frame uniforms (queue writes, so submit `encoder` on `gpu.queue`) and
    /// Sylvan's shadow-cascade passes. Call once per frame before the caller's main pass,
    /// then [`Renderer::draw`] inside it.
    ///
    /// The trees are culled and their level of detail chosen for `camera`; shadows are fitted
    /// to its view up to the scene's far distance (an infinite projection is culled there).
    pub fn prepare(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        camera: &CameraMatrices,
        sun: &Sun,
    ) -> Result<PreparedFrame, RenderError> {
        let fv = self.frame_view(camera)?;
        if (camera.width, camera.height) != (self.options.width, self.options.height) {
            self.resize(gpu, camera.width, camera.height)?;
        }
        self.record_prepare(gpu, encoder, &fv, sun)
    }

    /// Records `layers` into the caller's main pass (begun on attachments matching the
    /// renderer's [`MainTarget`]), after [`Renderer::prepare`] of the same frame. It sets its
    /// own pipelines and bind groups: set the caller's again before drawing more.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, layers: Layers) -> DrawCounts {
        let mut counts = DrawCounts::default();
        pass.set_bind_group(0, &self.frame.main_bind, &[]);
        if layers.sky {
            counts.draw_calls += self.sky.draw(pass);
        }
        if layers.terrain {
            let (calls, triangles) = self.terrain.draw(pass, 0);
            counts.draw_calls += calls;
            counts.triangles += triangles;
        }
        if layers.trees {
            let culled = self.world.as_ref().map(World::culled).unwrap_or_default();
            let ctx = DrawContext {
                pass: 0,
                frame_bind: &self.frame.main_bind,
                instances: &self.instances,
                ranges: &self.instances.ranges[0],
                culled: &culled,
            };
            counts += self.technique.draw(pass, &ctx);
        }
        counts
    }

    /// The attachments the main pass is built for (Sylvan's own, or the caller's).
    pub fn target(&self) -> MainTarget {
        self.frame.target
    }

    /// After a prepared frame's submission has completed: trees drawn per technique in the
    /// camera view. Blocks until the GPU cull's counts are read back (a GPU-driven technique);
    /// for tests and tools, not for every frame of an interactive program.
    pub fn trees_drawn(&mut self, gpu: &Gpu) -> Result<BTreeMap<String, u32>, RenderError> {
        if self.world.is_some() {
            return Ok(self.read_world_counts(gpu)?.0);
        }
        Ok(self.listed_trees_drawn())
    }

    /// Trees drawn per technique from the CPU-culled instance lists (a renderer without the
    /// tiled world).
    fn listed_trees_drawn(&self) -> BTreeMap<String, u32> {
        self.technique
            .trees_drawn(&self.instances)
            .into_iter()
            .map(|(name, n)| (name.to_string(), n))
            .collect()
    }

    /// The frame's view from a caller's matrices.
    fn frame_view(&self, camera: &CameraMatrices) -> Result<FrameView, RenderError> {
        let (p, v) = (camera.proj, camera.view);
        let perspective = (p.z_axis.w + 1.0).abs() < 1e-4 && p.w_axis.w.abs() < 1e-4;
        if !perspective || p.y_axis.y <= 0.0 || p.x_axis.x <= 0.0 {
            return Err(RenderError::Option(
                "camera projection: Sylvan needs a right-handed perspective projection (clip w = −view z), e.g. glam's perspective_rh or perspective_infinite_reverse_rh".into(),
            ));
        }
        if camera.width == 0 || camera.height == 0 || !v.is_finite() || v.determinant() == 0.0 {
            return Err(RenderError::Option(format!(
                "camera: a {}x{} target and an invertible, finite view matrix are needed",
                camera.width, camera.height
            )));
        }
        let inv = v.inverse();
        let eye = inv.w_axis.truncate();
        let forward = -inv.z_axis.truncate().normalize_or(Vec3::NEG_Z);
        let fov_y = 2.0 * (1.0 / p.y_axis.y).atan();
        let view = View {
            eye,
            target: eye + forward,
            fov_y,
            aspect: p.y_axis.y / p.x_axis.x,
            near: 0.25,
            far: self.far,
        };
        Ok(FrameView {
            view,
            view_proj: p * v,
            pixels_per_metre: pixels_per_metre(fov_y, camera.height),
        })
    }
}

// Viewer hooks (`sylvan view`): read the output target and change what the frame uniforms carry
// without re-creating the renderer. None of these allocates GPU resources.
impl Renderer {
    /// The options in effect (size, technique, debug view, …).
    pub fn options(&self) -> &RenderOptions {
        &self.options
    }

    /// The output target (`OUTPUT_FORMAT`, the output size) that [`Renderer::render`] draws
    /// into; `None` for a renderer drawing into a caller's target.
    pub fn output(&self) -> Option<&RenderTarget> {
        self.targets.as_ref().map(|t| &t.output)
    }

    /// Sky and ambient colours from the next frame on.
    pub fn set_sky(&mut self, sky: sylvan_scene::Sky) {
        self.scene_sky = sky;
    }

    /// Distance fog from the next frame on.
    pub fn set_fog(&mut self, fog: sylvan_scene::Fog) {
        self.fog_half = fog.half_distance_m.max(0.0);
    }

    /// Exposure multiplier from the next frame on.
    pub fn set_exposure(&mut self, exposure: f32) {
        self.options.exposure = exposure;
    }

    /// Debug colouring from the next frame on.
    pub fn set_debug(&mut self, debug: DebugView) {
        self.options.debug = debug;
    }

    /// Turns the world's pop audit on or off ([`crate::world::PopCounts`], in the `world`
    /// statistics as `pops_*`): GPU-driven frames only.
    pub fn set_pop_audit(&mut self, gpu: &Gpu, on: bool) -> Result<(), RenderError> {
        match &mut self.world {
            Some(w) => {
                w.set_pop_audit(gpu, on);
                Ok(())
            }
            None if !on => Ok(()),
            None => Err(RenderError::Option(
                "--count-pops: the pop audit is part of the GPU-driven frame, and this one is CPU-driven — drop --cpu-driven".into(),
            )),
        }
    }

    /// Cascaded shadows on or off from the next frame on (the shadow maps stay allocated).
    pub fn set_shadows(&mut self, shadows: bool) {
        self.options.shadows = shadows;
    }
}

// Baking and technique state.
impl Renderer {
    /// How each plant's baked asset was obtained when the renderer was made (empty for
    /// techniques without a bake).
    pub fn bake_reports(&self) -> &[BakeReport] {
        &self.bake_reports
    }

    /// Name of the technique drawing the trees.
    pub fn technique_name(&self) -> &'static str {
        self.technique.name()
    }

    /// A picture of the technique's baked images (sRGB, premultiplied colour over grey), when
    /// it bakes any.
    pub fn atlas_preview(&self) -> Option<&image::RgbaImage> {
        self.technique.atlas_preview()
    }

    /// Times a per-frame buffer had to grow (0 once the scene's worst frame has been seen).
    pub fn buffer_reallocations(&self) -> u32 {
        self.technique.reallocations()
    }
}

// A renderer moves between threads (an engine's render thread, Bevy's render world keeps it
// behind a mutex): every technique is `Send`.
const _: fn() = || {
    fn send<T: Send>() {}
    send::<Renderer>();
};

/// The ground cover's settings for `scene` (see [`GroundCover`]): the scene's `[sky]`
/// switches, its trees' mean height and density, where trees end and their widest crown.
fn cover_settings(scene: &Scene, source: &Source, far: f32) -> CoverSettings {
    let area = (scene.terrain.size[0] * scene.terrain.size[1]).max(1.0);
    let mean_height_m = if scene.trees.is_empty() {
        let n = scene.species.len().max(1) as f32;
        scene
            .species
            .iter()
            .map(|s| 0.5 * (s.height_m[0] + s.height_m[1]))
            .sum::<f32>()
            / n
    } else {
        scene.trees.iter().map(|t| t.height).sum::<f32>() / scene.trees.len() as f32
    };
    let tallest = scene.trees.iter().map(|t| t.height).fold(
        scene
            .species
            .iter()
            .map(|s| s.height_m[1])
            .fold(0.0, f32::max),
        f32::max,
    );
    let crown_m = crate::world::cover::crown_disks(source)
        .iter()
        .map(|(o, r)| (o.length() + r) * tallest)
        .fold(0.0, f32::max);
    CoverSettings {
        contrast: scene.sky.ground_contrast,
        enabled: scene.sky.ground_occlusion,
        mean_height_m,
        fallback_density: (scene.estimated_trees() / area as f64) as f32,
        trees_end_m: scene.world.tree_distance_m,
        reach_m: scene.world.tree_distance_m.min(far),
        prefetch_m: scene.world.prefetch_m,
        crown_m,
    }
}
