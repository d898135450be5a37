//! `cargo xtask demo` and `cargo xtask test`: the README's two commands.
//!
//! Both first make sure a GPU adapter exists. When there is no Vulkan adapter — none at all, or
//! only Mesa's GL driver, which a fresh Debian image may ship alone — they install Mesa's
//! software Vulkan driver (lavapipe: `mesa-vulkan-drivers libvulkan1`, and the GL driver
//! `libegl1 libegl-mesa0 libgl1-mesa-dri`) with apt-get, saying so, and then run (Sylvan works
//! on GL too, and `demo` goes on with GL when the install is not possible).
//!
//! - `demo`: renders the built-in forest to `out/demo.png` and prints frame stats.
//! - `test`: `cargo fmt --check`, `cargo clippy -D warnings`, then the whole test suite, then the
//!   render tests (`sylvan-render`) a second time on the GL backend (`WGPU_BACKEND=gl`), so
//!   every backend Sylvan claims is tested; both drivers are installed when missing. The
//!   viewer's tests (`crates/sylvan/tests/view_cli.rs`) open windows on their own `Xvfb`: when
//!   `Xvfb` is missing, `test` installs `xvfb` with apt-get first. Last, the Bevy plugin
//!   (`crates/sylvan-bevy`, its own workspace): fmt, clippy and its headless test on Vulkan.

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
    // A CI build is never rebuilt in place: incremental state would only take disk.
    if std::env::var_os("CI").is_some() && std::env::var_os("CARGO_INCREMENTAL").is_none() {
        c.env("CARGO_INCREMENTAL", "0");
    }
    c
}

