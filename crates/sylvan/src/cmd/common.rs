//! Flags shared by `render`, `bench` (and later `view`): raw strings → validated values.

use anyhow::{Context, Result, bail};
use glam::Vec3;
use std::path::{Path, PathBuf};
use sylvan_render::bake::CachePolicy;
use sylvan_render::technique::boxtree::{BoxTreeParams, PlaneLayout};
use sylvan_render::technique::hbt::{HbtParams, HbtProjection, HbtShadows};
use sylvan_render::{RenderOptions, TechniqueKind};
use sylvan_scene::{Camera, Scene, Sun};

/// Scene and view flags common to the frame commands.
#[derive(clap::Args, Debug, Clone)]
pub struct ViewArgs {
    /// Scene file (TOML). Without it: the built-in default scene.
    pub scene: Option<PathBuf>,
    /// Output size in pixels, WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x720")]
    pub size: String,
    /// Tree representation: geometry, boxtree, hbt, billboard-cloud, zfield, shadermap, auto.
    #[arg(long, default_value = "geometry")]
    pub technique: String,
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
    /// Shadow-map resolution per cascade.
    #[arg(long, default_value_t = 2048)]
    pub shadow_res: u32,
    #[command(flatten)]
    pub bake: BakeArgs,
}

/// Bake parameters and the cache, shared by every command that may bake.
#[derive(clap::Args, Debug, Clone)]
pub struct BakeArgs {
    /// boxtree: image size per box face in texels (LCV04 uses 64 or 128).
    #[arg(long, default_value_t = BoxTreeParams::default().tile)]
    pub tile: u32,
    /// boxtree: plane arrangement, `axis` (LCV04 fig. 3; 1.6× faster than diagonal at equal
    /// fidelity targets, see BENCHMARKS.md), `diagonal` (fig. 6) or `billboard` (the naive
    /// one-image baseline).
    #[arg(long, default_value = "axis")]
    pub planes: String,
    /// boxtree: volume-ratio threshold for boxes to get images (LCV04 §3.2.4).
    #[arg(long, default_value_t = BoxTreeParams::default().volume_threshold)]
    pub volume_threshold: f32,
    /// boxtree: keep all wood as geometry instead of baking it into the box images.
    #[arg(long)]
    pub wood_geometry: bool,
    /// boxtree: a box opens when one of its texels would cover more than this many pixels.
    #[arg(long, default_value_t = BoxTreeParams::default().texel_pixels)]
    pub texel_pixels: f32,
    /// boxtree: transition band width, relative to the LOD distance (0 = hard switches).
    #[arg(long, default_value_t = BoxTreeParams::default().band)]
    pub band: f32,
    /// Folder for baked assets (default: $SYLVAN_CACHE_DIR, $XDG_CACHE_HOME/sylvan or ~/.cache/sylvan).
    #[arg(long)]
    pub cache_dir: Option<PathBuf>,
    /// Bake every time; read and write no cache files.
    #[arg(long)]
    pub no_cache: bool,
    /// boxtree: most boxes per plant that get images.
    #[arg(long, default_value_t = BoxTreeParams::default().max_boxes)]
    pub max_boxes: u32,
    /// boxtree: fewest leaves a box needs to get images.
    #[arg(long, default_value_t = BoxTreeParams::default().min_leaves)]
    pub min_leaves: u32,
    /// hbt: view directions of the BTF (MNP01 §3.1): 6, 18, 66 or 258.
    #[arg(long, default_value_t = sylvan_render::directions::SAMPLE_COUNTS[HbtParams::default().view_level as usize])]
    pub hbt_views: usize,
    /// hbt: light directions of the BTF: 6, 18, 66 or 258.
    #[arg(long, default_value_t = sylvan_render::directions::SAMPLE_COUNTS[HbtParams::default().light_level as usize])]
    pub hbt_lights: usize,
    /// hbt: billboard size in texels (MNP01 uses 32 or 64).
    #[arg(long, default_value_t = HbtParams::default().tile)]
    pub hbt_tile: u32,
    /// hbt: hierarchy levels, 1 (the tree), 2 (also main branches, drawn when the tree's texels would be magnified) or 3 (also the plant's meshes, drawn when the branches' would be).
    #[arg(long, default_value_t = HbtParams::default().levels)]
    pub hbt_levels: u32,
    /// hbt: view directions of the branch level's BTFs: 6, 18, 66 or 258.
    #[arg(long, default_value_t = sylvan_render::directions::SAMPLE_COUNTS[HbtParams::default().branch_view_level as usize])]
    pub hbt_branch_views: usize,
    /// hbt: light directions of the branch level's BTFs: 6, 18, 66 or 258.
    #[arg(long, default_value_t = sylvan_render::directions::SAMPLE_COUNTS[HbtParams::default().branch_light_level as usize])]
    pub hbt_branch_lights: usize,
    /// hbt: most distinct main branches baked per plant (others drawn with a scaled representative).
    #[arg(long, default_value_t = HbtParams::default().max_branch_objects)]
    pub hbt_branch_objects: u32,
    /// hbt: visibility cube-map face size in texels (MNP01 §3.3 uses 32).
    #[arg(long, default_value_t = HbtParams::default().cube_resolution)]
    pub hbt_cube: u32,
    /// hbt: a tree opens into its branches when one of its texels would cover more than this many pixels.
    #[arg(long, default_value_t = HbtParams::default().open_texel_pixels)]
    pub hbt_open_pixels: f32,
    /// hbt (levels 3): a tree is drawn as its meshes when one texel of its largest main branch would cover more than this many pixels.
    #[arg(long, default_value_t = HbtParams::default().mesh_texel_pixels)]
    pub hbt_mesh_pixels: f32,
    /// hbt (levels 3): open an opened tree into its meshes `branch` by branch (each main branch where its own texels would be magnified) or as a whole `tree` (by its largest main branch).
    #[arg(long, default_value = "tree")]
    pub hbt_mesh_by: String,
    /// hbt: cross-fade band around each level switch, relative to the switch (0 = hard switches).
    #[arg(long, default_value_t = HbtParams::default().band)]
    pub hbt_band: f32,
    /// hbt: bake the tree level from `geometry` or by rendering its `branches` with the runtime algorithm (MNP01 §6.1); with --hbt-small-branches, main branches are rendered from their small branches too.
    #[arg(long, default_value = "geometry")]
    pub hbt_tree_from: String,
    /// hbt (levels 2 and 3): also bake MNP01's small-branch level below each main branch (branch objects at most half its size) and open main branches into it where their texels would be magnified.
    #[arg(long)]
    pub hbt_small_branches: bool,
    /// hbt: view × light pair weights below this are dropped and the rest renormalised (MNP01 §4.1); 0.45 keeps only the strongest pair.
    #[arg(long, default_value_t = HbtParams::default().min_weight)]
    pub hbt_min_weight: f32,
    /// hbt: received sun shadows from `cascades` (measured closer to the reference) or `cubemaps` (MNP01 §3.3's 8-corner interpolation); the sky term always comes from the cube-maps.
    #[arg(long, default_value = "cascades")]
    pub hbt_shadows: String,
    /// hbt baseline: reconstruct every tree under this fixed light direction X,Y,Z (towards the light) whatever the sun — a view-only impostor baked under one light.
    #[arg(long)]
    pub hbt_fixed_light: Option<String>,
    /// hbt: projection of the blended images, `facing` or `cross` (MNP01 fig. 3.2).
    #[arg(long, default_value = "facing")]
    pub hbt_projection: String,
}

