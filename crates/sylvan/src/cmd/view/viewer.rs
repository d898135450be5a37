//! The viewer's state without the window: the last good scene and its plants, the renderer,
//! the panel's settings, and how a change of setting reaches the renderer — a field write for
//! light, fog and debug views; a new renderer for technique, density or LOD bands (the old one
//! keeps running when the new one cannot be made, and the one-line error goes to the panel).

use super::camera::Controller;
use super::compare::Comparison;
use super::reload::SceneWatcher;
use std::sync::Arc;
use sylvan_gpu::Gpu;
use sylvan_plant::Plant;
use sylvan_render::{DebugView, RenderOptions, Renderer};
use sylvan_scene::{Fog, Scene, Sky, Sun};

/// What the panel edits.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Sun direction and colour.
    pub sun: Sun,
    /// Sky colours.
    pub sky: Sky,
    /// Fog.
    pub fog: Fog,
    /// Exposure multiplier.
    pub exposure: f32,
    /// Cascaded shadows.
    pub shadows: bool,
    /// Debug colouring.
    pub debug: DebugView,
    /// Scene resolution relative to the window (software adapters want < 1).
    pub render_scale: f32,
    /// Present with vsync.
    pub vsync: bool,
    /// The structural part: changing it rebuilds the renderer.
    pub build: BuildSettings,
}

/// Settings that need a new renderer.
#[derive(Debug, Clone, PartialEq)]
pub struct BuildSettings {
    /// Technique for every tree (`auto`: the LOD chain).
    pub technique: String,
    /// The `auto` chain, in scene-file spelling (`"geometry:0-60"`).
    pub lod_chain: Vec<String>,
    /// Per species: fraction of its placed trees that are drawn (0–1).
    pub density: Vec<f32>,
}

/// The viewer's scene, renderer and settings.
pub struct Viewer {
    /// The last scene that loaded.
    pub scene: Scene,
    plants: Vec<Plant>,
    /// The renderer in use (the last one that could be made).
    pub renderer: Renderer,
    base: RenderOptions,
    /// What the panel shows and edits.
    pub settings: Settings,
    /// The build settings of `renderer`.
    built: BuildSettings,
    /// The camera.
    pub camera: Controller,
    /// Hot reload of the scene file (none for the built-in scene).
    pub watcher: Option<SceneWatcher>,
    /// The command line's changes to the scene, applied to each reload too.
    pub overrides: crate::cmd::common::SceneOverrides,
    /// The last error, one line, shown in the panel until the next success.
    pub error: Option<String>,
    /// A short note for the panel (screenshot written, path saved, …).
    pub notice: Option<String>,
    /// The "compare with reference" job and its result.
    pub comparison: Comparison,
    /// Renderers made since start (the first included).
    pub rebuilds: u64,
    /// Set when the renderer's output texture changed (the presenter re-binds it).
    pub output_changed: bool,
}

impl Viewer {
    /// Loads plants and makes the first renderer; errors here end the program.
    pub fn new(
        gpu: &Gpu,
        scene: Scene,
        options: RenderOptions,
        sun: Sun,
        camera: Controller,
    ) -> anyhow::Result<Self> {
        let plants = sylvan_render::load_plants(&scene)?;
        let settings = Settings {
            sun,
            sky: scene.sky,
            fog: scene.fog,
            exposure: options.exposure,
            shadows: options.shadows,
            debug: options.debug,
            render_scale: 1.0,
            vsync: true,
            build: BuildSettings {
                technique: options.technique.clone(),
                lod_chain: scene.lod_chain.clone(),
                density: vec![1.0; scene.species.len()],
            },
        };
        let renderer = make_renderer(gpu, &scene, &plants, &options, &settings)?;
        let watcher = scene.source.as_deref().map(SceneWatcher::new);
        Ok(Self {
            built: settings.build.clone(),
            scene,
            plants,
            renderer,
            base: options,
            settings,
            camera,
            watcher,
            overrides: Default::default(),
            error: None,
            notice: None,
            comparison: Comparison::default(),
            rebuilds: 1,
            output_changed: true,
        })
    }

    /// Before a frame: picks up scene-file edits, rebuilds when a structural setting changed,
    /// pushes light/fog/debug settings, and sizes the scene to `width × height`.
    pub fn sync(&mut self, gpu: &Gpu, width: u32, height: u32) {
        if let Some(result) = self
            .watcher
            .as_mut()
            .and_then(|w| w.poll(std::time::Instant::now()))
        {
            match result {
                Ok(mut scene) => {
                    self.overrides.apply(&mut scene);
                    self.reload(gpu, scene)
                }
                Err(e) => self.error = Some(e),
            }
        }
        if self.settings.build != self.built {
            let scene = self.scene.clone();
            let plants = self.plants.clone();
            if self.replace_renderer(gpu, &scene, plants) {
                self.built = self.settings.build.clone();
            } else {
                // Show what is drawn: the settings of the renderer that kept running.
                self.settings.build = self.built.clone();
            }
        }
        let s = &self.settings;
        let r = &mut self.renderer;
        r.set_sky(s.sky);
        r.set_fog(s.fog);
        r.set_exposure(s.exposure);
        r.set_debug(s.debug);
        r.set_shadows(s.shadows);
        let scale = s.render_scale.clamp(0.1, 1.0);
        let (w, h) = (
            ((width as f32 * scale).round() as u32).max(1),
            ((height as f32 * scale).round() as u32).max(1),
        );
        let before = (r.options().width, r.options().height);
        if before != (w, h) {
            match r.resize(gpu, w, h) {
                Ok(()) => self.output_changed = true,
                Err(e) => self.error = Some(e.to_string()),
            }
        }
    }

