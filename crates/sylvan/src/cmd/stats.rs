//! The JSON shape shared by `render --stats` and `bench --json` (DESIGN.md contract).

use serde::Serialize;
use std::collections::BTreeMap;
use sylvan_render::FrameStats;

/// `frame_ms` summary.
#[derive(Serialize, Debug, Clone, Copy)]
pub struct Summary {
    pub median: f64,
    pub p95: f64,
    pub min: f64,
    pub max: f64,
}

impl Summary {
    /// Summarises samples (nearest-rank percentiles).
    pub fn of(samples: &[f64]) -> Self {
        let mut s = samples.to_vec();
        s.sort_by(f64::total_cmp);
        let rank = |q: f64| s[((q * s.len() as f64).ceil() as usize).clamp(1, s.len()) - 1];
        let median = if s.len() % 2 == 1 {
            s[s.len() / 2]
        } else {
            0.5 * (s[s.len() / 2 - 1] + s[s.len() / 2])
        };
        Self {
            median,
            p95: rank(0.95),
            min: s[0],
            max: s[s.len() - 1],
        }
    }
}

/// One JSON object describing frames of one technique on one scene.
#[derive(Serialize, Debug)]
pub struct Report {
    pub technique: String,
    pub frames: usize,
    pub size: [u32; 2],
    pub spp: u32,
    pub frame_ms: Summary,
    /// The frame's parts (GPU timer only; absent with the wall clock): `prepare` (tile
    /// uploads, the GPU cull, the techniques' compute work), `shadows` (the cascades),
    /// `ground` (sky, terrain and the shader-map's far field), `trees` (every band's trees),
    /// `resolve` (tone mapping and downsampling), each summarised over the frames like
    /// `frame_ms` — BN12 §9's split of a frame.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub split_ms: BTreeMap<String, Summary>,
    /// CPU time before recording each frame (culling, LOD traversal, uploads), not in `frame_ms`.
    pub cpu_ms: Summary,
    pub timer: &'static str,
    pub trees_total: usize,
    pub trees_drawn: BTreeMap<String, u32>,
    pub triangles: u64,
    pub shadow_triangles: u64,
    pub draw_calls: u32,
    pub baked_bytes: u64,
    pub gpu_bytes: u64,
    pub bake_ms: f64,
    /// Scene file to the first frame's commands (`bench`): loading the scene, preparing the
    /// renderer (bakes or cache reads) and the first frame's CPU work — tile production
    /// included — but not the GPU's time for it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub startup_ms: Option<f64>,
    /// Each drawing technique's own statistics (last frame), under its name: e.g.
    /// `"hbt": {"trees_opened": 12, "visibility_bytes": 3072, …}`.
    #[serde(flatten)]
    pub techniques: BTreeMap<String, BTreeMap<String, serde_json::Value>>,
    pub adapter: String,
    /// `render --measure X,Y,W,H`: the last frame's mean linear radiance (RGB, before exposure
    /// and tone mapping) over that rectangle of output pixels.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radiance_mean: Option<[f32; 3]>,
    /// The camera path replayed (`bench --path`), as given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub path: Option<String>,
    /// One record per timed frame (`bench --path`); `frames` stays the count.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub per_frame: Option<Vec<FrameRecord>>,
}

/// One frame of a path replay: when on the path, what it cost and drew.
#[derive(Serialize, Debug, Clone)]
pub struct FrameRecord {
    /// Path time in seconds.
    pub t: f32,
    /// Frame time in milliseconds (the report's `timer`).
    pub ms: f64,
    /// The frame's parts, milliseconds (as the report's `split_ms`).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub split_ms: BTreeMap<String, f64>,
    /// CPU milliseconds before recording (as the report's `cpu_ms`).
    pub cpu_ms: f64,
    /// The tiled world's statistics (GPU-driven techniques): tiles produced, waited for, …
    #[serde(skip_serializing_if = "Option::is_none")]
    pub world: Option<BTreeMap<String, f64>>,
    /// Trees drawn per technique.
    pub trees_drawn: BTreeMap<String, u32>,
    /// Triangles in the camera pass.
    pub triangles: u64,
    /// Triangles in the shadow passes.
    pub shadow_triangles: u64,
    /// Draw calls over all passes.
    pub draw_calls: u32,
}

impl FrameRecord {
    /// The record of `stats`, taken at path time `t`.
    pub fn new(t: f32, stats: &FrameStats) -> Self {
        Self {
            t,
            ms: stats.frame_ms,
            split_ms: stats
                .split_ms
                .iter()
                .map(|&(label, ms)| (label.to_string(), ms))
                .collect(),
            cpu_ms: stats.cpu_ms,
            world: stats.technique_stats.get("world").cloned(),
            trees_drawn: stats.trees_drawn.clone(),
            triangles: stats.triangles,
            shadow_triangles: stats.shadow_triangles,
            draw_calls: stats.draw_calls,
        }
    }
}

impl Report {
    /// Builds a report from per-frame stats (the last frame's counts, all frames' times).
    pub fn new(
        technique: &str,
        size: [u32; 2],
        spp: u32,
        frames: &[FrameStats],
        bake_ms: f64,
        adapter: String,
    ) -> Self {
        let last = frames.last().cloned().expect("at least one frame");
        let times: Vec<f64> = frames.iter().map(|f| f.frame_ms).collect();
        Self {
            technique: technique.to_string(),
            frames: frames.len(),
            size,
            spp,
            frame_ms: Summary::of(&times),
            split_ms: split_summaries(frames),
            cpu_ms: Summary::of(&frames.iter().map(|f| f.cpu_ms).collect::<Vec<_>>()),
            timer: last.timer.as_str(),
            trees_total: last.trees_total,
            trees_drawn: last.trees_drawn,
            triangles: last.triangles,
            shadow_triangles: last.shadow_triangles,
            draw_calls: last.draw_calls,
            baked_bytes: last.asset_bytes,
            gpu_bytes: last.gpu_bytes,
            bake_ms,
            startup_ms: None,
            techniques: last
                .technique_stats
                .iter()
                .map(|(name, stats)| {
                    let values = stats.iter().map(|(k, &v)| (k.clone(), number(v))).collect();
                    (name.clone(), values)
                })
                .collect(),
            adapter,
            radiance_mean: None,
            path: None,
            per_frame: None,
        }
    }
}

/// Each part of the frames' split summarised over the frames that have it.
fn split_summaries(frames: &[FrameStats]) -> BTreeMap<String, Summary> {
    let mut parts: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for f in frames {
        for (label, ms) in &f.split_ms {
            parts.entry(label.to_string()).or_default().push(*ms);
        }
    }
    parts
        .into_iter()
        .map(|(label, ms)| (label, Summary::of(&ms)))
        .collect()
}

/// A statistic as JSON: whole numbers as integers.
fn number(v: f64) -> serde_json::Value {
    if v.fract() == 0.0 && v.abs() < 9.0e15 {
        (v as i64).into()
    } else {
        v.into()
    }
}

#[cfg(test)]
mod tests {
    use super::Summary;

    #[test]
    fn summary_percentiles() {
        let s = Summary::of(&[5.0, 1.0, 3.0, 2.0, 4.0]);
        assert_eq!((s.median, s.min, s.max, s.p95), (3.0, 1.0, 5.0, 5.0));
        let s = Summary::of(&(1..=100).map(f64::from).collect::<Vec<_>>());
        assert_eq!((s.median, s.p95), (50.5, 95.0));
    }
}
