//! Known values of the metrics on synthetic images: the foundation's "compare gives known
//! values" check. Every expected number here is either exact (derived by hand in the comment) or
//! measured from `nv-flip` 0.1.2 and pinned with a tight tolerance.

use sylvan_eval::{EvalError, RgbImage, compare, flip, load_rgb, psnr, save_png, ssim};

const C1: f64 = (0.01 * 255.0) * (0.01 * 255.0);

fn solid(w: u32, h: u32, rgb: [u8; 3]) -> RgbImage {
    RgbImage::from_pixel(w, h, image::Rgb(rgb))
}

/// Deterministic noise in `[lo, hi]` per channel (xorshift32).
fn noise(w: u32, h: u32, seed: u32, lo: u8, hi: u8) -> RgbImage {
    let mut s = seed.max(1);
    let span = u32::from(hi - lo) + 1;
    RgbImage::from_fn(w, h, |_, _| {
        image::Rgb(std::array::from_fn(|_| {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            lo + (s % span) as u8
        }))
    })
}

fn map(img: &RgbImage, f: impl Fn(usize, u8) -> u8) -> RgbImage {
    let mut out = img.clone();
    for (i, v) in out.iter_mut().enumerate() {
        *v = f(i % 3, *v);
    }
    out
}

#[test]
fn identical_images_are_perfect() {
    let a = noise(40, 30, 7, 0, 255);
    let f = flip(&a, &a).unwrap();
    assert_eq!((f.mean, f.p50, f.p95, f.max), (0.0, 0.0, 0.0, 0.0));
    assert_eq!(f.heatmap.dimensions(), (40, 30));
    // Every pixel is magma(0), the darkest colour of the map.
    let first = *f.heatmap.get_pixel(0, 0);
    assert!(f.heatmap.pixels().all(|p| *p == first));
    assert!(
        first.0.iter().all(|&c| c < 8),
        "magma(0) is near-black, got {first:?}"
    );

    assert_eq!(ssim(&a, &a).unwrap(), 1.0);
    assert_eq!(psnr(&a, &a).unwrap(), f64::INFINITY);
    let m = compare(&a, &a).unwrap();
    assert_eq!(
        (m.flip_mean, m.ssim, m.psnr),
        (0.0, Some(1.0), f64::INFINITY)
    );
}

#[test]
fn metrics_json_writes_infinite_psnr_as_null() {
    let a = solid(16, 16, [10, 20, 30]);
    let json = serde_json::to_value(compare(&a, &a).unwrap()).unwrap();
    assert_eq!(json["flip_mean"], 0.0);
    assert_eq!(json["ssim"], 1.0);
    assert!(json["psnr"].is_null());
}

#[test]
fn black_versus_white_flip_is_near_maximal() {
    let black = solid(32, 32, [0, 0, 0]);
    let white = solid(32, 32, [255, 255, 255]);
    let f = flip(&black, &white).unwrap();
    // Measured with nv-flip 0.1.2 (ꟻLIP LDR, 67 ppd): every pixel has the same error, since
    // uniform images have no edges or points; only the colour term contributes.
    const BLACK_WHITE: f32 = 0.967_395_4;
    assert!(
        f.mean > 0.9,
        "black vs white must be near the maximum, got {}",
        f.mean
    );
    assert!((f.mean - BLACK_WHITE).abs() < 1e-5, "got {}", f.mean);
    assert!((f.max - f.mean).abs() < 1e-4 && (f.p50 - f.mean).abs() < 1e-4);
    // Symmetric on this pair.
    assert!((flip(&white, &black).unwrap().mean - f.mean).abs() < 1e-4);
}

#[test]
fn flip_grows_with_the_difference() {
    let grey = solid(32, 32, [128, 128, 128]);
    let means: Vec<f32> = [130u8, 140, 170, 220]
        .iter()
        .map(|&v| flip(&grey, &solid(32, 32, [v, v, v])).unwrap().mean)
        .collect();
    assert!(means[0] > 0.0);
    assert!(means.windows(2).all(|w| w[0] < w[1]), "{means:?}");

    // Noise of growing amplitude added to the same image.
    let base = noise(48, 48, 3, 64, 191);
    let means: Vec<f32> = [4i16, 16, 48]
        .iter()
        .map(|&amp| {
            let jitter = noise(48, 48, 11, 0, 255);
            let test = RgbImage::from_fn(48, 48, |x, y| {
                let (b, j) = (base.get_pixel(x, y).0, jitter.get_pixel(x, y).0);
                image::Rgb(std::array::from_fn(|c| {
                    let d = (i16::from(j[c]) - 128) * amp / 128;
                    (i16::from(b[c]) + d).clamp(0, 255) as u8
                }))
            });
            flip(&base, &test).unwrap().mean
        })
        .collect();
    assert!(means.windows(2).all(|w| w[0] < w[1]), "{means:?}");
}

#[test]
fn psnr_of_a_uniform_offset_of_ten() {
    // Every sample differs by 10: MSE = 100, PSNR = 10·log10(255²/100) = 20·log10(25.5).
    let a = noise(20, 20, 5, 0, 245);
    let b = map(&a, |_, v| v + 10);
    let expected = 20.0 * 25.5_f64.log10();
    assert!((expected - 28.130_803_608_679_1).abs() < 1e-9);
    assert!((psnr(&a, &b).unwrap() - expected).abs() < 1e-12);
    assert!((psnr(&b, &a).unwrap() - expected).abs() < 1e-12);
}