impl BakeArgs {
    /// The validated boxtree parameters.
    pub fn boxtree(&self) -> Result<BoxTreeParams> {
        let layout = PlaneLayout::parse(&self.planes).ok_or_else(|| {
            anyhow::anyhow!(
                "--planes {}: expected `diagonal`, `axis` or `billboard` (the naive baseline)",
                self.planes
            )
        })?;
        let p = BoxTreeParams {
            tile: self.tile,
            layout,
            volume_threshold: self.volume_threshold,
            bake_wood: !self.wood_geometry,
            texel_pixels: self.texel_pixels,
            band: self.band,
            max_boxes: self.max_boxes,
            min_leaves: self.min_leaves,
            ..Default::default()
        };
        p.validate()?;
        Ok(p)
    }

    /// The validated hbt parameters.
    pub fn hbt(&self) -> Result<HbtParams> {
        let level = |flag: &str, n: usize| -> Result<u32> {
            sylvan_render::directions::SAMPLE_COUNTS
                .iter()
                .position(|&c| c == n)
                .map(|l| l as u32)
                .ok_or_else(|| {
                    anyhow::anyhow!("--{flag} {n}: expected 6, 18, 66 or 258 directions")
                })
        };
        let projection = HbtProjection::parse(&self.hbt_projection).ok_or_else(|| {
            anyhow::anyhow!(
                "--hbt-projection {}: expected `facing` or `cross`",
                self.hbt_projection
            )
        })?;
        let shadows = HbtShadows::parse(&self.hbt_shadows).ok_or_else(|| {
            anyhow::anyhow!(
                "--hbt-shadows {}: expected `cubemaps` or `cascades`",
                self.hbt_shadows
            )
        })?;
        let fixed_light = match &self.hbt_fixed_light {
            None => None,
            Some(v) => {
                let parts: Vec<f32> = v
                    .split(',')
                    .map(|x| x.trim().parse::<f32>())
                    .collect::<Result<_, _>>()
                    .map_err(|_| {
                        anyhow::anyhow!("--hbt-fixed-light {v}: expected X,Y,Z numbers")
                    })?;
                let [x, y, z] = parts[..] else {
                    anyhow::bail!("--hbt-fixed-light {v}: expected three numbers X,Y,Z");
                };
                Some([x, y, z])
            }
        };
        let tree_from_branches = match self.hbt_tree_from.as_str() {
            "geometry" => false,
            "branches" => true,
            other => anyhow::bail!("--hbt-tree-from {other}: expected `geometry` or `branches`"),
        };
        let mesh_per_branch = match self.hbt_mesh_by.as_str() {
            "branch" => true,
            "tree" => false,
            other => anyhow::bail!("--hbt-mesh-by {other}: expected `branch` or `tree`"),
        };
        let p = HbtParams {
            mesh_per_branch,
            fixed_light,
            tree_from_branches,
            small_branches: self.hbt_small_branches,
            min_weight: self.hbt_min_weight,
            levels: self.hbt_levels,
            view_level: level("hbt-views", self.hbt_views)?,
            light_level: level("hbt-lights", self.hbt_lights)?,
            branch_view_level: level("hbt-branch-views", self.hbt_branch_views)?,
            branch_light_level: level("hbt-branch-lights", self.hbt_branch_lights)?,
            max_branch_objects: self.hbt_branch_objects,
            cube_resolution: self.hbt_cube,
            open_texel_pixels: self.hbt_open_pixels,
            mesh_texel_pixels: self.hbt_mesh_pixels,
            band: self.hbt_band,
            shadows,
            tile: self.hbt_tile,
            projection,
            ..Default::default()
        };
        p.validate()?;
        Ok(p)
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

/// Loads the scene (or the built-in one).
pub fn load_scene(path: Option<&Path>) -> Result<Scene> {
    match path {
        Some(p) => Ok(Scene::load(p)?),
        None => Ok(Scene::builtin_default()),
    }
}

impl ViewArgs {
    /// Validates every flag and loads the scene.
    pub fn resolve(&self) -> Result<Resolved> {
        let (width, height) = parse_size(&self.size)?;
        let technique = TechniqueKind::parse(&self.technique)?;
        let options = RenderOptions {
            width,
            height,
            spp: self.spp,
            technique,
            shadows: !self.no_shadows,
            shadow_resolution: self.shadow_res,
            boxtree: self.bake.boxtree()?,
            hbt: self.bake.hbt()?,
            cache: self.bake.cache(),
            ..Default::default()
        };
        options.factor()?;
        let scene = load_scene(self.scene.as_deref())?;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_times_span_the_path() {
        assert_eq!(path_time(0, 1, 4.0), 0.0);
        assert_eq!(path_time(0, 5, 4.0), 0.0);
        assert_eq!(path_time(2, 5, 4.0), 2.0);
        assert_eq!(path_time(4, 5, 4.0), 4.0);
    }
}
