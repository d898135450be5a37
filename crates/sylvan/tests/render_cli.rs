//! `sylvan render` / `sylvan bench` end to end: the stats contract with real values, and every
//! kind of bad input answered by one `error:` line (file:line:col where it applies), no panic.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn sylvan(args: &[&str], dir: &Path) -> Output {
    let xdg = std::env::temp_dir().join("sylvan-test-xdg");
    std::fs::create_dir_all(&xdg).unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&xdg, std::fs::Permissions::from_mode(0o700)).unwrap();
    }
    Command::new(env!("CARGO_BIN_EXE_sylvan"))
        .args(args)
        .current_dir(dir)
        .env("XDG_RUNTIME_DIR", xdg)
        .output()
        .expect("run sylvan")
}

fn workdir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const TINY: &str = r#"
[terrain]
procedural = { seed = 3, size_m = 60, relief_m = 6 }

[[species]]
name = "bush"
preset = "bush"
positions = "stand.csv"
height_m = [2, 3]

[camera]
position = [5, 8, 5]
look_at = [30, 1, 30]
fov_deg = 50
"#;

fn tiny_scene(dir: &Path) -> PathBuf {
    std::fs::write(dir.join("stand.csv"), "x,y\n20,20\n30,28\n25,35\n").unwrap();
    let p = dir.join("tiny.toml");
    std::fs::write(&p, TINY).unwrap();
    p
}

/// Asserts failure with exactly one `error: ` line on stderr containing every `needle`.
fn assert_one_line_error(out: &Output, needles: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "expected failure, got success; stderr: {stderr}"
    );
    assert!(!stderr.contains("panicked"), "panicked: {stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "expected one line, got: {stderr}");
    assert!(lines[0].starts_with("error: "), "{}", lines[0]);
    for n in needles {
        assert!(lines[0].contains(n), "'{}' missing from: {}", n, lines[0]);
    }
}

#[test]
fn render_writes_png_and_stats_with_real_values() {
    let dir = workdir("render_stats");
    let scene = tiny_scene(&dir);
    let out = sylvan(
        &[
            "render",
            scene.to_str().unwrap(),
            "--size",
            "96x64",
            "--out",
            "f.png",
            "--stats",
            "s.json",
        ],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let img = image::open(dir.join("f.png")).expect("png").into_rgb8();
    assert_eq!(img.dimensions(), (96, 64));
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("s.json")).unwrap()).unwrap();
    for key in ["median", "p95", "min", "max"] {
        assert!(s["frame_ms"][key].as_f64().unwrap() > 0.0, "frame_ms.{key}");
    }
    // lavapipe and every real GPU Sylvan targets have timestamp queries.
    assert_eq!(s["timer"], "gpu");
    // The frame's parts, in BN12 §9's terms: each there, none negative, together the frame.
    let frame = s["frame_ms"]["median"].as_f64().unwrap();
    let parts = [
        "prepare", "shadow0", "shadow1", "shadow2", "shadow3", "ground", "trees", "resolve",
    ];
    let split: Vec<f64> = parts
        .iter()
        .map(|p| s["split_ms"][p]["median"].as_f64().expect(p))
        .collect();
    assert!(split.iter().all(|&ms| ms >= 0.0), "{}", s["split_ms"]);
    let sum: f64 = split.iter().sum();
    assert!(
        sum <= frame * 1.0001 && sum >= 0.5 * frame,
        "parts {sum} ms against the frame's {frame} ms: {}",
        s["split_ms"]
    );
    assert!(split[6] > 0.0, "trees were drawn: {}", s["split_ms"]);
    assert_eq!(s["trees_total"], 3);
    assert!(s["trees_drawn"]["geometry"].as_u64().unwrap() >= 1);
    assert!(s["triangles"].as_u64().unwrap() > 1000);
    assert!(s["draw_calls"].as_u64().unwrap() >= 4);
    assert!(s["baked_bytes"].as_u64().unwrap() > 0);
    assert!(s["bake_ms"].as_f64().unwrap() >= 0.0);
    assert!(!s["adapter"].as_str().unwrap().is_empty());
}

