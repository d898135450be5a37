//! `sylvan bench`: N timed frames of one technique, as one JSON object. With `--path FILE` the
//! camera follows a recorded camera path (the viewer's format), sampled evenly over its keys, and
//! the JSON also carries `per_frame` records.

use super::common::{ViewArgs, load_path, path_time, prepare};
use super::stats::{FrameRecord, Report};
use anyhow::{Result, bail};
use std::path::PathBuf;

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
    /// Replay a camera path (TOML, as `sylvan view` records it): frame i of N is at path time
    /// duration·i/(N−1); the JSON gains `path` and `per_frame` (t, ms, counts per frame).
    #[arg(long, value_name = "FILE.toml")]
    pub path: Option<PathBuf>,
    /// Count, per frame, the trees inside the view in this frame and the last that appeared,
    /// vanished or changed presence by more than the world's fades allow (`pops_*` in the
    /// world's statistics and `per_frame`; GPU-driven techniques; waits for each frame's
    /// counts, so time frames without it).
    #[arg(long)]
    pub count_pops: bool,
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
    let camera_path = match &args.path {
        Some(p) => Some(load_path(p, args.view.camera.as_deref())?),
        None => None,
    };
    let start = std::time::Instant::now();
    let r = args.view.resolve()?;
    let camera_at = |i: usize| match &camera_path {
        Some(p) => {
            let t = path_time(i, args.frames, p.duration());
            (t, p.sample(t))
        }
        None => (0.0, r.camera),
    };
    let (gpu, mut renderer, bake_ms) = prepare(&r)?;
    renderer.set_pop_audit(&gpu, args.count_pops)?;
    let ready_ms = start.elapsed().as_secs_f64() * 1e3;
    let first = renderer.render(&gpu, &camera_at(0).1, &r.sun)?;
    let startup_ms = ready_ms + first.cpu_ms;
    renderer.render(&gpu, &camera_at(0).1, &r.sun)?;
    // A frame can take seconds on a software rasteriser: show progress on a terminal
    // (indicatif draws nothing when stderr is not one, so JSON consumers see no noise).
    let progress = indicatif::ProgressBar::new(args.frames as u64).with_message("frames");
    let mut frames = Vec::with_capacity(args.frames);
    let mut records = Vec::with_capacity(args.frames);
    for i in 0..args.frames {
        let (t, camera) = camera_at(i);
        let stats = renderer.render(&gpu, &camera, &r.sun)?;
        records.push(FrameRecord::new(t, &stats));
        frames.push(stats);
        progress.inc(1);
    }
    progress.finish_and_clear();
    let mut report = Report::new(
        &r.options.technique,
        [r.options.width, r.options.height],
        r.options.spp,
        &frames,
        bake_ms,
        gpu.adapter_label(),
    );
    report.startup_ms = Some(startup_ms);
    if let Some(p) = &args.path {
        report.path = Some(p.display().to_string());
        report.per_frame = Some(records);
    }
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
