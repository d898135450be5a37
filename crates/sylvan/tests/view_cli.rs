//! `sylvan view` end to end under a virtual X server, and `bench --path`.
//!
//! The viewer tests start their own `Xvfb` on a free display (or use `$DISPLAY` when Xvfb is not
//! installed but a display is). With neither they FAIL with the fix: install xvfb, or run
//! `cargo xtask test`, which installs it.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// A private Xvfb, killed on drop.
struct Display {
    name: String,
    server: Option<Child>,
}

impl Drop for Display {
    fn drop(&mut self) {
        if let Some(mut s) = self.server.take() {
            let _ = s.kill();
            let _ = s.wait();
        }
    }
}

fn xvfb_installed() -> bool {
    Command::new("Xvfb")
        .arg("-help")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok()
}

/// Starts `Xvfb :N` on the first free N from a per-process base, waiting for its socket.
fn display() -> Display {
    if !xvfb_installed() {
        if let Ok(d) = std::env::var("DISPLAY")
            && !d.is_empty()
        {
            return Display {
                name: d,
                server: None,
            };
        }
        panic!(
            "the viewer tests need an X server and found neither Xvfb nor $DISPLAY — \
             install it with `sudo apt-get install -y xvfb`, or run `cargo xtask test`, which installs it"
        );
    }
    let base = 100 + (std::process::id() % 300) * 3;
    for n in base..base + 60 {
        let socket = PathBuf::from(format!("/tmp/.X11-unix/X{n}"));
        let lock = PathBuf::from(format!("/tmp/.X{n}-lock"));
        if socket.exists() || lock.exists() {
            continue;
        }
        let Ok(mut child) = Command::new("Xvfb")
            .args([
                &format!(":{n}"),
                "-screen",
                "0",
                "1024x768x24",
                "-nolisten",
                "tcp",
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
        else {
            break;
        };
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(10) {
            if socket.exists() {
                return Display {
                    name: format!(":{n}"),
                    server: Some(child),
                };
            }
            if let Ok(Some(_)) = child.try_wait() {
                break; // lost a race for this display: try the next one
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let _ = child.kill();
        let _ = child.wait();
    }
    panic!("could not start Xvfb on any display — check `Xvfb :99` runs by hand");
}

fn sylvan(args: &[&str], dir: &Path, display: Option<&Display>) -> Output {
    let xdg = std::env::temp_dir().join("sylvan-test-xdg");
    std::fs::create_dir_all(&xdg).unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&xdg, std::fs::Permissions::from_mode(0o700)).unwrap();
    }
    let mut c = Command::new(env!("CARGO_BIN_EXE_sylvan"));
    c.args(args)
        .current_dir(dir)
        .env("XDG_RUNTIME_DIR", xdg)
        .env_remove("WAYLAND_DISPLAY");
    match display {
        Some(d) => c.env("DISPLAY", &d.name),
        None => c.env_remove("DISPLAY"),
    };
    c.output().expect("run sylvan")
}

fn workdir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A small grove (≈160 trees on 160 m) the camera looks over: fast on a software rasteriser.
const GROVE: &str = r#"
[terrain]
procedural = { seed = 11, size_m = 160, relief_m = 8 }

[[species]]
name = "pine"
preset = "pine"
density_per_ha = 25
height_m = [10, 16]

[[species]]
name = "bush"
preset = "bush"
density_per_ha = 40
height_m = [1.5, 3]

[camera]
position = [20, 14, 20]
look_at = [90, 4, 90]
fov_deg = 55
"#;

const PATH: &str = "interpolation = \"linear\"\n\n[[key]]\nt = 0\nposition = [20, 14, 20]\n\
look_at = [90, 4, 90]\n\n[[key]]\nt = 2\nposition = [60, 12, 30]\nlook_at = [80, 4, 120]\n";

fn grove(dir: &Path) -> PathBuf {
    let p = dir.join("grove.toml");
    std::fs::write(&p, GROVE).unwrap();
    std::fs::write(dir.join("fly.toml"), PATH).unwrap();
    p
}

fn assert_ok(out: &Output) {
    assert!(
        out.status.success(),
        "sylvan failed: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn scripted_view_shows_the_forest_with_the_panel_and_allocates_nothing_per_frame() {
    let x = display();
    let dir = workdir("view_scripted");
    let scene = grove(&dir);
    let out = sylvan(
        &[
            "view",
            scene.to_str().unwrap(),
            "--size",
            "480x270",
            "--frames",
            "30",
            "--screenshot",
            "shot.png",
            "--stats",
            "stats.json",
        ],
        &dir,
        Some(&x),
    );
    assert_ok(&out);
    eprintln!("{}", String::from_utf8_lossy(&out.stderr).trim());

    let shot = image::open(dir.join("shot.png")).unwrap().into_rgb8();
    assert_eq!(shot.dimensions(), (480, 270));
    // The panel: egui's dark grey on the left (measured ≈ (27, 27, 27)).
    let panel = shot.get_pixel(8, 260);
    assert!(
        panel.0.iter().all(|&c| c < 70) && panel.0[0].abs_diff(panel.0[2]) < 10,
        "no dark panel at the left: {panel:?}"
    );
    // The forest on the right: sky at the top (blue over red), and many green-dominant pixels
    // (leaves, grass) below the horizon. A black or unlit image has neither.
    // Sky in the row under the stats overlay: bright, blue at least as strong as red.
    let sky = (260..480).filter(|&x| {
        let [r, g, b] = shot.get_pixel(x, 95).0;
        r as u32 + g as u32 + b as u32 > 450 && b >= r
    });
    assert!(sky.count() > 20, "no sky at the top right");
    let mut green = 0;
    for y in 140..270 {
        for x in 260..480 {
            let [r, g, b] = shot.get_pixel(x, y).0;
            green += (g > r && g > b && g > 40) as u32;
        }
    }
    let share = green as f32 / (130.0 * 220.0);
    assert!(
        share > 0.2,
        "only {share:.2} of the lower right is vegetation"
    );

    let s = json(&dir.join("stats.json"));
    assert_eq!(s["frames"], 30);
    assert_eq!(s["per_frame"].as_array().unwrap().len(), 30);
    assert!(s["mean_ms"].as_f64().unwrap() > 0.0);
    assert_eq!(s["window"], serde_json::json!([480, 270]));
    // Nothing changes between the snapshots (after warm-up, at the end): wgpu's live objects and
    // memory, renderer rebuilds and presenter re-creations must all be equal.
    let snaps = s["allocations"].as_array().unwrap();
    assert_eq!(snaps.len(), 2, "{snaps:?}");
    assert_eq!(snaps[0]["after_frames"], 10);
    assert_eq!(snaps[1]["after_frames"], 30);
    assert!(
        snaps[0]["gpu"]["buffers"].as_i64().unwrap() > 0,
        "counters off?"
    );
    assert_eq!(
        snaps[0]["gpu"], snaps[1]["gpu"],
        "GPU objects allocated per frame"
    );
    assert_eq!(snaps[0]["renderer_rebuilds"], snaps[1]["renderer_rebuilds"]);
    assert_eq!(
        snaps[0]["presenter_allocations"],
        snaps[1]["presenter_allocations"]
    );
}

#[test]
fn scripted_view_replays_a_path_evenly() {
    let x = display();
    let dir = workdir("view_path");
    let scene = grove(&dir);
    let out = sylvan(
        &[
            "view",
            scene.to_str().unwrap(),
            "--size",
            "200x120",
            "--frames",
            "3",
            "--path",
            "fly.toml",
            "--no-panel",
            "--debug-view",
            "cascades",
            "--stats",
            "s.json",
        ],
        &dir,
        Some(&x),
    );
    assert_ok(&out);
    let s = json(&dir.join("s.json"));
    let t: Vec<f64> = s["per_frame"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["t"].as_f64().unwrap())
        .collect();
    assert_eq!(t, vec![0.0, 1.0, 2.0]);
}

#[test]
fn bench_replays_a_path_with_per_frame_stats() {
    let dir = workdir("bench_path");
    let scene = grove(&dir);
    let out = sylvan(
        &[
            "bench",
            scene.to_str().unwrap(),
            "--size",
            "96x64",
            "--frames",
            "3",
            "--path",
            "fly.toml",
            "--json",
        ],
        &dir,
        None,
    );
    assert_ok(&out);
    let s: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(s["frames"], 3);
    assert_eq!(s["path"], "fly.toml");
    let frames = s["per_frame"].as_array().unwrap();
    assert_eq!(frames.len(), 3);
    for (i, f) in frames.iter().enumerate() {
        assert_eq!(f["t"].as_f64().unwrap(), i as f64);
        assert!(f["ms"].as_f64().unwrap() > 0.0);
        assert!(f["triangles"].as_u64().unwrap() > 0);
        assert!(f["draw_calls"].as_u64().unwrap() > 0);
        assert!(f["trees_drawn"]["geometry"].as_u64().is_some());
    }
    // The camera moved: the first and last frames see different tree counts or triangles.
    assert_ne!(
        (&frames[0]["trees_drawn"], &frames[0]["triangles"]),
        (&frames[2]["trees_drawn"], &frames[2]["triangles"])
    );
}

/// Asserts failure with exactly one `error: ` line on stderr containing every `needle`.
fn assert_one_line_error(out: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "expected failure; stderr: {stderr}");
    assert!(!stderr.contains("panicked"), "panicked: {stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "expected one line, got: {stderr}");
    assert!(lines[0].starts_with("error: "), "{}", lines[0]);
    for n in needles {
        assert!(lines[0].contains(n), "'{n}' missing from: {}", lines[0]);
    }
}

#[test]
fn bad_view_and_path_input_is_one_line_never_a_panic() {
    let dir = workdir("view_bad");
    let scene = grove(&dir);
    let scene = scene.to_str().unwrap();
    std::fs::write(
        dir.join("bad.toml"),
        "[[key]]\nt = 1\nposition = [0, 0, 0]\nlook_at = [1, 0, 0]\n[[key]]\nt = 0.5\nposition = [0, 0, 0]\nlook_at = [1, 0, 0]\n",
    )
    .unwrap();
    std::fs::write(dir.join("broken.toml"), "[terrain\n").unwrap();
    let cases: &[(&[&str], &[&str])] = &[
        (&["view", scene, "--frames", "0"], &["--frames 0"]),
        (
            &["view", scene, "--path", "missing.toml"],
            &["missing.toml"],
        ),
        (
            &["view", scene, "--path", "bad.toml"],
            &["bad.toml:6:5", "t = 0.5"],
        ),
        (&["bench", scene, "--path", "bad.toml"], &["bad.toml:6:5"]),
        (
            &[
                "bench",
                scene,
                "--path",
                "fly.toml",
                "--camera",
                "0,1,0:1,1,1",
            ],
            &["--camera", "--path"],
        ),
        (
            &["view", scene, "--frames", "1", "--screenshot", "a.jpg"],
            &["a.jpg", ".png"],
        ),
        (
            &["view", scene, "--frames", "1", "--screenshot", "nope/a.png"],
            &["nope", "does not exist"],
        ),
        (
            &["view", scene, "--stats", "s.json"],
            &["--stats", "--frames"],
        ),
        (&["view", scene, "--debug-view", "x"], &["--debug-view x"]),
        (&["view", scene, "--render-scale", "0"], &["--render-scale"]),
        (
            &["view", "broken.toml", "--frames", "1"],
            &["broken.toml:1:"],
        ),
        (
            &["view", scene, "--technique", "nope"],
            &["unknown technique 'nope'"],
        ),
        // No display at all: a hint instead of a panic.
        (
            &["view", scene, "--frames", "1"],
            &["cannot open a window", "xvfb"],
        ),
    ];
    for (args, needles) in cases {
        let out = sylvan(args, &dir, None);
        assert_one_line_error(&out, needles);
    }
}