#[test]
fn bench_prints_one_json_object() {
    let dir = workdir("bench_json");
    let scene = tiny_scene(&dir);
    let out = sylvan(
        &[
            "bench",
            scene.to_str().unwrap(),
            "--size",
            "64x48",
            "--frames",
            "3",
            "--json",
        ],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert_eq!(stdout.trim().lines().count(), 1, "{stdout}");
    let s: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(s["frames"], 3);
    let f = &s["frame_ms"];
    let (min, med, p95, max) = (
        f["min"].as_f64().unwrap(),
        f["median"].as_f64().unwrap(),
        f["p95"].as_f64().unwrap(),
        f["max"].as_f64().unwrap(),
    );
    assert!(0.0 < min && min <= med && med <= p95 && p95 <= max, "{f}");
    for key in [
        "timer",
        "trees_total",
        "trees_drawn",
        "triangles",
        "draw_calls",
        "baked_bytes",
        "bake_ms",
        "adapter",
    ] {
        assert!(!s[key].is_null(), "{key} missing");
    }
}

#[test]
fn bad_flags_give_one_line_errors() {
    let dir = workdir("bad_flags");
    let scene = tiny_scene(&dir);
    let scene = scene.to_str().unwrap();
    assert_one_line_error(
        &sylvan(&["render", scene, "--size", "0x0"], &dir),
        &["--size 0x0"],
    );
    assert_one_line_error(
        &sylvan(&["render", scene, "--size", "big"], &dir),
        &["--size big"],
    );
    assert_one_line_error(
        &sylvan(&["render", scene, "--technique", "nerf"], &dir),
        &["unknown technique 'nerf'", "geometry"],
    );
    assert_one_line_error(
        &sylvan(&["render", scene, "--spp", "3"], &dir),
        &["--spp 3", "perfect square"],
    );
    assert_one_line_error(
        &sylvan(&["render", scene, "--camera", "1,2:3"], &dir),
        &["--camera"],
    );
    assert_one_line_error(&sylvan(&["render", scene, "--sun", "40"], &dir), &["--sun"]);
    assert_one_line_error(
        &sylvan(&["render", scene, "--seeds", "fast"], &dir),
        &["--seeds", "auto, gpu or cpu"],
    );
    assert_one_line_error(
        &sylvan(&["bench", scene, "--frames", "0"], &dir),
        &["--frames 0"],
    );
    assert_one_line_error(
        &sylvan(
            &[
                "render",
                scene,
                "--technique",
                "auto",
                "--chain",
                "geometry:0-40,nerf:40-",
            ],
            &dir,
        ),
        &["--chain", "unknown technique 'nerf'"],
    );
    assert_one_line_error(
        &sylvan(
            &[
                "render",
                scene,
                "--technique",
                "hbt",
                "--chain",
                "geometry:0-40,hbt:40-",
            ],
            &dir,
        ),
        &["--chain", "add --technique auto"],
    );
    assert_one_line_error(
        &sylvan(
            &[
                "render",
                scene,
                "--technique",
                "octahedral",
                "--occlusion-cull",
                "--cpu-driven",
            ],
            &dir,
        ),
        &["--occlusion-cull", "CPU-driven", "drop --cpu-driven"],
    );
    // Checked against a declared memory limit before allocating (was a bare "Out of Memory").
    assert_one_line_error(
        &sylvan(&["render", scene, "--shadow-res", "16384"], &dir),
        &["--shadow-res 16384", "GB", "use 8960 or less"],
    );
    // With a technique that casts translucent shadows the layer counts too, and the way out
    // is named.
    assert_one_line_error(
        &sylvan(
            &[
                "render",
                scene,
                "--technique",
                "zfield",
                "--shadow-res",
                "8192",
            ],
            &dir,
        ),
        &[
            "--shadow-res 8192",
            "translucent",
            "use 5120 or less",
            "zfield.shadow_opacity=false",
        ],
    );
    assert_one_line_error(
        &sylvan(&["render", scene, "--shadow-res", "100"], &dir),
        &["--shadow-res 100", "256"],
    );
}

#[test]
fn bad_scene_files_give_file_line_col() {
    let dir = workdir("bad_scenes");
    tiny_scene(&dir);
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        ("missing.toml", String::new(), vec!["missing.toml"]),
        (
            "malformed.toml",
            "[terrain\nprocedural = 3\n".into(),
            vec!["malformed.toml:1:"],
        ),
        (
            "negative.toml",
            TINY.replace("positions = \"stand.csv\"", "density_per_ha = -5"),
            vec!["negative.toml:8:18"],
        ),
        (
            "heightmap.toml",
            "[terrain]\nheightmap = \"notes.txt\"\nsize_m = [100, 100]\nheight_m = [0, 10]\n"
                .into(),
            vec!["notes.txt"],
        ),
        (
            "badcsv.toml",
            TINY.replace("stand.csv", "bad.csv"),
            vec!["bad.csv:3:"],
        ),
        (
            "badparam.toml",
            format!("{TINY}\n[technique.hbt]\nlevels = \"x\"\n"),
            vec!["badparam.toml:17:10", "hbt.levels", "—"],
        ),
        (
            "typo.toml",
            format!("{TINY}\n[technique.hbt]\nopen_texel_pixel = 2\n"),
            vec!["typo.toml:17:20", "open_texel_pixels", "—"],
        ),
        (
            "nosuch.toml",
            format!("{TINY}\n[technique.nerf]\nsize = 2\n"),
            vec!["nosuch.toml:17:8", "unknown technique `nerf`", "—"],
        ),
        (
            "badband.toml",
            format!(
                "{TINY}\n[[lod.band]]\ntechnique = \"geometry\"\nfrom = 0\n[lod.band.params]\nsize = 2\n"
            ),
            vec!["badband.toml:20:8", "geometry.size", "—"],
        ),
    ];
    std::fs::write(dir.join("notes.txt"), "this is not an image").unwrap();
    std::fs::write(dir.join("bad.csv"), "x,y\n10,10\n12,abc\n").unwrap();
    for (name, text, needles) in cases {
        if !text.is_empty() {
            std::fs::write(dir.join(name), text).unwrap();
        }
        let out = sylvan(&["render", name, "--size", "32x32"], &dir);
        assert_one_line_error(&out, &needles);
    }
}

