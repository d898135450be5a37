//! `cargo xtask demo` and `cargo xtask test`: the README's two commands.
//!
//! Both first make sure a GPU adapter exists. When none does, they install Mesa's software
//! Vulkan driver (lavapipe: `mesa-vulkan-drivers libvulkan1`, with the GL fallback
//! `libegl1 libegl-mesa0 libgl1-mesa-dri`) with apt-get, saying so, and then run.
//!
//! - `demo`: renders the built-in forest to `out/demo.png` and prints frame stats.
//! - `test`: `cargo fmt --check`, `cargo clippy -D warnings`, then the whole test suite. The
//!   viewer's tests (`crates/sylvan/tests/view_cli.rs`) open windows on their own `Xvfb`: when
//!   `Xvfb` is missing, `test` installs `xvfb` with apt-get first.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

const VULKAN_PACKAGES: &[&str] = &["mesa-vulkan-drivers", "libvulkan1"];
const GL_PACKAGES: &[&str] = &["libegl1", "libegl-mesa0", "libgl1-mesa-dri"];
const XVFB_PACKAGES: &[&str] = &["xvfb"];

fn main() -> ExitCode {
    let task = std::env::args().nth(1).unwrap_or_default();
    let result = match task.as_str() {
        "demo" => demo(),
        "test" => test(),
        _ => Err("usage: cargo xtask demo | cargo xtask test".to_string()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default()
}

fn cargo() -> Command {
    let mut c = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    c.current_dir(root());
    quiet_driver_noise(&mut c);
    c
}

/// Mesa/Vulkan print `XDG_RUNTIME_DIR is invalid` without one; give children a private one.
fn quiet_driver_noise(c: &mut Command) {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        let dir = std::env::temp_dir().join(format!("sylvan-xdg-{}", std::process::id()));
        if std::fs::create_dir_all(&dir).is_ok() {
            #[cfg(unix)]
            {
                use std::os::unix::fs::PermissionsExt;
                let _ = std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700));
            }
            c.env("XDG_RUNTIME_DIR", dir);
        }
    }
}

fn run(mut c: Command, what: &str) -> Result<(), String> {
    eprintln!("xtask: {what}");
    let status = c.status().map_err(|e| format!("{what}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("{what} failed ({status})"))
    }
}

/// Builds the CLI (release or debug) and returns its path.
fn build_cli(release: bool) -> Result<PathBuf, String> {
    let mut c = cargo();
    c.args(["build", "--package", "sylvan"]);
    if release {
        c.arg("--release");
    }
    let profile = if release { "release" } else { "debug" };
    run(c, &format!("building sylvan ({profile})"))?;
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .map(|t| if t.is_absolute() { t } else { root().join(t) })
        .unwrap_or_else(|| root().join("target"));
    Ok(target.join(profile).join("sylvan"))
}

/// Whether `sylvan adapter` finds a GPU adapter; prints its line.
fn adapter_found(cli: &Path) -> bool {
    let mut c = Command::new(cli);
    c.arg("adapter");
    quiet_driver_noise(&mut c);
    match c.output() {
        Ok(out) if out.status.success() => {
            eprint!("xtask: adapter: {}", String::from_utf8_lossy(&out.stdout));
            true
        }
        _ => false,
    }
}

fn apt_get(args: &[&str]) -> Result<(), String> {
    let is_root = Command::new("id")
        .arg("-u")
        .output()
        .map(|o| o.stdout.starts_with(b"0"))
        .unwrap_or(false);
    let mut c = if is_root {
        Command::new("apt-get")
    } else {
        let mut s = Command::new("sudo");
        s.arg("apt-get");
        s
    };
    c.args(args).env("DEBIAN_FRONTEND", "noninteractive");
    run(c, &format!("apt-get {}", args.join(" ")))
}

/// Makes sure an adapter exists, installing Mesa's software drivers when none does.
fn ensure_adapter(cli: &Path) -> Result<(), String> {
    if adapter_found(cli) {
        return Ok(());
    }
    eprintln!(
        "xtask: no GPU adapter found — installing Mesa's software Vulkan driver (lavapipe) and the GL fallback with apt-get: {} {}",
        VULKAN_PACKAGES.join(" "),
        GL_PACKAGES.join(" ")
    );
    let mut install = vec!["install", "-y", "--no-install-recommends"];
    install.extend(VULKAN_PACKAGES);
    install.extend(GL_PACKAGES);
    if apt_get(&install).is_err() {
        apt_get(&["update"])?;
        apt_get(&install)?;
    }
    if adapter_found(cli) {
        Ok(())
    } else {
        Err("still no GPU adapter after installing Mesa's drivers — check `vulkaninfo --summary`, or try WGPU_BACKEND=gl".into())
    }
}

/// Makes sure `Xvfb` exists for the viewer tests, installing `xvfb` with apt-get when not.
fn ensure_xvfb() -> Result<(), String> {
    let found = || {
        Command::new("Xvfb")
            .arg("-help")
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok()
    };
    if found() {
        return Ok(());
    }
    eprintln!(
        "xtask: Xvfb not found — installing the virtual X server for the viewer tests with apt-get: {}",
        XVFB_PACKAGES.join(" ")
    );
    let mut install = vec!["install", "-y", "--no-install-recommends"];
    install.extend(XVFB_PACKAGES);
    if apt_get(&install).is_err() {
        apt_get(&["update"])?;
        apt_get(&install)?;
    }
    if found() {
        Ok(())
    } else {
        Err(
            "still no Xvfb after installing xvfb — the viewer tests need it (`Xvfb :99` must run)"
                .into(),
        )
    }
}

fn demo() -> Result<(), String> {
    let cli = build_cli(true)?;
    ensure_adapter(&cli)?;
    let out = root().join("out");
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    let png = out.join("demo.png");
    let stats = out.join("demo-stats.json");
    let mut c = Command::new(&cli);
    c.args(["render", "--size", "1280x720", "--out"])
        .arg(&png)
        .arg("--stats")
        .arg(&stats);
    quiet_driver_noise(&mut c);
    run(
        c,
        "rendering the built-in forest (1280x720, technique geometry)",
    )?;
    let text = std::fs::read_to_string(&stats).map_err(|e| format!("{}: {e}", stats.display()))?;
    println!("{}", text.trim());
    println!("wrote {}", png.display());
    Ok(())
}

fn test() -> Result<(), String> {
    let mut fmt = cargo();
    fmt.args(["fmt", "--all", "--check"]);
    run(fmt, "cargo fmt --all --check")?;
    let mut clippy = cargo();
    clippy.args([
        "clippy",
        "--workspace",
        "--all-targets",
        "--",
        "-D",
        "warnings",
    ]);
    run(
        clippy,
        "cargo clippy --workspace --all-targets -- -D warnings",
    )?;
    let cli = build_cli(false)?;
    ensure_adapter(&cli)?;
    ensure_xvfb()?;
    let mut tests = cargo();
    tests.args(["test", "--workspace"]);
    run(tests, "cargo test --workspace")
}