#[test]
fn psnr_of_one_channel_offset() {
    // Only green is off by 10: one sample in three, so MSE = 100/3 and
    // PSNR = 10·log10(3·255²/100) = 10·log10(1950.75) ≈ 32.902 dB.
    let a = noise(20, 20, 9, 0, 245);
    let b = map(&a, |c, v| if c == 1 { v + 10 } else { v });
    let expected = 10.0 * 1950.75_f64.log10();
    assert!((expected - 32.902_016_155_875_7).abs() < 1e-9);
    assert!((psnr(&a, &b).unwrap() - expected).abs() < 1e-12);
}

#[test]
fn ssim_of_constant_images_is_the_luminance_term() {
    // No variance and no covariance: the contrast-structure term is C2/C2 = 1, leaving
    // (2μxμy + C1) / (μx² + μy² + C1). Grey c has luma c (the Rec.709 weights sum to 1).
    for (c1, c2) in [(50.0, 200.0), (0.0, 255.0), (128.0, 129.0)] {
        let a = solid(16, 13, [c1 as u8; 3]);
        let b = solid(16, 13, [c2 as u8; 3]);
        let expected = (2.0 * c1 * c2 + C1) / (c1 * c1 + c2 * c2 + C1);
        let got = ssim(&a, &b).unwrap();
        assert!(
            (got - expected).abs() < 1e-9,
            "{c1} vs {c2}: {got} vs {expected}"
        );
    }
}

#[test]
fn ssim_is_symmetric_and_below_one_for_different_images() {
    let a = noise(33, 21, 1, 0, 255);
    let b = noise(33, 21, 2, 0, 255);
    let ab = ssim(&a, &b).unwrap();
    let ba = ssim(&b, &a).unwrap();
    assert!((ab - ba).abs() < 1e-12, "{ab} vs {ba}");
    assert!(ab < 0.1, "independent noise is nearly unrelated, got {ab}");
    assert_eq!(ssim(&a, &a).unwrap(), 1.0);
}

#[test]
fn ssim_of_a_small_offset_is_close_to_but_below_one() {
    let a = noise(24, 24, 4, 20, 200);
    let b = map(&a, |_, v| v + 3);
    let s = ssim(&a, &b).unwrap();
    assert!(s < 1.0 && s > 0.99, "{s}");
}

#[test]
fn size_mismatch_is_a_typed_error_with_both_sizes() {
    let a = solid(16, 16, [0; 3]);
    let b = solid(16, 12, [0; 3]);
    for err in [
        flip(&a, &b).unwrap_err(),
        ssim(&a, &b).unwrap_err(),
        psnr(&a, &b).unwrap_err(),
        compare(&a, &b).unwrap_err(),
    ] {
        assert!(matches!(
            err,
            EvalError::SizeMismatch {
                reference: (16, 16),
                test: (16, 12)
            }
        ));
        let msg = err.to_string();
        assert!(
            msg.contains("16x16") && msg.contains("16x12") && msg.contains(" — "),
            "{msg}"
        );
        assert!(!msg.contains('\n'));
    }
}

#[test]
fn ssim_rejects_images_smaller_than_its_window() {
    let a = solid(10, 40, [0; 3]);
    let err = ssim(&a, &a).unwrap_err();
    assert!(matches!(
        err,
        EvalError::TooSmall {
            width: 10,
            height: 40,
            min: 11
        }
    ));
    assert!(psnr(&a, &a).is_ok() && flip(&a, &a).is_ok());
    // `compare` goes on without it: a few rows of a render are still worth a ꟻLIP and a PSNR.
    let b = solid(10, 40, [0, 0, 8]);
    let m = compare(&a, &b).unwrap();
    assert_eq!(m.ssim, None);
    assert!(m.flip_mean > 0.0 && m.psnr.is_finite());
    assert_eq!(
        serde_json::to_value(m).unwrap()["ssim"],
        serde_json::Value::Null
    );
    let empty = RgbImage::new(0, 0);
    assert!(matches!(psnr(&empty, &empty), Err(EvalError::Empty)));
    assert!(matches!(flip(&empty, &empty), Err(EvalError::Empty)));
}

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("sylvan-eval-known-values");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

#[test]
fn load_rgb_drops_alpha_and_reduces_16_bit() {
    let path = tmp("rgba16.png");
    let img = image::ImageBuffer::<image::Rgba<u16>, _>::from_fn(3, 2, |x, y| {
        image::Rgba([(x * 257 * 40) as u16, (y * 257 * 100) as u16, 65535, 0])
    });
    img.save(&path).unwrap();
    let rgb = load_rgb(&path).unwrap();
    assert_eq!(rgb.dimensions(), (3, 2));
    // Alpha 0 is ignored: the stored colours come back, 16-bit values v·257 → v.
    assert_eq!(rgb.get_pixel(2, 1).0, [80, 100, 255]);
    assert_eq!(rgb.get_pixel(0, 0).0, [0, 0, 255]);

    let out = tmp("roundtrip.png");
    save_png(&out, &rgb).unwrap();
    assert_eq!(load_rgb(&out).unwrap(), rgb);
}

#[test]
fn load_errors_name_the_file_on_one_line() {
    let missing = tmp("does-not-exist.png");
    let msg = load_rgb(&missing).unwrap_err().to_string();
    assert!(
        msg.starts_with(&format!("{}: ", missing.display())),
        "{msg}"
    );
    assert!(msg.contains(" — ") && !msg.contains('\n'), "{msg}");

    let garbage = tmp("garbage.png");
    std::fs::write(&garbage, b"not a png").unwrap();
    let msg = load_rgb(&garbage).unwrap_err().to_string();
    assert!(
        msg.starts_with(&format!("{}: ", garbage.display())),
        "{msg}"
    );

    let unwritable = tmp("no-such-dir/heat.png");
    let err = save_png(&unwritable, &solid(2, 2, [0; 3])).unwrap_err();
    assert!(
        err.to_string()
            .starts_with(&format!("{}: ", unwritable.display()))
    );
}
