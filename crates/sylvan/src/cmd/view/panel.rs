//! The egui side of the viewer: the settings panel (scene and reload errors, technique and LOD
//! bands, density, light, camera and paths, debug views, compare with reference), the stats
//! overlay, and the ꟻLIP heat-map overlay. The panel edits [`Viewer`] settings directly and asks
//! for anything that needs the window or the GPU through [`Action`]s, run after the frame.

use super::camera::Mode;
use super::stats::{FrameClock, bytes};
use super::viewer::Viewer;
use egui::{Align2, Color32, RichText};
use sylvan_render::{DebugView, registry};

/// Requests the panel makes of the application.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Action {
    /// Write a screenshot PNG.
    Screenshot,
    /// Render the reference and compare.
    Compare,
    /// Orbit the tree at the centre of the view.
    OrbitCentre,
    /// Start or stop recording; stopping saves to the path file.
    ToggleRecording,
    /// Load the path file and play it.
    LoadPath,
}

/// Panel state that is not a render setting.
pub struct UiState {
    /// Show the settings panel (F1).
    pub show_panel: bool,
    /// Show the stats overlay.
    pub show_stats: bool,
    /// Camera path file for recording and loading.
    pub path_file: String,
    /// Overlay the ꟻLIP heat-map of the last comparison.
    pub show_heatmap: bool,
    /// Heat-map opacity.
    pub heatmap_opacity: f32,
    heatmap: Option<(u64, egui::TextureHandle)>,
    /// The baked-image preview of the renderer made at rebuild N.
    atlas: Option<(u64, Option<egui::TextureHandle>)>,
    show_atlas: bool,
    /// What the panel asked for this frame.
    pub actions: Vec<Action>,
    /// Adapter line for the stats overlay.
    pub adapter: String,
}

impl UiState {
    /// Defaults: panel and stats shown.
    pub fn new(adapter: String, path_file: String) -> Self {
        Self {
            show_panel: true,
            show_stats: true,
            path_file,
            show_heatmap: true,
            heatmap_opacity: 0.85,
            heatmap: None,
            atlas: None,
            show_atlas: false,
            actions: Vec::new(),
            adapter,
        }
    }
}

/// Builds this frame's UI.
pub fn show(ui: &mut egui::Ui, v: &mut Viewer, s: &mut UiState, clock: &FrameClock) {
    let ctx = ui.ctx().clone();
    upload_heatmap(&ctx, v, s);
    if s.show_heatmap
        && let Some((_, tex)) = &s.heatmap
    {
        let alpha = (s.heatmap_opacity.clamp(0.0, 1.0) * 255.0) as u8;
        ctx.layer_painter(egui::LayerId::background()).image(
            tex.id(),
            ctx.content_rect(),
            egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)),
            Color32::from_white_alpha(alpha),
        );
    }
    if s.show_panel {
        egui::Panel::left("sylvan_panel")
            .default_size(190.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| panel(ui, v, s));
            });
    }
    if s.show_stats {
        egui::Area::new(egui::Id::unique("sylvan_stats"))
            .anchor(Align2::RIGHT_TOP, [-6.0, 6.0])
            .interactable(false)
            .show(&ctx, |ui| {
                egui::Frame::popup(ui.style()).show(ui, |ui| overlay(ui, v, s, clock));
            });
    }
}

/// The technique's baked images (one row per plant: its root box's images) and the bake
/// reports; the texture is uploaded once per renderer.
fn baked_atlases(ui: &mut egui::Ui, v: &Viewer, s: &mut UiState) {
    if s.atlas.as_ref().is_none_or(|(g, _)| *g != v.rebuilds) {
        let tex = v.renderer.atlas_preview().map(|img| {
            let color = egui::ColorImage::from_rgba_unmultiplied(
                [img.width() as usize, img.height() as usize],
                img.as_raw(),
            );
            ui.ctx()
                .load_texture("baked_atlas", color, egui::TextureOptions::NEAREST)
        });
        s.atlas = Some((v.rebuilds, tex));
    }
    let Some((_, Some(tex))) = &s.atlas else {
        ui.label(RichText::new("baked atlases: this technique bakes none").small());
        return;
    };
    ui.checkbox(&mut s.show_atlas, "show baked atlases");
    if s.show_atlas {
        for r in v.renderer.bake_reports() {
            ui.label(
                RichText::new(format!(
                    "{}: {:.1} MB, {} in {:.0} ms",
                    r.plant,
                    r.bytes as f64 / 1e6,
                    if r.from_cache { "cached" } else { "baked" },
                    r.ms
                ))
                .small(),
            );
        }
        let size = tex.size_vec2();
        let w = ui.available_width().min(size.x);
        ui.image((tex.id(), egui::vec2(w, size.y * w / size.x.max(1.0))));
    }
}

