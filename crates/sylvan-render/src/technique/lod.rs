//! Technique `auto`: the level-of-detail chain — a technique per distance band, each tree drawn
//! by the band its distance from the eye falls in, with a cross-fade across each boundary (the
//! far technique's presence rises from 0 to 1 over ±[`FADE`] of the boundary distance while the
//! near one's falls, so no tree pops). Bands come from the scene's `[lod] chain`, e.g.
//! `["geometry:0-60", "boxtree:60-"]`; without one, [`DEFAULT_CHAIN`].
//!
//! Bands can also be `[[lod.band]]` tables, each with its own parameters
//! (`params = { open_texel_pixels = 3 }`), applied over the scene's `[technique.NAME]` tables
//! and under `--set`.
//!
//! Each band keeps its own instance list, refilled from the frame's culled instances every
//! frame (no allocation), and its technique is built once like a stand-alone one, from the
//! registry.

use super::params::{self, NoParams};
use super::registry::{self, Entry, Kind};
use super::shadermap::field::ForestField;
use super::{
    BandRange, BuildContext, Built, DrawContext, DrawCounts, FieldEnd, FrameInput, Technique,
};
use crate::RenderError;
use crate::instances::{GpuTreeInstance, Instances};
use glam::Vec3;
use sylvan_gpu::Gpu;
use sylvan_scene::{LodBand, Setting};

/// The chain used when a scene has no `[lod] chain`.
pub const DEFAULT_CHAIN: [&str; 2] = ["geometry:0-40", "boxtree:40-"];

/// Half-width of the cross-fade at a band boundary, relative to the boundary distance.
pub const FADE: f32 = 0.1;

/// One band of the chain, parsed.
#[derive(Debug, Clone, PartialEq)]
pub struct Band {
    /// The technique drawing this band (a registry name).
    pub technique: &'static str,
    /// Start distance (metres).
    pub start: f32,
    /// End distance (metres, `f32::INFINITY` for an open end).
    pub end: f32,
    /// The band's own settings (from its `[[lod.band]]` table).
    pub settings: Vec<Setting>,
    /// Where the band was written, for messages (`[lod] chain entry '…'` or `FILE:LINE:COL`).
    pub place: String,
}

/// The registry entry of a chain member, refusing what cannot be a band.
fn member(name: &str, place: &str) -> Result<&'static str, RenderError> {
    let e =
        registry::find(name.trim()).map_err(|e| RenderError::Option(format!("{place}: {e}")))?;
    if !matches!(e.kind, Kind::PerTree | Kind::Field) {
        return Err(RenderError::Option(format!(
            "{place}: '{}' cannot be a band of the chain — use one of: {}",
            e.name,
            chainable().join(", ")
        )));
    }
    Ok(e.name)
}

/// Techniques a chain may use (a field only as its last band).
pub fn chainable() -> Vec<&'static str> {
    registry::REGISTRY
        .iter()
        .filter(|e| matches!(e.kind, Kind::PerTree | Kind::Field))
        .map(|e| e.name)
        .collect()
}

/// Whether `technique` is a forest field (drawn on the terrain, not per tree).
fn is_field(technique: &str) -> bool {
    registry::find(technique).is_ok_and(|e| e.kind == Kind::Field)
}

/// Checks that `bands` are contiguous, start at 0 and end open.
fn check_bands(bands: &[Band]) -> Result<(), RenderError> {
    for (i, b) in bands.iter().enumerate() {
        let bad = |why: String| RenderError::Option(format!("{}: {why}", b.place));
        if !(b.start.is_finite() && b.start >= 0.0 && b.end > b.start) {
            return Err(bad(
                "distances must satisfy 0 ≤ START < END — fix the band's distances".into(),
            ));
        }
        match i.checked_sub(1).map(|p| &bands[p]) {
            Some(prev) if prev.end != b.start => {
                return Err(bad(format!(
                    "the previous band ends at {}, this one starts at {} — make the bands contiguous",
                    prev.end, b.start
                )));
            }
            None if b.start != 0.0 => {
                return Err(bad("the first band must start at 0 — start it at 0".into()));
            }
            _ => {}
        }
    }
    if let Some(i) = bands.iter().position(|b| is_field(b.technique)) {
        let b = &bands[i];
        if i + 1 != bands.len() {
            return Err(RenderError::Option(format!(
                "{}: a forest field ('{}') draws everything beyond its start, so it can only be the last band — move it to the end",
                b.place, b.technique
            )));
        }
        if i == 0 {
            return Err(RenderError::Option(format!(
                "{}: a forest field needs a band of trees before it — start the chain with a per-tree technique, e.g. \"zfield:0-{}\"",
                b.place,
                if b.start > 0.0 { b.start } else { 1500.0 }
            )));
        }
    }
    match bands.last() {
        Some(b) if b.end.is_finite() => Err(RenderError::Option(format!(
            "{}: the last band must be open-ended so far trees are drawn — leave its end out",
            b.place
        ))),
        None => Err(RenderError::Option(
            "the LOD chain has no bands — give [lod] chain or [[lod.band]] tables".into(),
        )),
        _ => Ok(()),
    }
}

