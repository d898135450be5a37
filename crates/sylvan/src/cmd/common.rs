//! Flags shared by `render`, `bench` (and later `view`): raw strings → validated values.

use anyhow::{Context, Result, bail};
use glam::Vec3;
use std::path::{Path, PathBuf};
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

/// Opens the GPU, loads plants and prepares a renderer; returns it with the bake time (ms).
pub fn prepare(r: &Resolved) -> Result<(sylvan_gpu::Gpu, sylvan_render::Renderer, f64)> {
    let gpu = sylvan_gpu::Gpu::new()?;
    let start = std::time::Instant::now();
    let plants = sylvan_render::load_plants(&r.scene)?;
    let renderer = sylvan_render::Renderer::new(&gpu, &r.scene, &plants, &r.options)
        .context("preparing the renderer")?;
    Ok((gpu, renderer, start.elapsed().as_secs_f64() * 1e3))
}