    /// A scene that loaded from disk: new plants and renderer; on failure the old ones stay.
    fn reload(&mut self, gpu: &Gpu, scene: Scene) {
        let plants = match sylvan_render::load_plants(&scene) {
            Ok(p) => p,
            Err(e) => {
                self.error = Some(e.to_string());
                return;
            }
        };
        let old = std::mem::replace(&mut self.scene, scene.clone());
        // Keep the panel's edits unless the file changed that very setting.
        let s = &mut self.settings;
        if old.sun != scene.sun {
            s.sun = scene.sun;
        }
        if old.sky != scene.sky {
            s.sky = scene.sky;
        }
        if old.fog != scene.fog {
            s.fog = scene.fog;
        }
        if old.lod_chain != scene.lod_chain {
            s.build.lod_chain = scene.lod_chain.clone();
        }
        s.build.density = scene
            .species
            .iter()
            .map(|sp| {
                old.species
                    .iter()
                    .position(|o| o.name == sp.name)
                    .and_then(|i| s.build.density.get(i).copied())
                    .unwrap_or(1.0)
            })
            .collect();
        if old.camera != scene.camera {
            self.camera = Controller::new(scene.camera);
        }
        if self.replace_renderer(gpu, &scene, plants) {
            self.built = self.settings.build.clone();
            self.notice = Some("scene reloaded".into());
        } else {
            // The renderer could not take the new scene: keep drawing the old one.
            self.scene = old;
            self.settings.build = self.built.clone();
        }
    }

    /// Makes a renderer for `scene` with the current settings; keeps the old one on error.
    fn replace_renderer(&mut self, gpu: &Gpu, scene: &Scene, plants: Vec<Plant>) -> bool {
        let mut options = self.base.clone();
        options.width = self.renderer.options().width;
        options.height = self.renderer.options().height;
        match make_renderer(gpu, scene, &plants, &options, &self.settings) {
            Ok(r) => {
                self.renderer = r;
                self.plants = plants;
                self.rebuilds += 1;
                self.output_changed = true;
                self.error = None;
                true
            }
            Err(e) => {
                self.error = Some(super::one_line(&e));
                false
            }
        }
    }

    /// The scene as drawn: density-thinned trees and the edited LOD chain.
    pub fn effective_scene(&self) -> Scene {
        effective_scene(&self.scene, &self.settings.build)
    }

    /// Starts "compare with reference" for the current view (the frame just rendered).
    pub fn start_comparison(&mut self, gpu: &Arc<Gpu>) {
        if self.settings.debug != DebugView::None {
            self.error = Some("compare: switch the debug view to none first".into());
            return;
        }
        let test = match self.renderer.read_image(gpu) {
            Ok(i) => i,
            Err(e) => {
                self.error = Some(e.to_string());
                return;
            }
        };
        let mut options = self.renderer.options().clone();
        options.technique = "geometry".into();
        options.spp = 16;
        options.debug = DebugView::None;
        self.comparison.start(
            gpu.clone(),
            self.effective_scene(),
            self.plants.clone(),
            options,
            self.camera.camera(),
            self.settings.clone(),
            test,
        );
    }
}

fn make_renderer(
    gpu: &Gpu,
    scene: &Scene,
    plants: &[Plant],
    base: &RenderOptions,
    s: &Settings,
) -> anyhow::Result<Renderer> {
    let options = RenderOptions {
        technique: s.build.technique.clone(),
        shadows: s.shadows,
        exposure: s.exposure,
        debug: s.debug,
        ..base.clone()
    };
    let scene = effective_scene(scene, &s.build);
    let mut r = Renderer::new(gpu, &scene, plants, &options)?;
    r.set_sky(s.sky);
    r.set_fog(s.fog);
    Ok(r)
}

/// `scene` with each species thinned to its density fraction (a fixed, seeded subset, so
/// moving a slider down and up again brings the same trees back) and the edited LOD chain.
pub fn effective_scene(scene: &Scene, b: &BuildSettings) -> Scene {
    let mut s = scene.clone();
    s.lod_chain = b.lod_chain.clone();
    if b.density.iter().any(|&d| d < 1.0) {
        s.trees = scene
            .trees
            .iter()
            .enumerate()
            .filter(|(i, t)| {
                let keep = b.density.get(t.species as usize).copied().unwrap_or(1.0);
                unit_hash(*i as u64) < keep
            })
            .map(|(_, t)| *t)
            .collect();
    }
    s
}

/// A stable hash of `i` in [0, 1) (splitmix64).
fn unit_hash(i: u64) -> f32 {
    let mut z = i.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 40) as f32 / (1u64 << 24) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn density_thins_each_species_to_about_its_fraction() {
        let scene = Scene::builtin_grove();
        let species = scene.species.len();
        assert!(species >= 2);
        let mut density = vec![1.0; species];
        density[0] = 0.25;
        let b = BuildSettings {
            technique: "geometry".into(),
            lod_chain: vec!["geometry:0-60".into()],
            density,
        };
        let s = effective_scene(&scene, &b);
        let count = |sc: &Scene, k: u32| sc.trees.iter().filter(|t| t.species == k).count();
        let (before, after) = (count(&scene, 0) as f32, count(&s, 0) as f32);
        assert!((after / before - 0.25).abs() < 0.05, "{after} of {before}");
        assert_eq!(count(&s, 1), count(&scene, 1));
        assert_eq!(s.lod_chain, vec!["geometry:0-60".to_string()]);
        // The same subset every time.
        assert_eq!(effective_scene(&scene, &b).trees, s.trees);
    }
}