/// `--out` naming a folder, or a file in a missing folder: one line that says so, before any
/// rendering (issue #19: it used to end in "check the folder exists").
#[test]
fn out_that_is_a_folder_or_in_a_missing_folder_is_refused() {
    let dir = workdir("out_folder");
    tiny_scene(&dir);
    std::fs::create_dir_all(dir.join("shots")).unwrap();
    let out = sylvan(&["render", "tiny.toml", "--out", "shots"], &dir);
    assert_one_line_error(
        &out,
        &[
            "--out shots: is a folder, not a file — give a file name",
            "shots/sylvan.png",
        ],
    );
    let out = sylvan(&["render", "tiny.toml", "--out", "nope/a.png"], &dir);
    assert_one_line_error(&out, &["--out nope/a.png: folder nope does not exist — "]);
    let out = sylvan(&["render", "tiny.toml", "--stats", "shots"], &dir);
    assert_one_line_error(&out, &["--stats shots: is a folder, not a file — "]);
}

#[test]
fn no_adapter_names_the_packages_to_install() {
    // No Metal adapter exists on Linux: the same path as a machine without any GPU driver.
    if cfg!(target_os = "macos") {
        return;
    }
    let dir = workdir("no_adapter");
    let out = Command::new(env!("CARGO_BIN_EXE_sylvan"))
        .arg("adapter")
        .current_dir(&dir)
        .env("WGPU_BACKEND", "metal")
        .output()
        .expect("run sylvan");
    assert_one_line_error(
        &out,
        &[
            "no GPU adapter",
            "mesa-vulkan-drivers libvulkan1",
            "cargo xtask",
        ],
    );
}

fn json_of(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object on stdout")
}

