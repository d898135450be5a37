//! Sylvan forests inside Bevy 0.20.
//!
//! Add [`SylvanPlugin`], spawn a [`Forest`] (from a Sylvan scene file, or from a
//! [`sylvan_scene::Scene`] built in code: terrain, species, density), and mark the camera that
//! shows it with [`ForestCamera`]:
//!
//! ```no_run
//! use bevy::prelude::*;
//! use sylvan_bevy::{Forest, ForestCamera, SylvanPlugin};
//!
//! fn setup(mut commands: Commands) {
//!     commands.spawn(Forest::load("assets/scenes/example.toml").expect("scene"));
//!     commands.spawn((Camera3d::default(), ForestCamera, Transform::from_xyz(1000.0, 30.0, 900.0)));
//!     commands.spawn((DirectionalLight::default(), Transform::default().looking_to(Vec3::new(-0.3, -0.6, 0.7), Vec3::Y)));
//! }
//!
//! App::new().add_plugins((DefaultPlugins, SylvanPlugin)).add_systems(Startup, setup).run();
//! ```
//!
//! **How it draws.** The forest is a `sylvan_render::Renderer` built on Bevy's own device
//! (`Gpu::from_parts`) for the camera's main texture (its format, its MSAA sample count,
//! Bevy's reversed-Z `Depth32Float`), through Sylvan's embedding API. Two systems run in the
//! camera's `Core3d` schedule:
//! - before the main pass, `prepare` records Sylvan's GPU cull, level-of-detail work and
//!   shadow-cascade passes into Bevy's command encoder;
//! - between `main_opaque_pass_3d` and `main_transparent_pass_3d`, `draw` begins a pass on
//!   Bevy's main texture and depth buffer (loading both) and records the trees (and, by
//!   [`Forest::layers`], Sylvan's terrain and sky at the far plane). Bevy's opaque meshes and
//!   Sylvan's trees hide each other by depth; Bevy's transparent meshes draw over both.
//!
//! **Light.** With [`ForestLighting::Bevy`] the sun is the first `DirectionalLight`: its
//! direction, and its colour × illuminance × the camera's exposure ÷ π as Sylvan's sun
//! irradiance (Sylvan's Lambert term has no 1/π, Bevy's has), and the scene's sky colours
//! scaled by the same factor. On an HDR camera Sylvan writes exposed linear radiance and
//! Bevy's tonemapper maps it with everything else; on an LDR camera Sylvan applies its own
//! tone curve. [`ForestLighting::Scene`] keeps the scene file's sun and sky, as
//! `sylvan render` draws them.
//!
//! **What it does not do** (said plainly):
//! - Shadows are Sylvan's own cascades: trees shadow Sylvan's terrain and each other, but
//!   they cast nothing into Bevy's shadow maps, and Bevy's meshes cast nothing on the trees.
//! - One camera draws the forest (the first [`ForestCamera`]): Sylvan's frame uniforms are
//!   queue writes, so two views in one frame would share the last one's.
//! - The renderer (and any bake it needs, from Sylvan's cache when present) is built on the
//!   first frame the camera renders, blocking that frame.

use bevy::core_pipeline::Core3d;
use bevy::core_pipeline::core_3d::{
    CORE_3D_DEPTH_FORMAT, main_opaque_pass_3d, main_transparent_pass_3d,
};
use bevy::prelude::*;
use bevy::render::renderer::{
    RenderAdapter, RenderContext, RenderDevice, RenderInstance, RenderQueue, ViewQuery,
};
use bevy::render::sync_world::MainEntity;
use bevy::render::view::{ExtractedView, ViewDepthStencilTexture, ViewTarget};
use bevy::render::{Extract, ExtractSchedule, RenderApp};
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Instant;
use sylvan_gpu::Gpu;
use sylvan_plant::Plant;
use sylvan_render::{
    CameraMatrices, ColorOutput, DepthConvention, Layers, MainTarget, RenderOptions, Renderer,
};
use sylvan_scene::{Scene, Sun};

/// Adds the forest's extraction and its two `Core3d` systems.
pub struct SylvanPlugin;

