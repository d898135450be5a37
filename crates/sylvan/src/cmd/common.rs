//! Flags shared by `render`, `bench` (and later `view`): raw strings → validated values.

use anyhow::{Context, Result, bail};
use glam::Vec3;
use std::path::{Path, PathBuf};
use sylvan_render::bake::CachePolicy;
use sylvan_render::{RenderOptions, registry};
use sylvan_scene::{Camera, Scene, Setting, Sun};

/// Scene and view flags common to the frame commands.
#[derive(clap::Args, Debug, Clone)]
pub struct ViewArgs {
    /// Scene file (TOML), or `builtin:forest` / `builtin:grove`. Without it: the built-in
    /// forest (`builtin:forest`).
    pub scene: Option<PathBuf>,
    /// Output size in pixels, WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x720")]
    pub size: String,
    /// Tree representation: a registered technique (`sylvan params` lists them), or `auto`
    /// for the scene's LOD chain [default: `auto` for the built-in forest, `geometry` (the
    /// reference) for a scene file]
    #[arg(long)]
    pub technique: Option<String>,
    /// Samples per pixel (a perfect square; the reference uses 16).
    #[arg(long, default_value_t = 1)]
    pub spp: u32,
    /// Camera override: X,Y,Z:TX,TY,TZ (eye and target, metres).
    #[arg(long)]
    pub camera: Option<String>,
    /// Sun override: AZIMUTH,ELEVATION in degrees (azimuth from +Z towards +X).
    #[arg(long)]
    pub sun: Option<String>,
    /// Disable shadows.
    #[arg(long)]
    pub no_shadows: bool,
    /// The ground sees the whole sky, trees or not (the scene's `[sky] ground_occlusion =
    /// false`: no BN12 eq. 10–12 ground cover).
    #[arg(long)]
    pub no_ground_occlusion: bool,
    /// Shadow-map resolution per cascade.
    #[arg(long, default_value_t = 2048)]
    pub shadow_res: u32,
    /// How far from the eye shadows are cast, metres (the four cascades split this range; a
    /// reference of far trees needs it to reach them).
    #[arg(long, value_name = "M", default_value_t = 1500.0, value_parser = parse_shadow_distance)]
    pub shadow_distance: f32,
    /// Start the first shadow cascade this far from the eye, metres (0: at the eye). Nearer
    /// receivers are lit: for a reference of a far band with finer shadows — every cascade
    /// texel on that band (with a narrow field of view and `--shadow-res 8192`, as
    /// `scripts/measure-far-converged.sh` does)
    #[arg(long, value_name = "M", default_value_t = 0.0, value_parser = parse_shadow_near)]
    pub shadow_near: f32,
    /// Feed a GPU-driven technique from CPU-culled lists of every tree placed up front (the
    /// frame before the tiled world; for comparisons).
    #[arg(long)]
    pub cpu_driven: bool,
    /// Draw every shadow caster in each cascade's box, not only those whose shadow can reach
    /// what the camera sees (the frame before the caster cull; for comparisons).
    #[arg(long)]
    pub no_caster_cull: bool,
    /// Where a `wang` forest's tiles are seeded: `gpu`, `cpu` (the tile workers), or `auto`
    /// (the GPU on a hardware adapter, the CPU on a software rasteriser). The trees are the same.
    #[arg(long, value_name = "auto|gpu|cpu", default_value = "auto", value_parser = parse_seeds)]
    pub seeds: sylvan_render::Seeds,
    /// Cull the camera's trees against the previous frame's depth pyramid (GPU-driven
    /// techniques; one frame late, so a tree uncovered by the camera's move may be missing for
    /// a frame; `render` draws its first frame twice, so that the picture shows what the cull
    /// keeps).
    #[arg(long)]
    pub occlusion_cull: bool,
    /// The LOD chain of `auto`, replacing the scene's `[lod]` (its chain or band tables):
    /// comma-separated "technique:START-END" entries in metres, the last open-ended, e.g.
    /// "geometry:0-40,hbt:40-150,zfield:150-1000,shadermap:1000-".
    #[arg(long, value_name = "CHAIN")]
    pub chain: Option<String>,
    #[command(flatten)]
    pub bake: BakeArgs,
}

/// Technique parameters and the cache, shared by every command that may bake.
#[derive(clap::Args, Debug, Clone)]
pub struct BakeArgs {
    /// A technique parameter, TECHNIQUE.KEY=VALUE (repeatable), over the scene's
    /// `[technique.NAME]` tables; `sylvan params` lists every key.
    #[arg(long = "set", value_name = "TECHNIQUE.KEY=VALUE")]
    pub set: Vec<String>,
    /// Folder for baked assets (default: $SYLVAN_CACHE_DIR, $XDG_CACHE_HOME/sylvan or ~/.cache/sylvan).
    #[arg(long)]
    pub cache_dir: Option<PathBuf>,
    /// Bake every time; read and write no cache files.
    #[arg(long)]
    pub no_cache: bool,
}

