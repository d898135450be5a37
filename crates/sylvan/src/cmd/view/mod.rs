//! `sylvan view`: the interactive viewer — a winit window on the same renderer as `render` and
//! `bench`, an egui panel, a stats overlay, camera paths, scene hot reload — and its scripted
//! form for tests and docs: `--frames N [--screenshot FILE.png] [--path FILE] [--stats FILE.json]`
//! runs N frames and exits.
//!
//! | file | what |
//! |---|---|
//! | `app.rs` | window, surface, event loop, the frame loop, input, screenshots, scripted runs |
//! | `present.rs` | surface configuration, composite image, blit to the window |
//! | `viewer.rs` | scene, renderer and settings; rebuilds that keep the last working renderer |
//! | `camera.rs` | fly / orbit / path camera, recording, tree picking |
//! | `panel.rs` | the egui panel and overlays |
//! | `stats.rs` | frame times, GPU object counts, the `--stats` report |
//! | `reload.rs` | scene file hot reload |
//! | `compare.rs` | "compare with reference" (geometry, 16 spp, ꟻLIP) on a worker thread |

mod app;
mod camera;
mod compare;
mod panel;
mod present;
mod reload;
mod stats;
mod viewer;

use super::bench::MAX_FRAMES;
use super::common::{ViewArgs, load_path};
use anyhow::{Result, bail};
use std::path::{Path, PathBuf};
use sylvan_render::DebugView;

/// Flags of `sylvan view`.
#[derive(clap::Args, Debug)]
#[command(after_help = "\
Keys: WASD/QE fly (Shift 4x), right-drag look, wheel speed; middle-click a tree (or O for the \
one in the centre) to orbit it, left-drag turns the orbit, wheel zooms; R records a camera path \
(R again saves it), P plays the loaded path; F1 panel, F12 screenshot, V vsync, Esc quits.
The scene file is watched: edits show up within a second; a bad edit shows its error in the \
panel and the last good scene keeps running.")]
pub struct ViewerArgs {
    #[command(flatten)]
    pub view: ViewArgs,
    /// Camera path (TOML, as the viewer records it and `bench --path` replays): played in a
    /// loop; with --frames, frame i of N is at path time duration·i/(N−1).
    #[arg(long, value_name = "FILE.toml")]
    pub path: Option<PathBuf>,
    /// Run this many frames and exit (scripting, tests).
    #[arg(long, value_name = "N")]
    pub frames: Option<usize>,
    /// Screenshot file: with --frames, the last frame (scene and panel) is written here;
    /// interactively, F12 writes here (default: sylvan-view-NNN.png in the current folder).
    #[arg(long, value_name = "FILE.png")]
    pub screenshot: Option<PathBuf>,
    /// With --frames: write per-frame stats and GPU object counts as JSON.
    #[arg(long, value_name = "FILE.json")]
    pub stats: Option<PathBuf>,
    /// Debug view: none, technique, cascades, coverage.
    #[arg(long, default_value = "none")]
    pub debug_view: String,
    /// Scene resolution relative to the window (0.1–1; lower is faster on software adapters).
    #[arg(long, default_value_t = 1.0)]
    pub render_scale: f32,
    /// Present without vsync.
    #[arg(long)]
    pub no_vsync: bool,
    /// Start with the panel hidden (F1 shows it).
    #[arg(long)]
    pub no_panel: bool,
    /// With --frames: compare the first frame with the 16-spp reference and overlay the ꟻLIP
    /// heat-map before the screenshot.
    #[arg(long, requires = "frames")]
    pub compare: bool,
}

/// Runs `sylvan view`.
pub fn run(args: ViewerArgs) -> Result<()> {
    let config = Config::resolve(args)?;
    app::run(config)
}

/// Validated flags, checked before any window opens.
pub struct Config {
    resolved: super::common::Resolved,
    path: Option<sylvan_scene::CameraPath>,
    path_file: Option<PathBuf>,
    frames: Option<usize>,
    screenshot: Option<PathBuf>,
    stats: Option<PathBuf>,
    debug: DebugView,
    render_scale: f32,
    vsync: bool,
    panel: bool,
    compare: bool,
}

impl Config {
    fn resolve(args: ViewerArgs) -> Result<Self> {
        if let Some(n) = args.frames
            && (n == 0 || n > MAX_FRAMES)
        {
            bail!("--frames {n}: must be between 1 and {MAX_FRAMES}");
        }
        if args.stats.is_some() && args.frames.is_none() {
            bail!("--stats needs --frames N — the report describes a scripted run");
        }
        if !(0.1..=1.0).contains(&args.render_scale) {
            bail!(
                "--render-scale {}: must be between 0.1 and 1",
                args.render_scale
            );
        }
        let debug = DebugView::parse(&args.debug_view)
            .map_err(|e| anyhow::anyhow!("--debug-view {}: {e}", args.debug_view))?;
        if let Some(p) = &args.screenshot {
            check_output(p, "png", "--screenshot")?;
        }
        if let Some(p) = &args.stats {
            check_output(p, "json", "--stats")?;
        }
        let path = match &args.path {
            Some(p) => Some(load_path(p, args.view.camera.as_deref())?),
            None => None,
        };
        let mut resolved = args.view.resolve()?;
        resolved.options.debug = debug;
        Ok(Self {
            resolved,
            path,
            path_file: args.path,
            frames: args.frames,
            screenshot: args.screenshot,
            stats: args.stats,
            debug,
            render_scale: args.render_scale,
            vsync: !args.no_vsync && args.frames.is_none(),
            panel: !args.no_panel,
            compare: args.compare,
        })
    }
}

/// An output file must have the right extension and a folder that exists.
fn check_output(p: &Path, ext: &str, flag: &str) -> Result<()> {
    let ok = p
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case(ext));
    if !ok {
        bail!(
            "{flag} {}: expected a .{ext} file — name it FILE.{ext}",
            p.display()
        );
    }
    let dir = p.parent().filter(|d| !d.as_os_str().is_empty());
    if let Some(d) = dir
        && !d.is_dir()
    {
        bail!(
            "{flag} {}: folder {} does not exist — create it first",
            p.display(),
            d.display()
        );
    }
    Ok(())
}

pub use super::common::one_line;