/// Bands from `[[lod.band]]` tables.
pub fn from_tables(tables: &[LodBand]) -> Result<Vec<Band>, RenderError> {
    let bands = tables
        .iter()
        .map(|t| {
            let place = format!("{} [[lod.band]] {}", t.origin, t.technique);
            Ok(Band {
                technique: member(&t.technique, &place)?,
                start: t.from,
                end: t.to,
                settings: t.params.clone(),
                place,
            })
        })
        .collect::<Result<Vec<_>, RenderError>>()?;
    check_bands(&bands)?;
    Ok(bands)
}

/// Parses `[lod] chain` entries (`"name:start-end"`, end may be empty): bands must be
/// contiguous, start at 0, end open, and name registered techniques other than `auto`.
pub fn parse_chain(entries: &[String]) -> Result<Vec<Band>, RenderError> {
    let default: Vec<String> = DEFAULT_CHAIN.iter().map(|s| s.to_string()).collect();
    let entries = if entries.is_empty() {
        &default
    } else {
        entries
    };
    let mut bands: Vec<Band> = Vec::with_capacity(entries.len());
    for e in entries {
        let place = format!("[lod] chain entry '{e}'");
        let bad = |why: &str| {
            RenderError::Option(format!(
                "{place}: {why} — write entries as \"technique:START-END\", e.g. \"boxtree:60-\""
            ))
        };
        let (name, range) = e.split_once(':').ok_or_else(|| bad("no ':'"))?;
        let technique = member(name, &place)?;
        let (a, b) = range
            .split_once('-')
            .ok_or_else(|| bad("no '-' between the distances"))?;
        let start: f32 = a
            .trim()
            .parse()
            .map_err(|_| bad("the start is not a number"))?;
        let end: f32 = if b.trim().is_empty() {
            f32::INFINITY
        } else {
            b.trim()
                .parse()
                .map_err(|_| bad("the end is not a number"))?
        };
        bands.push(Band {
            technique,
            start,
            end,
            settings: Vec::new(),
            place,
        });
    }
    check_bands(&bands)?;
    Ok(bands)
}

/// Band `i`'s distance range and fades: ±[`FADE`] of each inner boundary, except before a
/// forest field, where the band stops at the field's start `s_max`; in a chain that ends in a
/// field every band's trees end by [`FieldEnd`] (BN12 §7: over `[0.8, 1]` of each tree's own
/// end, `s_max` or where the tree is `handover_px` tall; or stopping there when its technique
/// fades itself, `self_fading`, [`Technique::fades_to_field`]).
pub fn band_range(bands: &[Band], i: usize, self_fading: bool, handover_px: f32) -> BandRange {
    let b = &bands[i];
    let before_field = bands.get(i + 1).is_some_and(|n| is_field(n.technique));
    let field = bands.last().filter(|l| is_field(l.technique));
    BandRange {
        start: b.start,
        end: b.end,
        end_fade: before_field.then_some([b.end, b.end]),
        field_end: field.map(|f| FieldEnd {
            s_max: f.start,
            handover_px,
            self_fading,
        }),
    }
}

/// Presence of band `i` for a tree at `distance`: 1 inside the band, cross-fading over ±FADE
/// of each inner boundary; the presences of all bands sum to 1. A forest field lists no
/// trees (presence 0); the trees before it fade over `[0.8, 1]` of its start, the field
/// taking the rest on the terrain.
pub fn presence(bands: &[Band], i: usize, distance: f32) -> f32 {
    if is_field(bands[i].technique) {
        return 0.0;
    }
    band_range(bands, i, false, 0.0).tree_presence(distance, 0.0, 0.0)
}