impl Plugin for SylvanPlugin {
    fn build(&self, app: &mut App) {
        let stats = ForestStats::default();
        app.insert_resource(stats.clone());
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            warn!(
                "SylvanPlugin: no render app (headless without rendering?): forests are not drawn"
            );
            return;
        };
        render_app
            .insert_resource(stats)
            .init_resource::<ExtractedForest>()
            .insert_resource(ForestRenderer::default())
            .add_systems(ExtractSchedule, extract_forest)
            .add_systems(
                Core3d,
                (
                    prepare_forest.before(main_opaque_pass_3d),
                    draw_forest
                        .after(main_opaque_pass_3d)
                        .before(main_transparent_pass_3d),
                ),
            );
    }
}

/// A Sylvan forest: a scene (terrain, species, tree population, sky) and its plants, drawn
/// with a Sylvan technique by the [`ForestCamera`]. Only the first `Forest` is drawn.
#[derive(Component, Clone)]
pub struct Forest {
    source: Arc<ForestSource>,
    /// The technique drawing the trees (a registry name: `auto`, `geometry`, `octahedral`, …).
    pub technique: String,
    /// What Sylvan draws into Bevy's pass: trees only (Bevy draws the ground and sky), or
    /// Sylvan's terrain and sky too.
    pub layers: Layers,
    /// Where the sun and sky come from.
    pub lighting: ForestLighting,
    /// Technique parameters (`NAME.KEY=VALUE`, as `sylvan --set`).
    pub settings: Vec<String>,
    /// Sylvan's shadow cascades on or off.
    pub shadows: bool,
}

struct ForestSource {
    scene: Scene,
    plants: Vec<Plant>,
}

/// Why a [`Forest`] could not be made.
#[derive(Debug)]
pub struct ForestError(pub String);

impl std::fmt::Display for ForestError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ForestError {}

impl Forest {
    /// A forest from a Sylvan scene file (`.toml`); its plants are loaded now.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ForestError> {
        let scene = Scene::load(path.as_ref()).map_err(|e| ForestError(e.to_string()))?;
        Self::from_scene(scene)
    }

    /// A forest from a scene built in code (terrain heights, species, density or placed
    /// trees); the species' plants (presets or files) are loaded now.
    pub fn from_scene(scene: Scene) -> Result<Self, ForestError> {
        let plants = sylvan_render::load_plants(&scene).map_err(|e| ForestError(e.to_string()))?;
        Ok(Self::with_plants(scene, plants))
    }

    /// A forest of `scene` with its plants given (one per species, in species order).
    pub fn with_plants(scene: Scene, plants: Vec<Plant>) -> Self {
        Self {
            source: Arc::new(ForestSource { scene, plants }),
            technique: "auto".into(),
            layers: Layers::TREES,
            lighting: ForestLighting::Bevy,
            settings: Vec::new(),
            shadows: true,
        }
    }

    /// The scene drawn.
    pub fn scene(&self) -> &Scene {
        &self.source.scene
    }

    /// With technique `name`.
    pub fn with_technique(mut self, name: &str) -> Self {
        self.technique = name.into();
        self
    }

    /// With `layers`.
    pub fn with_layers(mut self, layers: Layers) -> Self {
        self.layers = layers;
        self
    }

    /// With `lighting`.
    pub fn with_lighting(mut self, lighting: ForestLighting) -> Self {
        self.lighting = lighting;
        self
    }

    /// The scene's terrain height at world `(x, z)` (for placing Bevy objects on it).
    pub fn height_at(&self, x: f32, z: f32) -> f32 {
        self.source.scene.terrain.height_at(x, z)
    }
}

/// A forest described from the Bevy side: a terrain (extent, sample grid and a height function
/// — the one the app's own ground mesh uses) and species (a Sylvan preset name or a plant
/// file, a height range, trees per hectare), seeded over the terrain tile by tile as a scene
/// file's `method = "tiled"` placement is.
///
/// ```no_run
/// let forest = sylvan_bevy::ForestBuilder::new([2000.0, 2000.0], [129, 129], |x, z| {
///     12.0 * (x * 0.004).sin() * (z * 0.003).cos()
/// })
/// .species("pine", "pine", [14.0, 22.0], 150.0)
/// .species("birch-ish", "prunus", [6.0, 10.0], 40.0)
/// .build()
/// .expect("forest");
/// ```
pub struct ForestBuilder {
    scene: Scene,
    layouts: Vec<sylvan_scene::SpeciesLayout>,
    seed: u64,
}

