//! The fidelity harness's table: one row per (case, technique), measured against the reference.

use crate::Metrics;
use std::fmt::Write;

/// One measured technique on one test case.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FidelityRow {
    /// The test case, e.g. `"pine-30m"`.
    pub case: String,
    /// The `--technique` name, e.g. `"hbt"`.
    pub technique: String,
    /// Mean ꟻLIP error against the reference; lower is better.
    pub flip_mean: f32,
    /// Mean SSIM against the reference; higher is better (`None`: images under 11×11).
    pub ssim: Option<f64>,
    /// PSNR against the reference in dB; `f64::INFINITY` when identical.
    pub psnr: f64,
}

impl FidelityRow {
    /// A row from the metrics of one comparison.
    pub fn new(case: impl Into<String>, technique: impl Into<String>, metrics: &Metrics) -> Self {
        Self {
            case: case.into(),
            technique: technique.into(),
            flip_mean: metrics.flip_mean,
            ssim: metrics.ssim,
            psnr: metrics.psnr,
        }
    }
}

/// Formats rows, in the given order, as a GitHub Markdown table (ending in a newline):
/// ꟻLIP to 4 decimals, SSIM to 4, PSNR to 2 dB, infinite PSNR as `∞`.
pub fn markdown_table(rows: &[FidelityRow]) -> String {
    let mut out = String::from("| case | technique | ꟻLIP mean ↓ | SSIM ↑ | PSNR dB ↑ |\n");
    out.push_str("|---|---|---:|---:|---:|\n");
    for r in rows {
        let psnr = if r.psnr.is_infinite() {
            "∞".to_owned()
        } else {
            format!("{:.2}", r.psnr)
        };
        let ssim = r
            .ssim
            .map_or_else(|| "n/a".to_owned(), |s| format!("{s:.4}"));
        let _ = writeln!(
            out,
            "| {} | {} | {:.4} | {ssim} | {} |",
            r.case, r.technique, r.flip_mean, psnr
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_has_header_and_one_line_per_row() {
        let rows = [
            FidelityRow::new(
                "pine-30m",
                "geometry",
                &Metrics {
                    flip_mean: 0.0,
                    ssim: Some(1.0),
                    psnr: f64::INFINITY,
                },
            ),
            FidelityRow::new(
                "pine-30m",
                "hbt",
                &Metrics {
                    flip_mean: 0.123_45,
                    ssim: Some(0.876_54),
                    psnr: 31.234,
                },
            ),
        ];
        let table = markdown_table(&rows);
        assert_eq!(
            table,
            "| case | technique | ꟻLIP mean ↓ | SSIM ↑ | PSNR dB ↑ |\n\
             |---|---|---:|---:|---:|\n\
             | pine-30m | geometry | 0.0000 | 1.0000 | ∞ |\n\
             | pine-30m | hbt | 0.1235 | 0.8765 | 31.23 |\n"
        );
    }
}