fn upload_heatmap(ctx: &egui::Context, v: &Viewer, s: &mut UiState) {
    let Some(result) = &v.comparison.result else {
        return;
    };
    let generation = v.comparison.generation;
    if s.heatmap.as_ref().is_some_and(|(g, _)| *g == generation) {
        return;
    }
    let img = &result.heatmap;
    let color =
        egui::ColorImage::from_rgb([img.width() as usize, img.height() as usize], img.as_raw());
    let tex = ctx.load_texture("flip_heatmap", color, egui::TextureOptions::LINEAR);
    s.heatmap = Some((generation, tex));
    s.show_heatmap = true;
}

fn overlay(ui: &mut egui::Ui, v: &Viewer, s: &UiState, clock: &FrameClock) {
    let timer = clock.last.as_ref().map_or("gpu", |f| f.timer.as_str());
    let out = v.renderer.options();
    let mut text = format!(
        "{:.1} ms {timer} · {:.1} ms cpu\n{}x{} · {}",
        clock.gpu_ms(),
        clock.cpu_ms(),
        out.width,
        out.height,
        s.adapter
    );
    if let Some(f) = &clock.last {
        for (technique, n) in &f.trees_drawn {
            text += &format!("\n{technique}: {n} of {} trees", f.trees_total);
        }
        text += &format!(
            "\n{} tris (+{} shadow) · {} draws\nbaked {} · gpu {}",
            millions(f.triangles),
            millions(f.shadow_triangles),
            f.draw_calls,
            bytes(f.asset_bytes),
            bytes(f.gpu_bytes)
        );
    }
    ui.label(RichText::new(text).monospace().size(10.0));
}

/// `1.23M`, `45.6k`, `789`.
fn millions(n: u64) -> String {
    match n {
        0..1_000 => n.to_string(),
        1_000..1_000_000 => format!("{:.1}k", n as f64 / 1e3),
        _ => format!("{:.2}M", n as f64 / 1e6),
    }
}

fn panel(ui: &mut egui::Ui, v: &mut Viewer, s: &mut UiState) {
    ui.heading("Sylvan");
    let source = v
        .scene
        .source
        .as_ref()
        .map_or("built-in scene".to_string(), |p| p.display().to_string());
    ui.style_mut().spacing.slider_width = 100.0;
    ui.add(egui::Label::new(RichText::new(source).small()).truncate());
    if let Some(e) = &v.error {
        ui.label(RichText::new(e).color(Color32::from_rgb(255, 110, 90)));
    }
    if let Some(n) = &v.notice {
        ui.label(RichText::new(n).color(Color32::from_rgb(140, 220, 140)));
    }

    egui::CollapsingHeader::new("Technique")
        .default_open(true)
        .show(ui, |ui| technique(ui, v));
    egui::CollapsingHeader::new("Light and fog")
        .default_open(true)
        .show(ui, |ui| light(ui, v));
    egui::CollapsingHeader::new("Camera")
        .default_open(false)
        .show(ui, |ui| camera(ui, v, s));
    egui::CollapsingHeader::new("Debug")
        .default_open(false)
        .show(ui, |ui| debug(ui, v, s));
}