/// Whether every band of `scene`'s chain is GPU-driven (then the chain is).
pub(crate) fn gpu_driven(scene: &sylvan_scene::Scene) -> Result<bool, RenderError> {
    Ok(bands(scene)?
        .iter()
        .all(|b| registry::find(b.technique).is_ok_and(|e| e.gpu_driven)))
}

/// The scene's bands: its `[[lod.band]]` tables, else its `[lod] chain` (or the default).
pub(crate) fn bands(scene: &sylvan_scene::Scene) -> Result<Vec<Band>, RenderError> {
    if scene.lod_bands.is_empty() {
        parse_chain(&scene.lod_chain)
    } else {
        from_tables(&scene.lod_bands)
    }
}

/// The techniques `scene`'s chain draws, each with its settings: the scene's
/// `[technique.NAME]` tables, then the band's own, then `overrides` (the command line's).
pub(crate) fn members(
    scene: &sylvan_scene::Scene,
    overrides: &[Setting],
) -> Result<Vec<(&'static str, Vec<Setting>)>, RenderError> {
    Ok(bands(scene)?
        .into_iter()
        .map(|band| {
            let settings = scene
                .technique_params
                .iter()
                .chain(&band.settings)
                .chain(overrides)
                .cloned()
                .collect();
            (band.technique, settings)
        })
        .collect())
}

/// Fills each band's instance list from the frame's (`ranges`: each band's, `None` for a
/// field, which lists no trees).
pub(crate) fn split(
    gpu: &sylvan_gpu::Gpu,
    ranges: &[Option<BandRange>],
    lists: &mut [Instances],
    master: &Instances,
    view: (Vec3, f32),
    tops: &[f32],
) {
    let (eye, pixels_per_metre) = view;
    for (range, list) in ranges.iter().zip(lists.iter_mut()) {
        let k = range
            .and_then(|r| r.field_end)
            .map_or(0.0, |f| f.per_height(pixels_per_metre));
        list.fill_from(gpu, master, |r: &GpuTreeInstance, species| {
            let d = Vec3::new(r.base_scale[0], r.base_scale[1], r.base_scale[2]).distance(eye);
            let height = tops.get(species).copied().unwrap_or(0.0) * r.base_scale[3];
            range.map_or(0.0, |b| b.tree_presence(d, height, k))
        });
    }
}

/// The registry entry of `auto`.
pub const ENTRY: Entry = Entry {
    name: "auto",
    kind: Kind::Chain,
    summary: "the LOD chain: a technique per distance band ([lod] chain or [[lod.band]]), cross-faded",
    debug_color: [1.0, 1.0, 1.0],
    // When every band's technique is (decided per scene: `gpu_driven`).
    gpu_driven: true,
    schema: params::schema::<NoParams, NoParams>,
    check: |s| params::resolve::<NoParams, NoParams>("auto", s).map(|_| ()),
    build: |cx| Chain::build(cx),
    bake: None,
    casts_translucent: None,
    shaders: Vec::new,
};

/// The `auto` chain: a technique and an instance list per band.
pub struct Chain {
    /// Each band's range and fades as built (`None`: the forest field, listing no trees).
    ranges: Vec<Option<BandRange>>,
    /// Each species' model top (plant units): a tree's height is it times the tree's scale.
    tops: Vec<f32>,
    /// The forest field of the last band, when the chain ends in one.
    field: Option<ForestField>,
    techniques: Vec<Box<dyn Technique>>,
    lists: Vec<Instances>,
    /// Each band's technique's own list windows (those of its `list_requests`, fixed at
    /// build), so a frame does not rebuild the requests.
    request_windows: Vec<Vec<[f32; 4]>>,
    /// Where each band's lists start in `DrawContext::culled` (a technique may ask for
    /// several), and their end.
    firsts: Vec<usize>,
}