#[test]
fn bake_writes_reuses_and_renders_from_the_cache() {
    let dir = workdir("bake_cache");
    let cache = dir.join("cache");
    let c = cache.to_str().unwrap();
    let first = json_of(&sylvan(
        &["bake", "--preset", "bush", "--cache-dir", c, "--json"],
        &dir,
    ));
    assert_eq!(first["technique"], "boxtree");
    assert_eq!(first["from_cache"], false);
    assert!(first["boxes"].as_u64().unwrap() > 1);
    assert_eq!(first["images"], first["boxes"].as_u64().unwrap() * 6);
    let file = std::path::PathBuf::from(first["file"].as_str().unwrap());
    assert!(file.starts_with(&cache) && file.exists());
    let again = json_of(&sylvan(
        &["bake", "--preset", "bush", "--cache-dir", c, "--json"],
        &dir,
    ));
    assert_eq!(again["from_cache"], true);
    assert_eq!(again["file"], first["file"]);
    // render with boxtree reads the same cache and reports the technique and its bake time.
    let scene = tiny_scene(&dir);
    let stats = dir.join("s.json");
    let out = sylvan(
        &[
            "render",
            scene.to_str().unwrap(),
            "--technique",
            "boxtree",
            "--size",
            "64x36",
            "--cache-dir",
            c,
            "--out",
            dir.join("b.png").to_str().unwrap(),
            "--stats",
            stats.to_str().unwrap(),
        ],
        &dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let s: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    assert_eq!(s["technique"], "boxtree");
    assert_eq!(s["trees_drawn"]["boxtree"], 3);
    assert!(s["baked_bytes"].as_u64().unwrap() > 0);
}

#[test]
fn bad_bake_input_is_one_error_line() {
    let dir = workdir("bake_bad");
    for (args, needles) in [
        (
            vec![
                "bake",
                "--preset",
                "bush",
                "--set",
                "boxtree.tile=100",
                "--no-cache",
            ],
            vec!["--set boxtree.tile=100", "tile 100", "—"],
        ),
        (
            vec!["bake", "--preset", "bush", "--set", "boxtree.layout=round"],
            vec!["--set boxtree.layout=round", "unknown variant", "—"],
        ),
        (
            vec!["render", "--set", "hbt.open_texel_pixel=2"],
            vec!["--set hbt.open_texel_pixel=2", "hbt.open_texel_pixels", "—"],
        ),
        (
            vec!["render", "--set", "hbt.levels"],
            vec!["--set hbt.levels", "no '='", "—"],
        ),
        (
            vec!["bake", "--preset", "bush", "--technique", "geometry"],
            vec!["nothing to bake"],
        ),
        (vec!["bake"], vec!["no plant given"]),
        (vec!["bake", "missing.lsys"], vec!["missing.lsys"]),
    ] {
        assert_one_line_error(&sylvan(&args, &dir), &needles);
    }
}

#[test]
fn params_lists_every_key_of_every_technique() {
    let dir = workdir("params");
    let out = sylvan(&["params"], &dir);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "geometry —",
        "boxtree —",
        "hbt —",
        "auto —",
        "open_texel_pixels = 2.0",
        "draw [px]",
        "tile = 64",
        "layout = \"axis\"",
    ] {
        assert!(text.contains(needle), "'{needle}' missing from: {text}");
    }
    let json = sylvan(&["params", "hbt", "--json"], &dir);
    let v = json_of(&json);
    let keys: Vec<&str> = v["hbt"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["key"].as_str().unwrap())
        .collect();
    assert!(
        keys.contains(&"levels") && keys.contains(&"views"),
        "{keys:?}"
    );
    assert_one_line_error(
        &sylvan(&["params", "nerf"], &dir),
        &["unknown technique 'nerf'"],
    );
}