fn technique(ui: &mut egui::Ui, v: &mut Viewer) {
    let b = &mut v.settings.build;
    egui::ComboBox::from_id_salt("technique")
        .selected_text(b.technique.clone())
        .show_ui(ui, |ui| {
            for e in registry::REGISTRY {
                ui.selectable_value(&mut b.technique, e.name.to_string(), e.name);
            }
        });
    if b.technique == "auto" || !b.lod_chain.is_empty() {
        ui.label("auto: distance bands (m)");
        let mut remove = None;
        for (i, entry) in b.lod_chain.iter_mut().enumerate() {
            ui.horizontal(|ui| {
                if let Some(mut band) = Band::parse(entry) {
                    let mut changed = false;
                    egui::ComboBox::from_id_salt(("band", i))
                        .width(90.0)
                        .selected_text(band.technique.clone())
                        .show_ui(ui, |ui| {
                            for name in sylvan_render::technique::lod::chainable() {
                                changed |= ui
                                    .selectable_value(&mut band.technique, name.to_string(), name)
                                    .changed();
                            }
                        });
                    changed |= ui
                        .add(egui::DragValue::new(&mut band.from).range(0.0..=1e5))
                        .changed();
                    let mut open = band.to.is_none();
                    let mut to = band.to.unwrap_or(band.from + 100.0);
                    if !open {
                        changed |= ui
                            .add(egui::DragValue::new(&mut to).range(band.from..=1e5))
                            .changed();
                    }
                    changed |= ui.checkbox(&mut open, "∞").changed();
                    band.to = (!open).then_some(to);
                    if changed {
                        *entry = band.to_string();
                    }
                } else {
                    ui.text_edit_singleline(entry);
                }
                if ui.small_button("✖").clicked() {
                    remove = Some(i);
                }
            });
        }
        if let Some(i) = remove {
            b.lod_chain.remove(i);
        }
        if ui.small_button("add band").clicked() {
            let from = b
                .lod_chain
                .last()
                .and_then(|e| Band::parse(e))
                .and_then(|band| band.to)
                .unwrap_or(0.0);
            b.lod_chain.push(format!("geometry:{from}-"));
        }
    }
    if !v.scene.species.is_empty() {
        ui.label("density (share of placed trees)");
        for (i, (sp, d)) in v.scene.species.iter().zip(b.density.iter_mut()).enumerate() {
            // Rebuild on release, not on every step of a drag: the dragged value lives in
            // egui's memory until then.
            let id = egui::Id::unique(("sylvan_density", i));
            let mut pct = ui.data(|m| m.get_temp::<f32>(id)).unwrap_or(*d * 100.0);
            let r = ui.add(
                egui::Slider::new(&mut pct, 0.0..=100.0)
                    .suffix(" %")
                    .text(&sp.name),
            );
            if r.dragged() {
                ui.data_mut(|m| m.insert_temp(id, pct));
            } else if r.drag_stopped() || r.changed() {
                *d = pct / 100.0;
                ui.data_mut(|m| m.remove::<f32>(id));
            }
        }
    }
}

fn light(ui: &mut egui::Ui, v: &mut Viewer) {
    let s = &mut v.settings;
    ui.add(egui::Slider::new(&mut s.sun.azimuth_deg, 0.0..=360.0).text("sun azimuth °"));
    ui.add(egui::Slider::new(&mut s.sun.elevation_deg, -10.0..=90.0).text("sun elevation °"));
    ui.horizontal(|ui| {
        ui.color_edit_button_rgb(&mut s.sky.zenith);
        ui.label("zenith");
        ui.color_edit_button_rgb(&mut s.sky.horizon);
        ui.label("horizon");
    });
    ui.horizontal(|ui| {
        ui.color_edit_button_rgb(&mut s.sky.ground);
        ui.label("ground");
        ui.color_edit_button_rgb(&mut s.sun.color);
        ui.label("sun");
    });
    ui.add(
        egui::Slider::new(&mut s.fog.half_distance_m, 0.0..=5000.0)
            .logarithmic(true)
            .text("fog half distance m"),
    );
    ui.add(egui::Slider::new(&mut s.exposure, 0.1..=4.0).text("exposure"));
    ui.checkbox(&mut s.shadows, "shadows");
}

