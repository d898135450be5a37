//! `sylvan bench`: N timed frames of one technique, as one JSON object.

use super::common::{ViewArgs, prepare};
use super::stats::Report;
use anyhow::{Result, bail};

/// Flags of `sylvan bench`.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    #[command(flatten)]
    pub view: ViewArgs,
    /// Timed frames (after 2 warm-up frames).
    #[arg(long, default_value_t = 20)]
    pub frames: usize,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Most frames a bench may ask for.
pub const MAX_FRAMES: usize = 100_000;

/// Runs `sylvan bench`.
pub fn run(args: BenchArgs) -> Result<()> {
    if args.frames == 0 || args.frames > MAX_FRAMES {
        bail!(
            "--frames {}: must be between 1 and {MAX_FRAMES}",
            args.frames
        );
    }
    let r = args.view.resolve()?;
    let (gpu, mut renderer, bake_ms) = prepare(&r)?;
    for _ in 0..2 {
        renderer.render(&gpu, &r.camera, &r.sun)?;
    }
    // A frame can take seconds on a software rasteriser: show progress on a terminal
    // (indicatif draws nothing when stderr is not one, so JSON consumers see no noise).
    let progress = indicatif::ProgressBar::new(args.frames as u64).with_message("frames");
    let mut frames = Vec::with_capacity(args.frames);
    for _ in 0..args.frames {
        frames.push(renderer.render(&gpu, &r.camera, &r.sun)?);
        progress.inc(1);
    }
    progress.finish_and_clear();
    let report = Report::new(
        r.options.technique.name(),
        [r.options.width, r.options.height],
        r.options.spp,
        &frames,
        bake_ms,
        gpu.adapter_label(),
    );
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!(
            "{}: median {:.2} ms, p95 {:.2} ms ({} timer, {} frames), {} triangles, {} draw calls on {}",
            report.technique,
            report.frame_ms.median,
            report.frame_ms.p95,
            report.timer,
            report.frames,
            report.triangles,
            report.draw_calls,
            report.adapter
        );
    }
    Ok(())
}