impl BakeArgs {
    /// The `--set` settings, each parsed and checked against its technique's schema.
    pub fn settings(&self) -> Result<Vec<Setting>> {
        let settings = self
            .set
            .iter()
            .map(|a| Setting::from_arg(a).map_err(anyhow::Error::msg))
            .collect::<Result<Vec<_>>>()?;
        registry::check_settings(&settings)?;
        Ok(settings)
    }

    /// The cache policy.
    pub fn cache(&self) -> CachePolicy {
        match (&self.cache_dir, self.no_cache) {
            (_, true) => CachePolicy::Off,
            (Some(d), false) => CachePolicy::Dir(d.clone()),
            (None, false) => CachePolicy::Default,
        }
    }
}

/// Everything a frame command needs, validated.
pub struct Resolved {
    pub scene: Scene,
    pub camera: Camera,
    pub sun: Sun,
    pub options: RenderOptions,
    /// The command line's changes to the scene (the viewer applies them to each reload).
    pub overrides: SceneOverrides,
}

/// What the command line changes in a loaded scene: `--chain` and `--no-ground-occlusion`.
#[derive(Debug, Clone, Default)]
pub struct SceneOverrides {
    /// `--chain`'s entries, replacing the scene's `[lod]` chain or band tables.
    pub chain: Option<Vec<String>>,
    /// `--no-ground-occlusion`.
    pub no_ground_occlusion: bool,
}

impl SceneOverrides {
    /// Applies the overrides to `scene` (as loaded from its file).
    pub fn apply(&self, scene: &mut Scene) {
        if self.no_ground_occlusion {
            scene.sky.ground_occlusion = false;
        }
        if let Some(chain) = &self.chain {
            scene.lod_chain = chain.clone();
            scene.lod_bands.clear();
        }
    }
}

/// An error and its causes on one line, without repeating a cause already in the message (as
/// `main` prints errors and the viewer shows them).
pub fn one_line(e: &anyhow::Error) -> String {
    let mut out = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !out.contains(&c) {
            out.push_str(": ");
            out.push_str(&c);
        }
    }
    out.replace('\n', " ")
}

/// Parses `WxH`.
pub fn parse_size(s: &str) -> Result<(u32, u32)> {
    let bad = || {
        anyhow::anyhow!(
            "--size {s}: expected WIDTHxHEIGHT with both at least 1, e.g. --size 1280x720"
        )
    };
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h): (u32, u32) = (
        w.trim().parse().map_err(|_| bad())?,
        h.trim().parse().map_err(|_| bad())?,
    );
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(bad());
    }
    Ok((w, h))
}

fn parse_floats<const N: usize>(flag: &str, s: &str, example: &str) -> Result<[f32; N]> {
    let parts: Vec<&str> = s.split(',').collect();
    let bad = || {
        anyhow::anyhow!("{flag} {s}: expected {N} comma-separated numbers, e.g. {flag} {example}")
    };
    if parts.len() != N {
        return Err(bad());
    }
    let mut out = [0.0; N];
    for (o, p) in out.iter_mut().zip(parts) {
        *o = p
            .trim()
            .parse::<f32>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(bad)?;
    }
    Ok(out)
}

/// Parses `X,Y,Z:TX,TY,TZ` over `base` (keeps its field of view).
pub fn parse_camera(s: &str, base: Camera) -> Result<Camera> {
    let example = "0,120,-900:0,40,0";
    let (eye, target) = s.split_once(':').ok_or_else(|| {
        anyhow::anyhow!("--camera {s}: expected X,Y,Z:TX,TY,TZ, e.g. --camera {example}")
    })?;
    let eye = Vec3::from(parse_floats::<3>("--camera", eye, example)?);
    let target = Vec3::from(parse_floats::<3>("--camera", target, example)?);
    if eye.distance(target) < 1e-3 {
        bail!("--camera {s}: eye and target coincide — give a target away from the eye");
    }
    Ok(Camera {
        position: eye,
        look_at: target,
        ..base
    })
}

/// Parses `AZIMUTH,ELEVATION` over `base` (keeps its colour).
pub fn parse_sun(s: &str, base: Sun) -> Result<Sun> {
    let [az, el] = parse_floats::<2>("--sun", s, "140,35")?;
    if !(-90.0..=90.0).contains(&el) {
        bail!("--sun {s}: elevation must be between -90 and 90 degrees");
    }
    Ok(Sun {
        azimuth_deg: az,
        elevation_deg: el,
        ..base
    })
}