fn camera(ui: &mut egui::Ui, v: &mut Viewer, s: &mut UiState) {
    let c = &mut v.camera;
    ui.horizontal(|ui| {
        let mut mode = c.mode;
        ui.radio_value(&mut mode, Mode::Fly, "fly");
        ui.radio_value(&mut mode, Mode::Orbit, "orbit");
        ui.add_enabled_ui(c.path.is_some(), |ui| {
            ui.radio_value(&mut mode, Mode::Path, "path")
        });
        c.set_mode(mode);
    });
    ui.add(
        egui::Slider::new(&mut c.speed, 0.5..=2000.0)
            .logarithmic(true)
            .text("speed m/s"),
    );
    ui.add(egui::Slider::new(&mut c.fov_deg, 10.0..=120.0).text("fov °"));
    if ui.button("orbit the tree in the centre (O)").clicked() {
        s.actions.push(Action::OrbitCentre);
    }
    ui.label("path file");
    ui.text_edit_singleline(&mut s.path_file);
    ui.horizontal(|ui| {
        let label = match c.recording_keys() {
            Some(n) => format!("stop + save ({n} keys)"),
            None => "record (R)".to_string(),
        };
        if ui.button(label).clicked() {
            s.actions.push(Action::ToggleRecording);
        }
        if ui.button("load + play").clicked() {
            s.actions.push(Action::LoadPath);
        }
    });
    if let Some(p) = &c.path {
        ui.label(format!(
            "path: {} keys, {:.1} s, at {:.1} s",
            p.keys.len(),
            p.duration(),
            c.path_time
        ));
    }
    ui.label(RichText::new("WASD/QE fly, right-drag look, wheel speed; left-drag turns an orbit, middle-click orbits a tree; F12 screenshot, F1 panel").small());
}

fn debug(ui: &mut egui::Ui, v: &mut Viewer, s: &mut UiState) {
    for (name, view) in DebugView::ALL {
        ui.radio_value(&mut v.settings.debug, view, format!("colour: {name}"));
    }
    baked_atlases(ui, v, s);
    ui.add(egui::Slider::new(&mut v.settings.render_scale, 0.25..=1.0).text("render scale"));
    ui.checkbox(&mut v.settings.vsync, "vsync");
    ui.checkbox(&mut s.show_stats, "stats overlay");
    ui.separator();
    match v.comparison.running_for() {
        Some(secs) => {
            ui.label(format!("rendering the 16-spp reference… {secs:.0} s"));
        }
        None => {
            if ui
                .button("compare with reference (geometry, 16 spp)")
                .clicked()
            {
                s.actions.push(Action::Compare);
            }
        }
    }
    if let Some(r) = &v.comparison.result {
        ui.label(format!(
            "ꟻLIP mean {:.4} (p95 {:.4}), reference {:.1} s",
            r.flip_mean,
            r.flip_p95,
            r.ms / 1e3
        ));
        ui.checkbox(&mut s.show_heatmap, "overlay the ꟻLIP heat-map");
        ui.add(egui::Slider::new(&mut s.heatmap_opacity, 0.0..=1.0).text("opacity"));
    }
    if ui.button("screenshot (F12)").clicked() {
        s.actions.push(Action::Screenshot);
    }
}

/// One `[lod] chain` entry: `technique:from-to` or `technique:from-` (metres).
#[derive(Debug, Clone, PartialEq)]
pub struct Band {
    /// Technique name.
    pub technique: String,
    /// Start distance.
    pub from: f32,
    /// End distance; `None` = to the horizon.
    pub to: Option<f32>,
}

impl Band {
    /// Parses an entry as written in scene files.
    pub fn parse(s: &str) -> Option<Self> {
        let (technique, range) = s.split_once(':')?;
        let (from, to) = range.split_once('-')?;
        let from: f32 = from.trim().parse().ok()?;
        let to = match to.trim() {
            "" => None,
            t => Some(t.parse::<f32>().ok()?),
        };
        Some(Self {
            technique: technique.trim().to_string(),
            from,
            to,
        })
    }
}

impl std::fmt::Display for Band {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.to {
            Some(to) => write!(f, "{}:{}-{}", self.technique, self.from, to),
            None => write!(f, "{}:{}-", self.technique, self.from),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Band;

    #[test]
    fn bands_round_trip() {
        for s in ["geometry:0-60", "hbt:60-400", "shadermap:3000-"] {
            assert_eq!(Band::parse(s).unwrap().to_string(), s);
        }
        assert_eq!(Band::parse("geometry").map(|b| b.from), None);
        assert_eq!(Band::parse("geometry:a-3"), None);
    }
}