#[test]
fn band_tables_and_set_reach_the_technique() {
    // A chain written as [[lod.band]] tables with their own parameters (geometry, boxtree,
    // then the octahedral baseline far away) renders, and `--set` changes what a technique
    // draws (boxtree opening every box: more triangles).
    let dir = workdir("bands");
    tiny_scene(&dir);
    let scene = format!(
        "{TINY}\n[[lod.band]]\ntechnique = \"geometry\"\nfrom = 0\nto = 10\n[[lod.band]]\ntechnique = \"boxtree\"\nfrom = 10\nto = 30\nparams = {{ texel_pixels = 4 }}\n[[lod.band]]\ntechnique = \"octahedral\"\nfrom = 30\n"
    );
    std::fs::write(dir.join("bands.toml"), scene).unwrap();
    let cache = dir.join("cache");
    let c = cache.to_str().unwrap();
    let render = |extra: &[&str]| {
        let stats = dir.join("s.json");
        let mut args = vec![
            "render",
            "bands.toml",
            "--technique",
            "auto",
            "--size",
            "64x36",
            "--cache-dir",
            c,
            "--out",
            "b.png",
            "--stats",
            stats.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let out = sylvan(&args, &dir);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice::<serde_json::Value>(&std::fs::read(&stats).unwrap()).unwrap()
    };
    let banded = render(&[]);
    let n: u64 = banded["trees_drawn"]
        .as_object()
        .unwrap()
        .values()
        .map(|v| v.as_u64().unwrap())
        .sum();
    assert!(n >= 3, "{banded}");
    assert!(
        banded["trees_drawn"]["octahedral"].as_u64() >= Some(1),
        "{banded}"
    );
    // `--chain` replaces the scene's bands: everything beyond 10 m as octahedral now, and no
    // boxtree.
    let chained = render(&["--chain", "geometry:0-10,octahedral:10-"]);
    assert!(chained["trees_drawn"]["boxtree"].is_null(), "{chained}");
    assert!(
        chained["trees_drawn"]["octahedral"].as_u64()
            >= banded["trees_drawn"]["octahedral"].as_u64(),
        "{chained} against {banded}"
    );
    let closed = render(&["--set", "boxtree.texel_pixels=60"]);
    let opened = render(&["--set", "boxtree.texel_pixels=0.1"]);
    assert!(
        opened["triangles"].as_u64() > closed["triangles"].as_u64(),
        "opened {} vs closed {}",
        opened["triangles"],
        closed["triangles"]
    );
}

#[test]
fn bake_measures_and_caches_shadermap_tables_for_a_scene() {
    let dir = workdir("bake_tables");
    let scene = tiny_scene(&dir);
    let c = dir.join("cache");
    let args = [
        "bake",
        "--technique",
        "shadermap",
        "--scene",
        scene.to_str().unwrap(),
        "--cache-dir",
        c.to_str().unwrap(),
        "--set",
        "zfield.order=3",
        "--set",
        "zfield.tile=32",
        "--set",
        "shadermap.theta=4",
        "--set",
        "shadermap.phi=3",
        "--set",
        "shadermap.lambda=3",
        "--set",
        "shadermap.patch_px=64",
        "--json",
    ];
    let first = json_of(&sylvan(&args, &dir));
    assert_eq!(first["species"], "bush");
    assert_eq!(first["from_cache"], false);
    // Per non-empty density node: a light map per direction (the zenith, 3 × 3 others) and a
    // G-buffer per view zenith (4).
    assert_eq!(first["renders"], 2 * (1 + 3 * 3 + 4));
    assert_eq!(first["evaluations"], 2 * 4 * (1 + 3 * 3) * 64 * 64);
    let gd = first["gd_by_lambda"].as_array().unwrap();
    assert_eq!(gd.len(), 3);
    // The top view of the densest node sees less ground than no trees at all.
    assert!(gd[2][0].as_f64().unwrap() < 1.0 && gd[0][0].as_f64().unwrap() == 1.0);
    let again = json_of(&sylvan(&args, &dir));
    assert_eq!(again["from_cache"], true);
    assert_eq!(again["gd_by_lambda"], first["gd_by_lambda"]);
    // `--out` names the tables' file (the z-field bakes stay in the cache): read back next time.
    let out_file = dir.join("tables.sylbake");
    let mut with_out: Vec<&str> = args.to_vec();
    with_out.extend(["--out", out_file.to_str().unwrap()]);
    let written = json_of(&sylvan(&with_out, &dir));
    assert_eq!(written["file"], out_file.to_str().unwrap());
    let read = json_of(&sylvan(&with_out, &dir));
    assert_eq!(read["from_cache"], true, "{read}");
    // The scene's own [technique.shadermap] table applies (another patch seed: other tables,
    // not the cached ones), under --set (theta stays 4).
    let own = dir.join("own.toml");
    std::fs::write(
        &own,
        format!("{TINY}\n[technique.shadermap]\nseed = 7\ntheta = 6\n"),
    )
    .unwrap();
    let mut scene_args: Vec<&str> = args.to_vec();
    scene_args[4] = own.to_str().unwrap();
    let from_scene = json_of(&sylvan(&scene_args, &dir));
    assert_eq!(from_scene["from_cache"], false, "{from_scene}");
    assert_eq!(
        from_scene["tables"]["theta"], 4,
        "--set shadermap.theta=4 wins"
    );
    // A bad table key and a plant where a scene is wanted are one-line errors.
    let out = sylvan(
        &[
            "bake",
            "--technique",
            "shadermap",
            "--set",
            "shadermap.theta=1",
        ],
        &dir,
    );
    assert_one_line_error(&out, &["theta 1", "3 to 32"]);
    let out = sylvan(
        &["bake", "--technique", "shadermap", "--preset", "pine"],
        &dir,
    );
    assert_one_line_error(&out, &["--scene"]);
}

#[test]
fn render_measures_linear_radiance_over_a_rectangle() {
    let dir = workdir("measure");
    let scene = tiny_scene(&dir);
    let stats = dir.join("s.json");
    let run = |rect: &str| {
        sylvan(
            &[
                "render",
                scene.to_str().unwrap(),
                "--size",
                "32x18",
                "--out",
                dir.join("m.png").to_str().unwrap(),
                "--stats",
                stats.to_str().unwrap(),
                "--measure",
                rect,
            ],
            &dir,
        )
    };
    let out = run("0,0,32,18");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let all: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    let mean = all["radiance_mean"].as_array().unwrap();
    assert_eq!(mean.len(), 3);
    assert!(mean.iter().all(|v| v.as_f64().unwrap() > 0.0), "{mean:?}");
    // The top rows are sky, brighter than the whole frame's mean in blue.
    assert!(run("0,0,32,2").status.success());
    let sky: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    assert!(sky["radiance_mean"][2].as_f64().unwrap() > mean[2].as_f64().unwrap());
    assert_one_line_error(&run("20,0,20,4"), &["inside the 32x18 image"]);
    assert_one_line_error(&run("1,2,3"), &["X,Y,W,H"]);
}
