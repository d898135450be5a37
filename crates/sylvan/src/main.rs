//! The `sylvan` command line: `plant`, `bake`, `render`, `bench`, `compare`, `view`, `params`.
//!
//! The binary is thin: each subcommand parses its flags into a validated configuration and calls
//! the libraries. Errors print once, on one line, as `error: FILE:LINE:COL: what — fix` where a
//! location applies, and the exit status is non-zero.

mod cmd;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Real-time forest rendering with image-based tree representations.
#[derive(Parser)]
#[command(name = "sylvan", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Build a plant from an L-system, a preset or a mesh; print stats or export .glb.
    Plant(cmd::plant::PlantArgs),
    /// Bake a plant's image-based asset for a technique (cached; --out FILE to choose).
    Bake(cmd::bake::BakeCmdArgs),
    /// Render one frame of a scene to a PNG.
    Render(cmd::render::RenderArgs),
    /// Time N frames of a scene with one technique; print JSON.
    Bench(cmd::bench::BenchArgs),
    /// Compare two images: FLIP, SSIM, PSNR.
    Compare(cmd::compare::CompareArgs),
    /// Open the interactive viewer (or, with --frames N, run N frames and exit).
    View(cmd::view::ViewerArgs),
    /// List technique parameters: default, unit, bake or draw, and what each does.
    Params(cmd::params::ParamsArgs),
    /// Print the GPU adapter Sylvan would use; fails with an install hint when there is none.
    Adapter,
}

/// clap's error (several lines: the error, a tip, usage, a pointer to --help) as one line: its
/// first line, plus where to look — `sylvan CMD --help` for the subcommand given.
fn clap_one_line(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let first = text
        .lines()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("invalid arguments");
    let what = first.strip_prefix("error: ").unwrap_or(first).trim();
    let sub = std::env::args().nth(1).filter(|a| {
        <Cli as clap::CommandFactory>::command()
            .find_subcommand(a)
            .is_some()
    });
    let help = match sub {
        Some(s) => format!("sylvan {s} --help"),
        None => "sylvan --help".into(),
    };
    format!("{what} — see `{help}`")
}

/// Only Mesa on Unix prints the `XDG_RUNTIME_DIR` noise: nothing to do elsewhere.
#[cfg(not(unix))]
fn quiet_driver_noise() {}

/// Mesa's drivers print `error: XDG_RUNTIME_DIR is invalid or not set in the environment` on
/// every run without a usable one: give the process a private one (0700) when it has none.
#[cfg(unix)]
fn quiet_driver_noise() {
    let usable = std::env::var_os("XDG_RUNTIME_DIR").is_some_and(|d| {
        std::fs::metadata(&d).is_ok_and(|m| {
            use std::os::unix::fs::PermissionsExt;
            m.is_dir() && m.permissions().mode() & 0o077 == 0
        })
    });
    if usable {
        return;
    }
    let dir = std::env::temp_dir().join(format!("sylvan-runtime-{}", uid()));
    let made = std::fs::create_dir_all(&dir).is_ok() && {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700)).is_ok()
    };
    if made {
        // SAFETY: called first thing in `main`, before any other thread exists.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", &dir) };
    }
}

/// The user id from `/proc/self` (no libc dependency); 0 when unknown.
fn uid() -> u32 {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata("/proc/self").map_or(0, |m| m.uid())
}

fn main() -> ExitCode {
    quiet_driver_noise();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            // --help / --version are not errors.
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("error: {}", clap_one_line(&e));
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Command::Plant(args) => cmd::plant::run(args),
        Command::Bake(args) => cmd::bake::run(args),
        Command::Render(args) => cmd::render::run(args),
        Command::Bench(args) => cmd::bench::run(args),
        Command::Compare(args) => cmd::compare::run(args),
        Command::View(args) => cmd::view::run(args),
        Command::Params(args) => cmd::params::run(args),
        Command::Adapter => sylvan_gpu::Gpu::new().map_err(Into::into).map(|gpu| {
            let ts = if gpu.timestamps {
                "GPU timestamps"
            } else {
                "wall-clock timer"
            };
            println!("{} — {ts}", gpu.adapter_label());
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", cmd::common::one_line(&e));
            ExitCode::FAILURE
        }
    }
}