/// Checks a scene's `[technique.NAME]` and `[[lod.band]]` parameters against the registry, so
/// a bad key is reported with its place before anything is prepared.
pub fn check_scene_settings(scene: &Scene) -> Result<()> {
    registry::check_settings(&scene.technique_params)?;
    for band in &scene.lod_bands {
        registry::check_settings(&band.params)?;
    }
    Ok(())
}

/// A built-in scene named on the command line in place of a scene file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Builtin {
    /// `builtin:forest`: [`Scene::builtin_default`], the forest to the horizon.
    Forest,
    /// `builtin:grove`: [`Scene::builtin_grove`], the small grove of the older benchmarks.
    Grove,
}

/// The built-in scene `path` names (`builtin:forest`, `builtin:grove`), if it names one.
pub fn builtin(path: &Path) -> Option<Builtin> {
    match path.to_str()? {
        "builtin:forest" => Some(Builtin::Forest),
        "builtin:grove" => Some(Builtin::Grove),
        _ => None,
    }
}

/// Loads the scene: a file, a named built-in one, or without a path the built-in forest.
pub fn load_scene(path: Option<&Path>) -> Result<Scene> {
    match path.map(|p| (p, builtin(p))) {
        None | Some((_, Some(Builtin::Forest))) => Ok(Scene::builtin_default()),
        Some((_, Some(Builtin::Grove))) => Ok(Scene::builtin_grove()),
        Some((p, None)) => Ok(Scene::load(p)?),
    }
}

impl ViewArgs {
    /// The technique asked for, or the default: `auto` (the chain to the horizon) for the
    /// built-in forest, `geometry` (the reference) for a scene file.
    pub fn technique_name(&self) -> &str {
        match (&self.technique, self.scene.as_deref().map(builtin)) {
            (Some(t), _) => t,
            (None, None | Some(Some(Builtin::Forest))) => "auto",
            (None, Some(_)) => "geometry",
        }
    }

    /// Validates every flag and loads the scene.
    pub fn resolve(&self) -> Result<Resolved> {
        let (width, height) = parse_size(&self.size)?;
        if self.shadow_near >= self.shadow_distance {
            bail!(
                "--shadow-near {} is not nearer than --shadow-distance {}: make it smaller, or the shadow distance larger",
                self.shadow_near,
                self.shadow_distance
            );
        }
        let technique = registry::find(self.technique_name())?.name.to_string();
        let options = RenderOptions {
            width,
            height,
            spp: self.spp,
            technique,
            shadows: !self.no_shadows,
            shadow_resolution: self.shadow_res,
            shadow_distance: self.shadow_distance,
            shadow_near: self.shadow_near,
            settings: self.bake.settings()?,
            cache: self.bake.cache(),
            cpu_driven: self.cpu_driven,
            caster_cull: !self.no_caster_cull,
            seeds: self.seeds,
            occlusion_cull: self.occlusion_cull,
            ..Default::default()
        };
        options.factor()?;
        let mut scene = load_scene(self.scene.as_deref())?;
        let overrides = SceneOverrides {
            chain: self
                .chain
                .as_ref()
                .map(|c| c.split(',').map(|e| e.trim().to_string()).collect()),
            no_ground_occlusion: self.no_ground_occlusion,
        };
        if let Some(chain) = &overrides.chain {
            sylvan_render::technique::lod::parse_chain(chain)
                .map_err(|e| anyhow::anyhow!("--chain: {e}"))?;
            if self.technique_name() != "auto" {
                bail!(
                    "--chain is the chain of `auto`, and the technique is `{}` — add --technique auto",
                    self.technique_name()
                );
            }
        }
        overrides.apply(&mut scene);
        check_scene_settings(&scene)?;
        let camera = match &self.camera {
            Some(c) => parse_camera(c, scene.camera)?,
            None => scene.camera,
        };
        let sun = match &self.sun {
            Some(s) => parse_sun(s, scene.sun)?,
            None => scene.sun,
        };
        Ok(Resolved {
            scene,
            camera,
            sun,
            options,
            overrides,
        })
    }
}

/// Opens the GPU, loads plants and prepares a renderer (baking what the technique needs, with
/// a progress bar on a terminal); returns it with the preparation time (ms).
pub fn prepare(r: &Resolved) -> Result<(sylvan_gpu::Gpu, sylvan_render::Renderer, f64)> {
    let gpu = sylvan_gpu::Gpu::new()?;
    let start = std::time::Instant::now();
    let plants = sylvan_render::load_plants(&r.scene)?;
    let bar = BakeBar::new();
    let renderer = sylvan_render::Renderer::with_progress(
        &gpu,
        &r.scene,
        &plants,
        &r.options,
        &mut |plant, done, total| bar.update(plant, done, total),
    )
    .context("preparing the renderer")?;
    bar.finish();
    for report in renderer.bake_reports() {
        if let Some(why) = &report.stale {
            eprintln!("note: re-baked {} ({why})", report.plant);
        }
    }
    Ok((gpu, renderer, start.elapsed().as_secs_f64() * 1e3))
}

