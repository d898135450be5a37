//! `sylvan compare`: ꟻLIP, SSIM and PSNR of two PNGs, as one line for people or one JSON object
//! for tools (`--json`), optionally writing the ꟻLIP heat-map, with both images' mean linear
//! colours (a bias shows there apart from texture). The metrics are `sylvan-eval`'s.

use std::path::PathBuf;
use sylvan_eval::{EvalError, Metrics};

/// Flags of `sylvan compare`.
#[derive(clap::Args)]
#[command(after_help = "\
Metrics: FLIP (LDR, 67 pixels per degree; 0 = identical, lower is better), SSIM (Rec.709 luma, \
11x11 Gaussian window; 1 = identical; n/a, null in JSON, for images smaller than that), PSNR (RGB, 8-bit, dB), and each image's mean colour in \
linear light (sRGB decoded).
With --json, identical images have infinite PSNR, which JSON cannot write: \"psnr\" is null then.")]
pub struct CompareArgs {
    /// Reference image (PNG, 8- or 16-bit; alpha is ignored).
    a: PathBuf,
    /// Test image (PNG, the same size as A).
    b: PathBuf,
    /// Print one JSON object {"flip_mean", "ssim", "psnr", "mean_a", "mean_b"} on stdout ("psnr":
    /// null when identical; the means are linear [R, G, B]).
    #[arg(long)]
    json: bool,
    /// Also write the FLIP error heat-map (magma colours, black = no error) to this PNG.
    #[arg(long, value_name = "FILE.png")]
    heatmap: Option<PathBuf>,
    /// Compare only this rectangle of both images: X,Y,WIDTH,HEIGHT in pixels (clipped to the
    /// image), e.g. the region around one tree.
    #[arg(long, value_name = "X,Y,W,H")]
    crop: Option<String>,
}

/// Parses `X,Y,W,H` and clips it to a `width`×`height` image.
fn parse_crop(s: &str, width: u32, height: u32) -> anyhow::Result<[u32; 4]> {
    let bad = || {
        anyhow::anyhow!(
            "--crop {s}: expected X,Y,WIDTH,HEIGHT in pixels, e.g. --crop 100,50,200,300"
        )
    };
    let v: Vec<u32> = s
        .split(',')
        .map(|p| p.trim().parse::<u32>().map_err(|_| bad()))
        .collect::<Result<_, _>>()?;
    let [x, y, w, h] = <[u32; 4]>::try_from(v).map_err(|_| bad())?;
    if x >= width || y >= height || w == 0 || h == 0 {
        anyhow::bail!(
            "--crop {s}: the rectangle is outside the {width}x{height} image or empty — give a \
             corner inside the image and a non-zero size, e.g. --crop 0,0,{width},{height}"
        );
    }
    Ok([x, y, w.min(width - x), h.min(height - y)])
}

/// Runs `sylvan compare`.
pub fn run(args: CompareArgs) -> anyhow::Result<()> {
    let mut a = sylvan_eval::load_rgb(&args.a)?;
    let mut b = sylvan_eval::load_rgb(&args.b)?;
    if let Some(c) = &args.crop {
        let [x, y, w, h] = parse_crop(c, a.width(), a.height())?;
        if b.dimensions() != a.dimensions() {
            anyhow::bail!(
                "{} vs {}: the images differ in size ({}x{} vs {}x{}) — compare renders of the same --size",
                args.a.display(),
                args.b.display(),
                a.width(),
                a.height(),
                b.width(),
                b.height()
            );
        }
        a = image::imageops::crop_imm(&a, x, y, w, h).to_image();
        b = image::imageops::crop_imm(&b, x, y, w, h).to_image();
    }
    let (metrics, flip) = sylvan_eval::compare_detailed(&a, &b).map_err(|e| match e {
        // The library knows the sizes, not the files: name them.
        EvalError::SizeMismatch { .. } | EvalError::Empty => {
            anyhow::Error::new(e).context(format!("{} vs {}", args.a.display(), args.b.display()))
        }
        e => e.into(),
    })?;
    if let Some(path) = &args.heatmap {
        sylvan_eval::save_png(path, &flip.heatmap)?;
    }
    let means = [sylvan_eval::mean_linear(&a)?, sylvan_eval::mean_linear(&b)?];
    if args.json {
        #[derive(serde::Serialize)]
        struct Report {
            #[serde(flatten)]
            metrics: Metrics,
            mean_a: [f64; 3],
            mean_b: [f64; 3],
        }
        let [mean_a, mean_b] = means;
        let report = Report {
            metrics,
            mean_a,
            mean_b,
        };
        // serde_json writes an infinite PSNR as `null`.
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!("{}", human_line(&metrics, flip.p95, flip.max, means));
    }
    Ok(())
}

/// `FLIP 0.1333 (p95 0.4120, max 0.9830)  SSIM 0.9123  PSNR 31.20 dB  mean B/A −1.2 +0.4 +3.0 %`.
fn human_line(m: &Metrics, p95: f32, max: f32, [a, b]: [[f64; 3]; 2]) -> String {
    let psnr = if m.psnr.is_infinite() {
        "inf (identical)".to_owned()
    } else {
        format!("{:.2} dB", m.psnr)
    };
    let bias = |i: usize| {
        if a[i] > 0.0 {
            format!("{:+.1}", 100.0 * (b[i] / a[i] - 1.0))
        } else {
            "n/a".to_owned()
        }
    };
    let ssim = m
        .ssim
        .map_or_else(|| "n/a (under 11x11)".to_owned(), |s| format!("{s:.4}"));
    format!(
        "FLIP {:.4} (p95 {p95:.4}, max {max:.4})  SSIM {ssim}  PSNR {psnr}  mean B/A {} {} {} %",
        m.flip_mean,
        bias(0),
        bias(1),
        bias(2)
    )
}

#[cfg(test)]
mod tests {
    use super::parse_crop;

    #[test]
    fn crops_are_clipped_and_bad_ones_say_how_to_fix_them() {
        assert_eq!(parse_crop("10,20,500,5", 100, 50).unwrap(), [10, 20, 90, 5]);
        let e = parse_crop("100,0,5,5", 100, 50).unwrap_err().to_string();
        assert!(
            e.starts_with(
                "--crop 100,0,5,5: the rectangle is outside the 100x50 image or empty — "
            ) && e.ends_with("e.g. --crop 0,0,100,50"),
            "{e}"
        );
        let e = parse_crop("1,2,3", 100, 50).unwrap_err().to_string();
        assert!(e.contains(" — ") || e.contains("e.g. --crop"), "{e}");
    }
}
