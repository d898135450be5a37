//! `sylvan render`: one frame to a PNG, optionally with stats JSON; with `--path FILE --frames
//! N`, N frames along a camera path to numbered PNGs (for transition studies and videos).

use super::common::{ViewArgs, load_path, path_time, prepare};
use super::stats::Report;
use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};
use sylvan_render::DebugView;

/// Flags of `sylvan render`.
#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    #[command(flatten)]
    pub view: ViewArgs,
    /// Output PNG.
    #[arg(long, default_value = "sylvan.png")]
    pub out: PathBuf,
    /// Write frame stats (same fields as `bench --json`) to this JSON file.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Follow a camera path (TOML, as `sylvan view` records it and `bench --path` replays).
    #[arg(long, value_name = "FILE.toml")]
    pub path: Option<PathBuf>,
    /// With --path: frames to render, evenly spaced in path time; `--out a.png` becomes
    /// `a-000.png`, `a-001.png`, ….
    #[arg(long, default_value_t = 1)]
    pub frames: usize,
    /// Add the last frame's mean linear radiance (RGB, before exposure and tone mapping) over
    /// this rectangle of output pixels to the stats (`radiance_mean`; needs --stats).
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_rect)]
    pub measure: Option<[u32; 4]>,
    /// Debug view: none, technique (trees tinted by the technique that drew them), cascades,
    /// coverage (trees white at their opacity, terrain black, the forest field at its trees'
    /// share: with --measure, the fraction of the rectangle covered by trees).
    #[arg(long, default_value = "none", value_parser = DebugView::parse)]
    pub debug: DebugView,
}

fn parse_rect(s: &str) -> Result<[u32; 4], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let values: Option<Vec<u32>> = parts.iter().map(|p| p.parse().ok()).collect();
    match values {
        Some(v) if v.len() == 4 => Ok([v[0], v[1], v[2], v[3]]),
        _ => Err(format!(
            "'{s}' is not a rectangle — give X,Y,W,H in output pixels, e.g. 100,50,40,30"
        )),
    }
}

/// Most frames `render --path` writes.
pub const MAX_FRAMES: usize = 10_000;

fn numbered(out: &Path, i: usize) -> PathBuf {
    let stem = out
        .file_stem()
        .map_or("frame".into(), |s| s.to_string_lossy().into_owned());
    out.with_file_name(format!("{stem}-{i:03}.png"))
}

fn save(image: image::RgbaImage, out: &Path) -> Result<()> {
    image::DynamicImage::ImageRgba8(image)
        .into_rgb8()
        .save(out)
        .with_context(|| {
            format!(
                "{}: cannot write PNG — check the folder exists and is writable",
                out.display()
            )
        })
}

/// Refuses an output path that cannot be written as a file, before any rendering: an existing
/// folder (`--out shots/`), or a path whose folder does not exist.
fn check_out(flag: &str, out: &Path) -> Result<()> {
    if out.is_dir() {
        bail!(
            "{flag} {}: is a folder, not a file — give a file name, e.g. {}",
            out.display(),
            out.join("sylvan.png").display()
        );
    }
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty())
        && !dir.is_dir()
    {
        bail!(
            "{flag} {}: folder {} does not exist — create it or write somewhere else",
            out.display(),
            dir.display()
        );
    }
    Ok(())
}

/// Runs `sylvan render`.
pub fn run(args: RenderArgs) -> Result<()> {
    check_out("--out", &args.out)?;
    if args.measure.is_some() && args.stats.is_none() {
        anyhow::bail!("--measure adds to the stats — pass --stats FILE.json too");
    }
    if let Some(stats) = &args.stats {
        check_out("--stats", stats)?;
    }
    if args.frames == 0 || args.frames > MAX_FRAMES {
        bail!(
            "--frames {}: must be between 1 and {MAX_FRAMES}",
            args.frames
        );
    }
    if args.frames > 1 && args.path.is_none() {
        bail!(
            "--frames {}: several frames need a camera path — add --path FILE.toml",
            args.frames
        );
    }
    let camera_path = match &args.path {
        Some(p) => Some(load_path(p, args.view.camera.as_deref())?),
        None => None,
    };
    let mut r = args.view.resolve()?;
    r.options.debug = args.debug;
    let (gpu, mut renderer, bake_ms) = prepare(&r)?;
    let mut stats = None;
    for i in 0..args.frames {
        let camera = match &camera_path {
            Some(p) => p.sample(path_time(i, args.frames, p.duration())),
            None => r.camera,
        };
        if i == 0 && r.options.occlusion_cull {
            // The occlusion cull tests against the previous frame: draw one first, so the
            // picture shows what the cull keeps.
            renderer.render(&gpu, &camera, &r.sun)?;
        }
        let s = renderer.render(&gpu, &camera, &r.sun)?;
        let out = if camera_path.is_some() {
            numbered(&args.out, i)
        } else {
            args.out.clone()
        };
        save(renderer.read_image(&gpu)?, &out)?;
        stats = Some(s);
    }
    let stats = stats.expect("at least one frame");
    let radiance = match args.measure {
        Some(rect) => Some(renderer.radiance_mean(&gpu, rect)?),
        None => None,
    };
    let mut report = Report::new(
        &r.options.technique,
        [r.options.width, r.options.height],
        r.options.spp,
        std::slice::from_ref(&stats),
        bake_ms,
        gpu.adapter_label(),
    );
    report.radiance_mean = radiance;
    if let Some(path) = &args.stats {
        std::fs::write(path, serde_json::to_string_pretty(&report)? + "\n").with_context(|| {
            format!(
                "{}: cannot write stats — check the folder exists and is writable",
                path.display()
            )
        })?;
    }
    eprintln!(
        "{}: {}x{} spp {} — {:.1} ms ({}), {} / {} trees, {} triangles, {} draw calls, {}",
        args.out.display(),
        report.size[0],
        report.size[1],
        report.spp,
        stats.frame_ms,
        report.timer,
        stats.trees_drawn.values().sum::<u32>(),
        stats.trees_total,
        stats.triangles,
        stats.draw_calls,
        report.adapter
    );
    Ok(())
}