impl Chain {
    /// Builds each band's technique with its settings: the scene's `[technique.NAME]` tables,
    /// then the band's own, then the command line's.
    fn build(cx: &mut BuildContext<'_>) -> Result<Built, RenderError> {
        params::resolve::<NoParams, NoParams>("auto", &cx.settings_for("auto"))?;
        let bands = bands(cx.scene)?;
        let settings_of: Vec<Vec<Setting>> = members(cx.scene, cx.overrides)?
            .into_iter()
            .map(|(_, s)| s)
            .collect();
        let n = bands.len();
        let mut techniques: Vec<Option<Box<dyn Technique>>> = (0..n).map(|_| None).collect();
        let mut ranges: Vec<Option<BandRange>> = vec![None; n];
        let mut reports = Vec::new();
        // The field first (it can only be last): the bands before it are built with it.
        let mut field = None;
        let field_band = bands.iter().position(|b| is_field(b.technique));
        let order = field_band
            .into_iter()
            .chain((0..n).filter(|&i| Some(i) != field_band));
        for i in order {
            let band = &bands[i];
            let settings = &settings_of[i];
            let handover_px = field.as_ref().map_or(0.0, |f: &ForestField| f.handover_px);
            let range = match Some(i) == field_band {
                true => BandRange::new(band.start, band.end),
                false => band_range(&bands, i, false, handover_px),
            };
            let mut sub = BuildContext {
                gpu: cx.gpu,
                frame: cx.frame,
                scene: cx.scene,
                plants: cx.plants,
                population: cx.population,
                band: range,
                field: field.as_ref(),
                settings,
                overrides: cx.overrides,
                policy: cx.policy,
                progress: &mut *cx.progress,
            };
            let entry = registry::find(band.technique)?;
            let built = (entry.build)(&mut sub)?;
            if Some(i) == field_band {
                field = built.technique.field().cloned();
            } else {
                let own = built.technique.fades_to_field();
                ranges[i] = Some(band_range(&bands, i, own, handover_px));
            }
            techniques[i] = Some(built.technique);
            reports.extend(built.reports);
        }
        let techniques: Vec<Box<dyn Technique>> = techniques.into_iter().flatten().collect();
        let lists = ranges
            .iter()
            .map(|r| {
                // A field lists no trees.
                let capacity = if r.is_some() {
                    cx.population.capacity()
                } else {
                    1
                };
                Instances::derived(cx.gpu, capacity, cx.population.species_count())
            })
            .collect();
        let request_windows: Vec<Vec<[f32; 4]>> = techniques
            .iter()
            .map(|t| t.list_requests().iter().map(|r| r.window).collect())
            .collect();
        let mut firsts = vec![0];
        for w in &request_windows {
            firsts.push(firsts.last().copied().unwrap_or(0) + w.len());
        }
        let tops = cx.plants.iter().map(|p| p.bbox_max[1]).collect();
        Ok(Built {
            technique: Box::new(Self {
                ranges,
                tops,
                field,
                techniques,
                lists,
                request_windows,
                firsts,
            }),
            reports,
        })
    }
}

impl Chain {
    /// Band `i`'s presence window ([`BandRange::window`]; bands start at 0 and end open, so
    /// the chain's two ends are open).
    fn band_window(&self, i: usize) -> [f32; 4] {
        self.ranges[i].map_or([1e30; 4], |r| r.window())
    }
}