impl ForestBuilder {
    /// A terrain of `size` metres (X, Z) sampled on `resolution` points (each ≥ 2) of
    /// `height(x, z)`, with the built-in scene's sun, sky and camera.
    pub fn new(size: [f32; 2], resolution: [u32; 2], height: impl Fn(f32, f32) -> f32) -> Self {
        let [nx, nz] = resolution.map(|n| n.max(2));
        let mut heights = Vec::with_capacity((nx * nz) as usize);
        for r in 0..nz {
            for c in 0..nx {
                let x = size[0] * c as f32 / (nx - 1) as f32;
                let z = size[1] * r as f32 / (nz - 1) as f32;
                heights.push(height(x, z));
            }
        }
        let mut scene = Scene::builtin_grove();
        scene.terrain = sylvan_scene::Terrain {
            size,
            resolution: [nx, nz],
            heights,
        };
        scene.species.clear();
        scene.trees.clear();
        scene.seeded = None;
        scene.source = None;
        scene.camera = sylvan_scene::Camera::overview(&scene.terrain);
        Self {
            scene,
            layouts: Vec::new(),
            seed: 1,
        }
    }

    /// Adds a species: `plant` is a preset name (`sylvan plant --list`) or a `.lsys`, `.glb`,
    /// `.gltf` or `.obj` path; heights uniform in `height_m`; `per_hectare` trees per hectare.
    pub fn species(
        mut self,
        name: &str,
        plant: &str,
        height_m: [f32; 2],
        per_hectare: f32,
    ) -> Self {
        let source = if sylvan_plant::PRESETS.contains(&plant) {
            sylvan_scene::PlantSource::Preset(plant.into())
        } else {
            sylvan_scene::PlantSource::File(plant.into())
        };
        self.layouts.push(sylvan_scene::SpeciesLayout {
            species: self.scene.species.len() as u32,
            height_m,
            density: sylvan_scene::Density::PerHectare(per_hectare),
        });
        self.scene.species.push(sylvan_scene::Species {
            name: name.into(),
            plant: source,
            height_m,
        });
        self
    }

    /// The placement seed (the same seed, the same trees).
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// The sun used by [`ForestLighting::Scene`] (and when there is no `DirectionalLight`).
    pub fn sun(mut self, sun: Sun) -> Self {
        self.scene.sun = sun;
        self
    }

    /// Places the species and loads their plants.
    pub fn build(mut self) -> Result<Forest, ForestError> {
        if self.scene.species.is_empty() {
            return Err(ForestError(
                "a forest needs at least one species — call ForestBuilder::species".into(),
            ));
        }
        self.scene.seeded =
            sylvan_scene::SeededForest::new(self.scene.terrain.size, &self.layouts, self.seed, &[])
                .map_err(|e| ForestError(e.to_string()))?
                .map(Arc::new);
        Forest::from_scene(self.scene)
    }
}

/// Where the forest's sun and sky come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ForestLighting {
    /// The first `DirectionalLight` (direction, colour × illuminance × exposure ÷ π), the
    /// scene's sky scaled to match; the scene's sun when there is no directional light.
    #[default]
    Bevy,
    /// The scene file's sun and sky, exactly as `sylvan render` draws them.
    Scene,
}

/// Marks the camera that draws the forest.
#[derive(Component, Clone, Copy, Default, Debug)]
pub struct ForestCamera;

/// What the forest cost in the last frame, shared by the main and render worlds.
#[derive(Resource, Clone, Default)]
pub struct ForestStats(Arc<Mutex<ForestFrame>>);

/// One frame's figures (see [`ForestStats::last`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ForestFrame {
    /// Frames drawn so far.
    pub frames: u64,
    /// CPU milliseconds of the plugin's two systems (Sylvan's preparation, recording the
    /// draw) in the last frame.
    pub cpu_ms: f64,
    /// Draw calls Sylvan recorded in Bevy's main pass in the last frame.
    pub draw_calls: u32,
    /// Milliseconds the renderer took to build (bakes included), once.
    pub build_ms: f64,
    /// The technique drawing.
    pub technique: String,
    /// Why the forest is not drawn, when it is not.
    pub error: Option<String>,
}

impl ForestStats {
    /// The last frame's figures.
    pub fn last(&self) -> ForestFrame {
        self.0.lock().map(|f| f.clone()).unwrap_or_default()
    }

    fn update(&self, f: impl FnOnce(&mut ForestFrame)) {
        if let Ok(mut frame) = self.0.lock() {
            f(&mut frame);
        }
    }
}