/// A progress bar for bakes, drawn only on a terminal (stderr), so JSON on stdout stays clean.
pub struct BakeBar {
    bar: Option<indicatif::ProgressBar>,
}

impl BakeBar {
    /// A hidden bar unless stderr is a terminal.
    pub fn new() -> Self {
        use std::io::IsTerminal;
        Self {
            bar: std::io::stderr().is_terminal().then(|| {
                let b = indicatif::ProgressBar::new(0);
                b.set_style(
                    indicatif::ProgressStyle::with_template(
                        "baking {msg:12} [{bar:30}] {pos}/{len} images ({elapsed})",
                    )
                    .expect("valid template")
                    .progress_chars("=> "),
                );
                b
            }),
        }
    }

    /// Shows `done` of `total` for `plant`.
    pub fn update(&self, plant: &str, done: usize, total: usize) {
        if let Some(b) = &self.bar {
            b.set_length(total as u64);
            b.set_position(done as u64);
            b.set_message(plant.to_string());
        }
    }

    /// Clears the bar.
    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

impl Default for BakeBar {
    fn default() -> Self {
        Self::new()
    }
}

/// The path time of frame `i` of `n` when a camera path of `duration` seconds is replayed in `n`
/// frames: evenly spaced from the first key (frame 0) to the last (frame n − 1).
pub fn path_time(i: usize, n: usize, duration: f32) -> f32 {
    if n <= 1 {
        0.0
    } else {
        duration * i as f32 / (n - 1) as f32
    }
}

/// Loads a camera path for `--path`, refusing it together with `--camera`.
pub fn load_path(path: &Path, camera_flag: Option<&str>) -> Result<sylvan_scene::CameraPath> {
    if let Some(c) = camera_flag {
        bail!(
            "--camera {c} and --path {}: both set the camera — give one",
            path.display()
        );
    }
    Ok(sylvan_scene::CameraPath::load(path)?)
}

/// `--seeds auto|gpu|cpu`.
fn parse_seeds(s: &str) -> Result<sylvan_render::Seeds, String> {
    match s {
        "auto" => Ok(sylvan_render::Seeds::Auto),
        "gpu" => Ok(sylvan_render::Seeds::Gpu),
        "cpu" => Ok(sylvan_render::Seeds::Cpu),
        _ => Err(format!("'{s}': write auto, gpu or cpu")),
    }
}

/// Longest `--shadow-distance`: the cascades' depth range and texel snapping stay in f32's
/// comfortable range well beyond it.
const MAX_SHADOW_DISTANCE_M: f32 = 100_000.0;

fn parse_shadow_distance(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(d) if d.is_finite() && (10.0..=MAX_SHADOW_DISTANCE_M).contains(&d) => Ok(d),
        _ => Err(format!(
            "'{s}': write a distance in metres from 10 to {MAX_SHADOW_DISTANCE_M}"
        )),
    }
}

fn parse_shadow_near(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(d) if d.is_finite() && (0.0..=MAX_SHADOW_DISTANCE_M).contains(&d) => Ok(d),
        _ => Err(format!(
            "'{s}': write a distance in metres from 0 to {MAX_SHADOW_DISTANCE_M}"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shadow_distances_are_checked() {
        assert_eq!(parse_shadow_distance("5000"), Ok(5000.0));
        for bad in ["0", "-3", "nan", "inf", "1e9", "far"] {
            let e = parse_shadow_distance(bad).unwrap_err();
            assert!(e.contains("metres from 10"), "{bad}: {e}");
        }
        assert_eq!(parse_shadow_near("0"), Ok(0.0));
        assert_eq!(parse_shadow_near("3000"), Ok(3000.0));
        for bad in ["-1", "nan", "1e9", "near"] {
            let e = parse_shadow_near(bad).unwrap_err();
            assert!(e.contains("metres from 0"), "{bad}: {e}");
        }
    }

    #[test]
    fn path_times_span_the_path() {
        assert_eq!(path_time(0, 1, 4.0), 0.0);
        assert_eq!(path_time(0, 5, 4.0), 0.0);
        assert_eq!(path_time(2, 5, 4.0), 2.0);
        assert_eq!(path_time(4, 5, 4.0), 4.0);
    }
}