impl Technique for Chain {
    fn name(&self) -> &'static str {
        ENTRY.name
    }

    fn prepare_frame(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        input: &FrameInput<'_>,
    ) -> Result<(), RenderError> {
        split(
            gpu,
            &self.ranges,
            &mut self.lists,
            input.instances,
            (input.eye, input.pixels_per_metre),
            &self.tops,
        );
        for (i, (t, list)) in self.techniques.iter_mut().zip(&self.lists).enumerate() {
            let sub = FrameInput {
                instances: list,
                culled: input
                    .culled
                    .get(self.firsts[i]..self.firsts[i + 1])
                    .unwrap_or(&[]),
                ..*input
            };
            t.prepare_frame(gpu, encoder, &sub)?;
        }
        Ok(())
    }

    fn finish_frame(&mut self, gpu: &Gpu) -> Result<bool, RenderError> {
        let mut again = false;
        for t in &mut self.techniques {
            again |= t.finish_frame(gpu)?;
        }
        Ok(again)
    }

    fn own_triangles(&self, pass: usize) -> u64 {
        self.techniques.iter().map(|t| t.own_triangles(pass)).sum()
    }

    fn draw(&self, pass: &mut wgpu::RenderPass<'_>, ctx: &DrawContext<'_>) -> DrawCounts {
        let mut counts = DrawCounts::default();
        for (i, (t, list)) in self.techniques.iter().zip(&self.lists).enumerate() {
            let sub = DrawContext {
                pass: ctx.pass,
                frame_bind: ctx.frame_bind,
                instances: list,
                ranges: &list.ranges[ctx.pass],
                culled: ctx
                    .culled
                    .get(self.firsts[i]..self.firsts[i + 1])
                    .unwrap_or(&[]),
            };
            counts += t.draw(pass, &sub);
        }
        counts
    }

    /// One request per band: its technique's lists, presence by the band's cross-fades.
    fn list_requests(&self) -> Vec<crate::world::ListRequest> {
        self.techniques
            .iter()
            .enumerate()
            .flat_map(|(i, t)| {
                let window = self.band_window(i);
                let field_end = self.ranges[i].and_then(|r| r.field_end);
                t.list_requests().into_iter().map(move |mut r| {
                    r.window = crate::world::intersect_windows(r.window, window);
                    r.field_end = field_end;
                    r
                })
            })
            .collect()
    }

    /// Each band's technique's windows of this frame (its own, or those of its requests),
    /// inside the band's.
    fn list_windows(&self, pixels_per_metre: f32) -> Option<Vec<[f32; 4]>> {
        if self
            .techniques
            .iter()
            .all(|t| t.list_windows(pixels_per_metre).is_none())
        {
            return None;
        }
        let mut out = Vec::new();
        for (i, t) in self.techniques.iter().enumerate() {
            let band = self.band_window(i);
            let own = t
                .list_windows(pixels_per_metre)
                .unwrap_or_else(|| self.request_windows[i].clone());
            out.extend(
                own.into_iter()
                    .map(|w| crate::world::intersect_windows(w, band)),
            );
        }
        Some(out)
    }

    fn bytes(&self) -> u64 {
        self.techniques.iter().map(|t| t.bytes()).sum::<u64>()
            + self.lists.iter().map(|l| l.buffer().size()).sum::<u64>()
    }

    fn trees_drawn(&self, _: &Instances) -> Vec<(&'static str, u32)> {
        let mut out: Vec<(&'static str, u32)> = Vec::new();
        for (t, list) in self.techniques.iter().zip(&self.lists) {
            for (name, n) in t.trees_drawn(list) {
                match out.iter_mut().find(|(m, _)| *m == name) {
                    Some(e) => e.1 += n,
                    None => out.push((name, n)),
                }
            }
        }
        out
    }

    /// Each band technique's statistics, bands of the same technique summed.
    fn stats_by_technique(&self) -> Vec<(&'static str, Vec<(&'static str, f64)>)> {
        let mut out: Vec<(&'static str, Vec<(&'static str, f64)>)> = Vec::new();
        for t in &self.techniques {
            for (name, stats) in t.stats_by_technique() {
                match out.iter_mut().find(|(m, _)| *m == name) {
                    Some((_, acc)) => {
                        for (k, v) in stats {
                            match acc.iter_mut().find(|(a, _)| *a == k) {
                                Some(e) => e.1 += v,
                                None => acc.push((k, v)),
                            }
                        }
                    }
                    None => out.push((name, stats)),
                }
            }
        }
        out
    }

    /// The last band's forest field, which the terrain is shaded with.
    fn field(&self) -> Option<&super::shadermap::field::ForestField> {
        self.field.as_ref()
    }

    fn atlas_preview(&self) -> Option<&image::RgbaImage> {
        self.techniques.iter().find_map(|t| t.atlas_preview())
    }

    fn reallocations(&self) -> u32 {
        self.techniques.iter().map(|t| t.reallocations()).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chain(e: &[&str]) -> Result<Vec<Band>, RenderError> {
        parse_chain(&e.iter().map(|s| s.to_string()).collect::<Vec<_>>())
    }

    #[test]
    fn parses_and_rejects() {
        let b = chain(&["geometry:0-60", "boxtree:60-"]).unwrap();
        assert_eq!(b.len(), 2);
        assert_eq!(b[1].end, f32::INFINITY);
        assert_eq!(chain(&[]).unwrap().len(), DEFAULT_CHAIN.len());
        for bad in [
            &["geometry:0-60", "boxtree:70-"][..],
            &["geometry:10-"],
            &["geometry:0-60"],
            &["geometry 0-60"],
            &["shadermap:0-"],
            &["nope:0-"],
            &["geometry:0-x"],
        ] {
            let e = chain(bad).unwrap_err().to_string();
            assert!(e.contains('—'), "{e}");
        }
    }

    #[test]
    fn a_field_is_only_the_last_band() {
        let b = chain(&["zfield:0-500", "shadermap:500-"]).unwrap();
        assert_eq!(b[1].technique, "shadermap");
        for bad in [
            &["shadermap:0-500", "zfield:500-"][..],
            &["zfield:0-500", "shadermap:500-900", "shadermap:900-"],
            &["shadermap:0-"],
        ] {
            let e = chain(bad).unwrap_err().to_string();
            assert!(e.contains('—') && e.contains("field"), "{bad:?}: {e}");
        }
        // The trees before the field fade over [0.8, 1] of its start (BN12 §7), unless their
        // technique fades itself (then they stop at the start); the field lists no trees.
        let fading = band_range(&b, 0, false, 0.0);
        assert_eq!(fading.tree_presence(399.0, 10.0, 0.0), 1.0);
        assert!((fading.tree_presence(450.0, 10.0, 0.0) - 0.5).abs() < 1e-6);
        assert_eq!(fading.tree_presence(500.0, 10.0, 0.0), 0.0);
        let own = band_range(&b, 0, true, 0.0);
        assert_eq!(own.tree_presence(499.0, 10.0, 0.0), 1.0);
        assert_eq!(own.tree_presence(500.0, 10.0, 0.0), 0.0);
        assert_eq!(presence(&b, 1, 2000.0), 0.0);
    }

    #[test]
    fn each_tree_ends_where_it_is_handover_px_tall() {
        // BN12 §4's 3-px rule: at 100 px per metre and 5 px, a tree ends at 20 × its height
        // (a 10 m tree at 200 m, fading over [160, 200] m), never beyond the field's start;
        // in every band of the chain, not only the last before the field.
        let b = chain(&["geometry:0-100", "zfield:100-500", "shadermap:500-"]).unwrap();
        let last = band_range(&b, 1, false, 5.0);
        let k = last.field_end.unwrap().per_height(100.0);
        assert_eq!(k, 20.0);
        assert_eq!(last.tree_presence(159.0, 10.0, k), 1.0);
        assert!((last.tree_presence(180.0, 10.0, k) - 0.5).abs() < 1e-6);
        assert_eq!(last.tree_presence(200.0, 10.0, k), 0.0);
        assert!((last.tree_presence(450.0, 30.0, k) - 0.5).abs() < 1e-6);
        // Self-fading (zfield fades its own opacity): presence stops at the tree's end.
        let own = band_range(&b, 1, true, 5.0);
        assert_eq!(own.tree_presence(199.0, 10.0, k), 1.0);
        assert_eq!(own.tree_presence(200.0, 10.0, k), 0.0);
        let first = band_range(&b, 0, false, 5.0);
        assert!((first.tree_presence(36.0, 2.0, k) - 0.5).abs() < 1e-6);
        assert_eq!(first.tree_presence(36.0, 10.0, k), 1.0);
        // Without the rule (0 px) every tree ends at s_max.
        let off = band_range(&b, 1, false, 0.0);
        let k0 = off.field_end.unwrap().per_height(100.0);
        assert_eq!(off.tree_presence(300.0, 1.0, k0), 1.0);
        // A chain without a field has no per-tree end.
        let plain = chain(&["geometry:0-100", "zfield:100-"]).unwrap();
        assert_eq!(band_range(&plain, 1, false, 5.0).field_end, None);
    }

    #[test]
    fn presences_sum_to_one() {
        let b = chain(&["geometry:0-50", "boxtree:50-200", "geometry:200-"]).unwrap();
        for d in (0..3000).map(|i| i as f32 * 0.1) {
            let s: f32 = (0..b.len()).map(|i| presence(&b, i, d)).sum();
            assert!((s - 1.0).abs() < 1e-5, "{d}: {s}");
        }
        assert_eq!(presence(&b, 0, 10.0), 1.0);
        assert_eq!(presence(&b, 1, 100.0), 1.0);
    }
}