/// The render world's copy of the main world's forest, camera and light.
#[derive(Resource, Default)]
struct ExtractedForest {
    forest: Option<Forest>,
    camera: Option<Entity>,
    exposure: f32,
    light: Option<(Vec3, LinearRgba, f32)>,
}

/// The forest cameras (with their exposure, when set).
type ForestCameras<'w, 's> =
    Query<'w, 's, (Entity, Option<&'static bevy::camera::Exposure>), With<ForestCamera>>;

fn extract_forest(
    forests: Extract<Query<&Forest>>,
    cameras: Extract<ForestCameras>,
    lights: Extract<Query<(&DirectionalLight, &GlobalTransform)>>,
    mut out: ResMut<ExtractedForest>,
) {
    out.forest = forests.iter().next().cloned();
    let camera = cameras.iter().next();
    out.camera = camera.map(|(e, _)| e);
    out.exposure = camera
        .and_then(|(_, x)| x.copied())
        .unwrap_or_default()
        .exposure();
    out.light = lights
        .iter()
        .next()
        .map(|(l, t)| (*t.back(), l.color.to_linear(), l.illuminance));
}

/// What a renderer is built for: the forest's source, technique and settings, and the target.
type BuildKey = (usize, String, Vec<String>, MainTarget);

/// The Sylvan renderer, built for the forest camera's target on first use.
#[derive(Resource, Default)]
struct ForestRenderer(Mutex<RendererSlot>);

#[derive(Default)]
struct RendererSlot {
    built: Option<Built>,
    /// What the last failed build was for: not retried until the forest or target changes.
    failed: Option<BuildKey>,
}

struct Built {
    gpu: Gpu,
    renderer: Renderer,
    key: BuildKey,
    /// Whether the last `prepare` succeeded (draw only then).
    prepared: bool,
}

/// The colour output for a main texture format: exposed radiance for Bevy's tonemapper on
/// HDR formats, Sylvan's tone curve on 8-bit sRGB ones.
fn output_for(format: wgpu::TextureFormat) -> Result<ColorOutput, String> {
    use wgpu::TextureFormat as F;
    match format {
        F::Rgba16Float | F::Rgba32Float | F::Rg11b10Ufloat => Ok(ColorOutput::Exposed),
        F::Rgba8UnormSrgb | F::Bgra8UnormSrgb => Ok(ColorOutput::ToneMapped),
        other => Err(format!(
            "camera main texture {other:?}: Sylvan draws into HDR (Rgba16Float) or sRGB 8-bit main textures — add `Hdr` to the camera"
        )),
    }
}

#[allow(clippy::too_many_arguments)] // a Bevy system: each parameter is one resource
fn prepare_forest(
    view: ViewQuery<(&ExtractedView, &ViewTarget, &Msaa, &MainEntity)>,
    extracted: Res<ExtractedForest>,
    state: Res<ForestRenderer>,
    stats: Res<ForestStats>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    adapter: Res<RenderAdapter>,
    instance: Res<RenderInstance>,
    mut ctx: RenderContext,
) {
    let (view, target, msaa, main) = view.into_inner();
    let Some(forest) = &extracted.forest else {
        return;
    };
    if extracted.camera != Some(main.id()) {
        return;
    }
    let Ok(mut guard) = state.0.lock() else {
        return;
    };
    let slot = &mut *guard;
    let start = Instant::now();
    let output = match output_for(target.main_texture_format()) {
        Ok(o) => o,
        Err(e) => return report(&stats, slot, None, e),
    };
    let main_target = MainTarget {
        color_format: target.main_texture_format(),
        depth_format: CORE_3D_DEPTH_FORMAT,
        sample_count: msaa.samples(),
        depth: DepthConvention::Reversed,
        output,
    };
    let key = (
        Arc::as_ptr(&forest.source) as usize,
        forest.technique.clone(),
        forest.settings.clone(),
        main_target,
    );
    if slot.built.as_ref().is_none_or(|b| b.key != key) {
        // Built once per forest, technique and target; a failure is reported once and
        // retried only when one of them changes.
        if slot.failed.as_ref() == Some(&key) {
            return;
        }
        let gpu = Gpu::from_parts(
            (**instance).clone(),
            (**adapter).clone(),
            device.wgpu_device().clone(),
            (**queue).clone(),
        );
        let settings = match forest
            .settings
            .iter()
            .map(|s| sylvan_scene::Setting::from_arg(s).map_err(|e| e.to_string()))
            .collect::<Result<Vec<_>, _>>()
        {
            Ok(s) => s,
            Err(e) => return report(&stats, slot, Some(key), e),
        };
        let options = RenderOptions {
            technique: forest.technique.clone(),
            settings,
            shadows: forest.shadows,
            ..Default::default()
        };
        let src = &forest.source;
        match Renderer::for_target(
            &gpu,
            &src.scene,
            &src.plants,
            &options,
            main_target,
            &mut |_, _, _| {},
        ) {
            Ok(renderer) => {
                let ms = start.elapsed().as_secs_f64() * 1e3;
                stats.update(|f| {
                    f.build_ms = ms;
                    f.technique = renderer.technique_name().to_string();
                    f.error = None;
                });
                slot.built = Some(Built {
                    gpu,
                    renderer,
                    key,
                    prepared: false,
                });
                slot.failed = None;
            }
            Err(e) => return report(&stats, slot, Some(key), e.to_string()),
        }
    }
    let Some(built) = slot.built.as_mut() else {
        return;
    };
    let start = Instant::now();
    let scene = &forest.source.scene;
    let mut sun = scene.sun;
    let mut sky = scene.sky;
    if let (ForestLighting::Bevy, Some((dir, color, lux))) = (forest.lighting, extracted.light) {
        let scale = lux * extracted.exposure / std::f32::consts::PI;
        let rgb = [color.red * scale, color.green * scale, color.blue * scale];
        let luma = |c: [f32; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
        let k = luma(rgb) / luma(scene.sun.color).max(1e-6);
        sun = Sun {
            azimuth_deg: dir.x.atan2(dir.z).to_degrees(),
            elevation_deg: dir.y.clamp(-1.0, 1.0).asin().to_degrees(),
            color: rgb,
        };
        for c in [&mut sky.zenith, &mut sky.horizon, &mut sky.ground] {
            *c = c.map(|v| v * k);
        }
    }
    built.renderer.set_sky(sky);
    built.renderer.set_shadows(forest.shadows);
    let camera = CameraMatrices {
        view: glam::Mat4::from_cols_array(
            &view.world_from_view.to_matrix().inverse().to_cols_array(),
        ),
        proj: glam::Mat4::from_cols_array(&view.clip_from_view.to_cols_array()),
        width: view.viewport.z.max(1),
        height: view.viewport.w.max(1),
    };
    let encoder = ctx.command_encoder();
    match built.renderer.prepare(&built.gpu, encoder, &camera, &sun) {
        Ok(_) => built.prepared = true,
        Err(e) => {
            built.prepared = false;
            stats.update(|f| f.error = Some(e.to_string()));
        }
    }
    let ms = start.elapsed().as_secs_f64() * 1e3;
    stats.update(|f| f.cpu_ms = ms);
}

/// Logs why the forest is not drawn (once per reason) and drops the renderer.
fn report(stats: &ForestStats, slot: &mut RendererSlot, key: Option<BuildKey>, error: String) {
    if stats.last().error.as_deref() != Some(error.as_str()) {
        error!("sylvan: the forest is not drawn: {error}");
    }
    slot.built = None;
    slot.failed = key;
    stats.update(|f| f.error = Some(error));
}

fn draw_forest(
    view: ViewQuery<(&ViewTarget, &ViewDepthStencilTexture, &MainEntity)>,
    extracted: Res<ExtractedForest>,
    state: Res<ForestRenderer>,
    stats: Res<ForestStats>,
    mut ctx: RenderContext,
) {
    let (target, depth, main) = view.into_inner();
    let Some(forest) = &extracted.forest else {
        return;
    };
    if extracted.camera != Some(main.id()) {
        return;
    }
    let Ok(slot) = state.0.lock() else {
        return;
    };
    let Some(built) = slot.built.as_ref().filter(|b| b.prepared) else {
        return;
    };
    let start = Instant::now();
    let color = [Some(target.get_color_attachment())];
    let encoder = ctx.command_encoder();
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("sylvan_forest"),
        color_attachments: &color,
        depth_stencil_attachment: Some(depth.get_attachment(wgpu::StoreOp::Store)),
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    });
    let counts = built.renderer.draw(&mut pass, forest.layers);
    drop(pass);
    let ms = start.elapsed().as_secs_f64() * 1e3;
    stats.update(|f| {
        f.frames += 1;
        f.cpu_ms += ms;
        f.draw_calls = counts.draw_calls;
    });
}
