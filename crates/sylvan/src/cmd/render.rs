//! `sylvan render`: one frame to a PNG, optionally with stats JSON.

use super::common::{ViewArgs, prepare};
use super::stats::Report;
use anyhow::{Context, Result};
use std::path::PathBuf;

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
}

/// Runs `sylvan render`.
pub fn run(args: RenderArgs) -> Result<()> {
    let r = args.view.resolve()?;
    let (gpu, mut renderer, bake_ms) = prepare(&r)?;
    let stats = renderer.render(&gpu, &r.camera, &r.sun)?;
    let image = renderer.read_image(&gpu)?;
    image::DynamicImage::ImageRgba8(image)
        .into_rgb8()
        .save(&args.out)
        .with_context(|| {
            format!(
                "{}: cannot write PNG — check the folder exists and is writable",
                args.out.display()
            )
        })?;
    let report = Report::new(
        r.options.technique.name(),
        [r.options.width, r.options.height],
        r.options.spp,
        std::slice::from_ref(&stats),
        bake_ms,
        gpu.adapter_label(),
    );
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
