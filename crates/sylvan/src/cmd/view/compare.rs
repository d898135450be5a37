//! "Compare with reference": the current view rendered again as the ground truth (technique
//! `geometry`, `--spp 16`) on a worker thread, so the window stays live while a software
//! rasteriser takes its time, then ꟻLIP against the frame on screen; the heat-map is overlaid.

use super::viewer::Settings;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, TryRecvError, channel};
use std::time::Instant;
use sylvan_gpu::Gpu;
use sylvan_plant::Plant;
use sylvan_render::{RenderOptions, Renderer};
use sylvan_scene::{Camera, Scene};

/// A finished comparison.
pub struct CompareResult {
    /// Mean ꟻLIP error (0 = identical).
    pub flip_mean: f32,
    /// 95th percentile of the ꟻLIP error.
    pub flip_p95: f32,
    /// The ꟻLIP heat-map (magma), the size of the view.
    pub heatmap: image::RgbImage,
    /// How long the reference took (ms).
    pub ms: f64,
}

/// The comparison job: idle, running, or done.
#[derive(Default)]
pub struct Comparison {
    running: Option<(Instant, Receiver<Result<CompareResult, String>>)>,
    /// The last result (its heat-map is uploaded by the panel once).
    pub result: Option<CompareResult>,
    /// Bumped whenever `result` changes (the panel re-uploads the heat-map then).
    pub generation: u64,
}

impl Comparison {
    /// Seconds the running comparison has taken so far, if one runs.
    pub fn running_for(&self) -> Option<f64> {
        self.running
            .as_ref()
            .map(|(t, _)| t.elapsed().as_secs_f64())
    }

    /// Starts rendering the reference of `camera` in `scene` on a worker thread.
    #[allow(clippy::too_many_arguments)]
    pub fn start(
        &mut self,
        gpu: Arc<Gpu>,
        scene: Scene,
        plants: Vec<Plant>,
        options: RenderOptions,
        camera: Camera,
        settings: Settings,
        test: image::RgbaImage,
    ) {
        if self.running.is_some() {
            return;
        }
        let (tx, rx) = channel();
        std::thread::spawn(move || {
            let result = reference(&gpu, &scene, &plants, &options, &camera, &settings, test);
            let _ = tx.send(result);
        });
        self.running = Some((Instant::now(), rx));
    }

    /// Collects a finished comparison: `Some(Err(..))` when it failed.
    pub fn poll(&mut self) -> Option<Result<(), String>> {
        let (_, rx) = self.running.as_ref()?;
        let outcome = match rx.try_recv() {
            Ok(r) => r,
            Err(TryRecvError::Empty) => return None,
            Err(TryRecvError::Disconnected) => {
                Err("compare: the reference render stopped unexpectedly".into())
            }
        };
        self.running = None;
        Some(outcome.map(|r| {
            self.result = Some(r);
            self.generation += 1;
        }))
    }

    /// Waits for the running comparison (scripted runs).
    pub fn wait(&mut self) -> Option<Result<(), String>> {
        loop {
            self.running.as_ref()?;
            if let Some(r) = self.poll() {
                return Some(r);
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
    }
}

fn reference(
    gpu: &Gpu,
    scene: &Scene,
    plants: &[Plant],
    options: &RenderOptions,
    camera: &Camera,
    settings: &Settings,
    test: image::RgbaImage,
) -> Result<CompareResult, String> {
    let start = Instant::now();
    let mut r = Renderer::new(gpu, scene, plants, options).map_err(|e| format!("compare: {e}"))?;
    r.set_sky(settings.sky);
    r.set_fog(settings.fog);
    r.render(gpu, camera, &settings.sun)
        .map_err(|e| format!("compare: {e}"))?;
    let reference = r.read_image(gpu).map_err(|e| format!("compare: {e}"))?;
    let ms = start.elapsed().as_secs_f64() * 1e3;
    let rgb = |i: image::RgbaImage| image::DynamicImage::ImageRgba8(i).into_rgb8();
    let (_, flip) = sylvan_eval::compare_detailed(&rgb(reference), &rgb(test))
        .map_err(|e| format!("compare: {e}"))?;
    Ok(CompareResult {
        flip_mean: flip.mean,
        flip_p95: flip.p95,
        heatmap: flip.heatmap,
        ms,
    })
}
