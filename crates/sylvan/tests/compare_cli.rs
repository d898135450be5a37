//! `sylvan compare` end to end, on synthetic PNGs: the JSON contract of DESIGN.md, the heat-map,
//! and one-line errors.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh folder for one test's files.
fn dir(test: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("compare_cli")
        .join(test);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Deterministic noise in [0, 245], so that +10 never clips.
fn noise(w: u32, h: u32) -> image::RgbImage {
    let mut s = 0x9e37_79b9_u32;
    image::RgbImage::from_fn(w, h, |_, _| {
        image::Rgb(std::array::from_fn(|_| {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            (s % 246) as u8
        }))
    })
}

fn write(dir: &Path, name: &str, img: &image::RgbImage) -> PathBuf {
    let path = dir.join(name);
    img.save(&path).unwrap();
    path
}

/// Writes `a.png` (noise, 32×24) and `b.png` (its sRGB values halved) into `dir`.
fn noise_and_halved(dir: &Path) -> (PathBuf, PathBuf) {
    let img = noise(32, 24);
    let mut darker = img.clone();
    darker.iter_mut().for_each(|v| *v /= 2);
    (write(dir, "a.png", &img), write(dir, "b.png", &darker))
}

fn sylvan(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sylvan"))
        .args(args)
        .output()
        .unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Runs successfully and parses the one JSON object on stdout.
fn json(args: &[&str]) -> serde_json::Value {
    let out = sylvan(args);
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(stdout.lines().count(), 1, "one JSON line: {stdout}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    assert_eq!(keys.len(), 5, "{stdout}");
    for key in ["flip_mean", "ssim", "psnr", "mean_a", "mean_b"] {
        assert!(keys.contains(&key), "missing {key}: {stdout}");
    }
    v
}

/// Fails with exactly one stderr line, starting `error: `; returns it.
fn one_line_error(args: &[&str]) -> String {
    let out = sylvan(args);
    assert!(!out.status.success(), "{args:?} should fail");
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    assert!(stderr.starts_with("error: "), "{stderr}");
    assert!(out.stdout.is_empty());
    stderr.trim_end().to_owned()
}

#[test]
fn identical_images_json() {
    let d = dir("identical");
    let a = write(&d, "a.png", &noise(32, 24));
    let v = json(&["compare", s(&a), s(&a), "--json"]);
    assert_eq!(v["flip_mean"], 0.0);
    assert_eq!(v["ssim"], 1.0);
    assert_eq!(v["mean_a"], v["mean_b"]);
    // Infinite PSNR: JSON has no infinity, so it is null (documented in --help).
    assert!(v["psnr"].is_null());
}

#[test]
fn offset_by_ten_json() {
    let d = dir("offset");
    let img = noise(32, 24);
    let mut plus = img.clone();
    plus.iter_mut().for_each(|v| *v += 10);
    let a = write(&d, "a.png", &img);
    let b = write(&d, "b.png", &plus);
    let v = json(&["compare", s(&a), s(&b), "--json"]);
    // MSE = 100 exactly: PSNR = 20·log10(255/10).
    let psnr = v["psnr"].as_f64().unwrap();
    assert!((psnr - 20.0 * 25.5_f64.log10()).abs() < 1e-9, "{psnr}");
    let ssim = v["ssim"].as_f64().unwrap();
    assert!(ssim > 0.9 && ssim < 1.0, "{ssim}");
    let flip = v["flip_mean"].as_f64().unwrap();
    assert!(flip > 0.0 && flip < 0.5, "{flip}");
}

#[test]
fn human_readable_line_and_heatmap() {
    let d = dir("heatmap");
    let (a, b) = noise_and_halved(&d);
    let heat = d.join("heat.png");
    let out = sylvan(&["compare", s(&a), s(&b), "--heatmap", s(&heat)]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert_eq!(stdout.lines().count(), 1, "{stdout}");
    assert!(stdout.contains("FLIP") && stdout.contains("SSIM") && stdout.contains("PSNR"));
    // Halving sRGB values takes a linear channel to between 0.21 and 0.5 of itself.
    let bias = stdout.split("mean B/A ").nth(1).unwrap();
    for v in bias
        .trim_end_matches(|c: char| c == '%' || c.is_whitespace())
        .split(' ')
    {
        let v: f64 = v.parse().unwrap_or_else(|_| panic!("{stdout}"));
        assert!((-79.0..=-50.0).contains(&v), "{stdout}");
    }

    let bytes = std::fs::read(&heat).unwrap();
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "heat-map is a PNG");
    let heatmap = image::load_from_memory(&bytes).unwrap();
    assert_eq!((heatmap.width(), heatmap.height()), (32, 24));
}

#[test]
fn missing_file_is_a_one_line_error_naming_it() {
    let d = dir("missing");
    let a = write(&d, "a.png", &noise(16, 16));
    let missing = d.join("nope.png");
    let line = one_line_error(&["compare", s(&a), s(&missing), "--json"]);
    assert!(
        line.starts_with(&format!("error: {}: ", missing.display())),
        "{line}"
    );
}

#[test]
fn size_mismatch_is_a_one_line_error() {
    let d = dir("mismatch");
    let a = write(&d, "a.png", &noise(32, 24));
    let b = write(&d, "b.png", &noise(24, 32));
    let line = one_line_error(&["compare", s(&a), s(&b), "--json"]);
    assert!(line.contains("32x24") && line.contains("24x32"), "{line}");
    assert!(line.contains("a.png") && line.contains("b.png"), "{line}");
}

#[test]
fn a_crop_of_a_few_rows_has_no_ssim_but_a_flip_and_means() {
    let d = dir("few_rows");
    let (a, b) = noise_and_halved(&d);
    let v = json(&["compare", s(&a), s(&b), "--json", "--crop", "4,10,16,2"]);
    assert!(v["ssim"].is_null(), "{v}");
    assert!(v["flip_mean"].as_f64().unwrap() > 0.0, "{v}");
    let (ma, mb) = (&v["mean_a"], &v["mean_b"]);
    assert!((0..3).all(|i| mb[i].as_f64() < ma[i].as_f64()), "{v}");
    let out = sylvan(&["compare", s(&a), s(&b), "--crop", "4,10,16,2"]);
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(
        out.status.success() && stdout.contains("SSIM n/a"),
        "{stdout}"
    );
}