/// Prints the free space where the build goes (CI disks are small; a full one crashes the
/// linker with SIGBUS rather than saying so).
fn report_disk(when: &str) {
    if let Ok(out) = Command::new("df")
        .args(["-h", "--output=avail"])
        .arg(root())
        .output()
    {
        let text = String::from_utf8_lossy(&out.stdout);
        if let Some(avail) = text.lines().nth(1) {
            eprintln!("xtask: {} free on the build disk {when}", avail.trim());
        }
    }
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

/// Builds the release CLI (the demo's) and returns its path; `test` takes its CLI from the
/// test build instead ([`build_tests`]).
fn build_release_cli() -> Result<PathBuf, String> {
    let mut c = cargo();
    c.args(["build", "--package", "sylvan", "--release"]);
    run(c, "building sylvan (release)")?;
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .map(|t| if t.is_absolute() { t } else { root().join(t) })
        .unwrap_or_else(|| root().join("target"));
    Ok(target.join("release").join("sylvan"))
}

/// The adapter `sylvan adapter` finds on `backend` (`vulkan`, `gl`), its line printed.
fn adapter_on(cli: &Path, backend: &str) -> bool {
    let mut c = Command::new(cli);
    c.arg("adapter").env("WGPU_BACKEND", backend);
    quiet_driver_noise(&mut c);
    match c.output() {
        Ok(out) if out.status.success() => {
            eprint!(
                "xtask: {backend} adapter: {}",
                String::from_utf8_lossy(&out.stdout)
            );
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

fn install(packages: &[&str]) -> Result<(), String> {
    let mut args = vec!["install", "-y", "--no-install-recommends"];
    args.extend(packages);
    if apt_get(&args).is_err() {
        apt_get(&["update"])?;
        apt_get(&args)?;
    }
    Ok(())
}

/// Makes sure a Vulkan adapter exists (and, with `gl_too`, a GL one), installing Mesa's
/// software drivers when not. Without `gl_too`, a GL adapter alone is enough when the
/// install fails (the demo runs on GL).
fn ensure_adapter(cli: &Path, gl_too: bool) -> Result<(), String> {
    let vulkan = adapter_on(cli, "vulkan");
    let gl = adapter_on(cli, "gl");
    if !vulkan {
        let why = if gl {
            "only a GL adapter found"
        } else {
            "no GPU adapter found"
        };
        eprintln!(
            "xtask: {why} — installing Mesa's software Vulkan driver (lavapipe), which Sylvan prefers, and the GL driver with apt-get: {} {}",
            VULKAN_PACKAGES.join(" "),
            GL_PACKAGES.join(" ")
        );
        let packages: Vec<&str> = VULKAN_PACKAGES.iter().chain(GL_PACKAGES).copied().collect();
        match install(&packages) {
            Ok(()) if adapter_on(cli, "vulkan") => {}
            result if gl && !gl_too => {
                let e = result
                    .err()
                    .unwrap_or_else(|| "no Vulkan adapter after it".into());
                eprintln!("xtask: could not install lavapipe ({e}) — going on with the GL adapter");
                return Ok(());
            }
            _ => {
                return Err("still no Vulkan adapter after installing Mesa's drivers — check `vulkaninfo --summary`, or try WGPU_BACKEND=gl".into());
            }
        }
    }
    // Installing lavapipe above installs the GL driver too: look again only then.
    if gl_too && !(gl || adapter_on(cli, "gl")) {
        eprintln!(
            "xtask: no GL adapter found — installing Mesa's GL driver for the GL test pass with apt-get: {}",
            GL_PACKAGES.join(" ")
        );
        install(GL_PACKAGES)?;
        if !adapter_on(cli, "gl") {
            return Err(
                "still no GL adapter after installing Mesa's GL driver — check `eglinfo`".into(),
            );
        }
    }
    Ok(())
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
    install(XVFB_PACKAGES)?;
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
    let cli = build_release_cli()?;
    ensure_adapter(&cli, false)?;
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
        "rendering the built-in forest (1280x720, technique auto: geometry, boxtree, zfield, \
         then BN12's shader-map to the horizon; the first run bakes the box trees, z-fields and \
         ground tables into ~/.cache/sylvan — minutes on a CPU driver, once)",
    )?;
    let text = std::fs::read_to_string(&stats).map_err(|e| format!("{}: {e}", stats.display()))?;
    println!("{}", text.trim());
    println!("wrote {}", png.display());
    Ok(())
}

fn test() -> Result<(), String> {
    report_disk("before the tests");
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
    // Doc comments' links resolve (a renamed item leaves no dangling [`link`] behind).
    let mut doc = cargo();
    doc.args(["doc", "--workspace", "--no-deps", "--quiet"])
        .env("RUSTDOCFLAGS", "-D warnings");
    run(
        doc,
        "RUSTDOCFLAGS='-D warnings' cargo doc --workspace --no-deps",
    )?;
    // One build serves every step: the test executables, and the CLI they drive (built with
    // the same features, so the run below and the GL pass rebuild nothing).
    let (binaries, cli) = build_tests()?;
    ensure_adapter(&cli, true)?;
    ensure_xvfb()?;
    let mut tests = cargo();
    tests.args(["test", "--workspace"]);
    run(tests, "cargo test --workspace")?;
    // The render tests again on the GL backend (the cross-backend tests, `*_as_vulkan_does`,
    // already ran both), from the executables just built: `cargo test --package sylvan-render`
    // alone would resolve features for that package only and rebuild wgpu (5 min in CI).
    let gl: Vec<&TestBinary> = binaries
        .iter()
        .filter(|b| b.package_dir.ends_with("crates/sylvan-render"))
        .collect();
    if gl.is_empty() {
        return Err("cargo built no test executable for crates/sylvan-render".into());
    }
    for b in gl {
        let mut c = Command::new(&b.exe);
        c.current_dir(&b.package_dir)
            .env("CARGO_MANIFEST_DIR", &b.package_dir)
            .env("WGPU_BACKEND", "gl")
            .args(["--skip", "as_vulkan_does"]);
        quiet_driver_noise(&mut c);
        let name = b.exe.file_name().unwrap_or_default().to_string_lossy();
        run(c, &format!("WGPU_BACKEND=gl sylvan-render test {name}"))?;
    }
    report_disk("after the workspace tests");
    bevy_plugin()?;
    report_disk("after the Bevy plugin's tests");
    Ok(())
}

/// A test executable of the workspace.
struct TestBinary {
    /// The directory of its package's `Cargo.toml` (where `cargo test` runs it).
    package_dir: PathBuf,
    exe: PathBuf,
}

/// `cargo test --workspace --no-run`: builds every test target and the `sylvan` CLI, and
/// returns the test executables and the CLI's path, read from cargo's JSON messages.
fn build_tests() -> Result<(Vec<TestBinary>, PathBuf), String> {
    let what = "cargo test --workspace --no-run";
    eprintln!("xtask: {what}");
    let mut c = cargo();
    c.args([
        "test",
        "--workspace",
        "--no-run",
        "--message-format=json-render-diagnostics",
    ])
    .stdout(std::process::Stdio::piped())
    .stderr(std::process::Stdio::inherit());
    let out = c.output().map_err(|e| format!("{what}: {e}"))?;
    if !out.status.success() {
        return Err(format!("{what} failed ({})", out.status));
    }
    let mut binaries = Vec::new();
    let mut cli = None;
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let Ok(m) = serde_json::from_str::<serde_json::Value>(line) else {
            continue;
        };
        let (Some(exe), Some(manifest)) = (m["executable"].as_str(), m["manifest_path"].as_str())
        else {
            continue;
        };
        let exe = PathBuf::from(exe);
        if m["profile"]["test"].as_bool() == Some(true) {
            let package_dir = Path::new(manifest)
                .parent()
                .map(Path::to_path_buf)
                .unwrap_or_default();
            binaries.push(TestBinary { package_dir, exe });
        } else if m["target"]["name"] == "sylvan"
            && m["target"]["kind"]
                .as_array()
                .is_some_and(|k| k.iter().any(|k| k == "bin"))
        {
            cli = Some(exe);
        }
    }
    let cli = cli.ok_or("cargo test --workspace --no-run built no `sylvan` binary")?;
    Ok((binaries, cli))
}

/// The Bevy plugin (`crates/sylvan-bevy`): fmt, clippy and its headless test. It is its own
/// workspace, so Bevy is built only here (into `target/bevy`), and with
/// `--ignore-rust-version`: Bevy 0.20 declares rustc 1.97.1 on its umbrella and `wesl`
/// crates, and builds and renders on this repository's 1.95. Its test runs on Vulkan only:
/// Bevy 0.20's own PBR shaders do not compile on Mesa's llvmpipe GL (`textureGatherOffset` on
/// a `sampler2DShadow`), so Bevy cannot start there.
fn bevy_plugin() -> Result<(), String> {
    let dir = root().join("crates/sylvan-bevy");
    let bevy = |args: &[&str]| {
        let mut c = cargo();
        c.current_dir(&dir).args(args);
        c
    };
    run(
        bevy(&["fmt", "--all", "--check"]),
        "(crates/sylvan-bevy) cargo fmt --all --check",
    )?;
    let ignore = "--ignore-rust-version";
    run(
        bevy(&["clippy", ignore, "--all-targets", "--", "-D", "warnings"]),
        "(crates/sylvan-bevy) cargo clippy --ignore-rust-version --all-targets -- -D warnings",
    )?;
    let mut test = bevy(&["test", ignore]);
    test.env("WGPU_BACKEND", "vulkan");
    run(
        test,
        "(crates/sylvan-bevy) WGPU_BACKEND=vulkan cargo test --ignore-rust-version",
    )
}
