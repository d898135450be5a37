//! The TOML scene file (DESIGN.md, "Scene file"): raw `serde` tables with `deny_unknown_fields`
//! and spans, then validation into a [`Scene`]. Every error is one line with the file, line and
//! column of the offending value.

use crate::error::{ErrorKind, Location, SceneError};
use crate::heightmap::{Purpose, read_gray};
use crate::params::{LodBand, Origin, ParamValue, Setting};
use crate::placement::{
    MAX_TREES, Placement, PlacementError, PlacementMethod, SeededForest, place_trees_within,
};
use crate::species::{Growth, RawSpecies, build_species};
use crate::terrain::{MAX_TERRAIN_SIZE_M, ProceduralTerrain};
use crate::types::{Camera, Fog, Scene, Sky, Sun, Terrain, TreeInstance, World};
use glam::Vec3;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use toml::Spanned;

pub(crate) type Span = std::ops::Range<usize>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    terrain: Option<Spanned<RawTerrain>>,
    #[serde(default)]
    species: Vec<Spanned<RawSpecies>>,
    sun: Option<RawSun>,
    sky: Option<RawSky>,
    fog: Option<RawFog>,
    camera: Option<RawCamera>,
    lod: Option<RawLod>,
    placement: Option<RawPlacement>,
    world: Option<RawWorld>,
    /// `[technique.NAME]` tables: every key with its value's span.
    technique: Option<BTreeMap<String, RawParams>>,
}

/// A parameter table: key → value (with where the value is).
type RawParams = BTreeMap<String, Spanned<toml::Value>>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTerrain {
    procedural: Option<Spanned<RawProcedural>>,
    heightmap: Option<Spanned<String>>,
    size_m: Option<Spanned<Size2>>,
    height_m: Option<Spanned<Nums<2>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawProcedural {
    seed: Option<u64>,
    size_m: Option<Spanned<Size2>>,
    relief_m: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSun {
    azimuth_deg: Option<Spanned<f32>>,
    elevation_deg: Option<Spanned<f32>>,
    color: Option<Spanned<Nums<3>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSky {
    zenith: Option<Spanned<Nums<3>>>,
    horizon: Option<Spanned<Nums<3>>>,
    ground: Option<Spanned<Nums<3>>>,
    ground_occlusion: Option<bool>,
    ground_contrast: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFog {
    half_distance_m: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    position: Option<Spanned<Nums<3>>>,
    look_at: Option<Spanned<Nums<3>>>,
    fov_deg: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLod {
    #[serde(default)]
    chain: Vec<String>,
    #[serde(default)]
    band: Vec<Spanned<RawBand>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBand {
    technique: Spanned<String>,
    from: Spanned<f32>,
    to: Option<Spanned<f32>>,
    #[serde(default)]
    params: RawParams,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWorld {
    tile_m: Option<Spanned<f32>>,
    tree_distance_m: Option<Spanned<f32>>,
    prefetch_m: Option<Spanned<f32>>,
    cache_mib: Option<Spanned<i64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPlacement {
    seed: Option<u64>,
    method: Option<Spanned<String>>,
}

/// Highest and lowest terrain elevation accepted, metres (Everest and the Mariana Trench are
/// ~11 km from sea level): heightmap `height_m` ranges and GeoTIFF samples outside are refused.
pub const MAX_ELEVATION_M: f32 = 20_000.0;
/// Most `[[species]]` entries in a scene, checked before any plant or placement is built (each
/// species holds its own plant, ~2 MB for a preset).
pub const MAX_SPECIES: usize = 64;
/// Largest linear-RGB component accepted for colours (sun, sky).
pub const MAX_COLOR: f32 = 1_000.0;

/// Exactly `N` numbers (`[a, b]`, `[r, g, b]`): a longer or shorter array is a syntax error at
/// the array (serde's fixed-size arrays would silently ignore extra elements).
#[derive(Clone, Copy)]
pub(crate) struct Nums<const N: usize>(pub [f32; N]);

impl<'de, const N: usize> Deserialize<'de> for Nums<N> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<const N: usize>;
        impl<'de, const N: usize> serde::de::Visitor<'de> for V<N> {
            type Value = Nums<N>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                write!(f, "an array of exactly {N} numbers")
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut s: A,
            ) -> Result<Nums<N>, A::Error> {
                let mut out = [0.0; N];
                for (i, slot) in out.iter_mut().enumerate() {
                    *slot = s
                        .next_element()?
                        .ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
                }
                let mut extra = N;
                while s.next_element::<toml::Value>()?.is_some() {
                    extra += 1;
                }
                if extra > N {
                    return Err(serde::de::Error::invalid_length(extra, &self));
                }
                Ok(Nums(out))
            }
        }
        d.deserialize_seq(V::<N>)
    }
}

/// An extent: one number (square) or `[x, z]`.
struct Size2([f32; 2]);

impl<'de> Deserialize<'de> for Size2 {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Size2;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a size in metres: a number or [x, z]")
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Size2, E> {
                Ok(Size2([v as f32; 2]))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Size2, E> {
                Ok(Size2([v as f32; 2]))
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Size2, E> {
                Ok(Size2([v as f32; 2]))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut s: A) -> Result<Size2, A::Error> {
                let x: f32 = s
                    .next_element()?
                    .ok_or_else(|| serde::de::Error::invalid_length(0, &self))?;
                let z: f32 = s
                    .next_element()?
                    .ok_or_else(|| serde::de::Error::invalid_length(1, &self))?;
                if s.next_element::<f32>()?.is_some() {
                    return Err(serde::de::Error::invalid_length(3, &self));
                }
                Ok(Size2([x, z]))
            }
        }
        d.deserialize_any(V)
    }
}

/// Parsing context: the file's text and path, for locating errors and resolving paths.
pub(crate) struct Ctx<'a> {
    text: &'a str,
    path: &'a Path,
}

impl Ctx<'_> {
    pub(crate) fn loc(&self, span: &Span) -> Location {
        Location::at_offset(self.path, self.text, span.start)
    }

    pub(crate) fn invalid(
        &self,
        span: &Span,
        what: impl Into<String>,
        fix: impl Into<String>,
    ) -> SceneError {
        SceneError::new(ErrorKind::InvalidValue, self.loc(span), what, fix)
    }

    pub(crate) fn resolve(&self, file: &str) -> PathBuf {
        let base = self.path.parent().unwrap_or(Path::new(""));
        base.join(file)
    }

    pub(crate) fn non_empty<'s>(
        &self,
        s: &'s Spanned<String>,
        key: &str,
    ) -> Result<&'s str, SceneError> {
        let v = s.get_ref().trim();
        if v.is_empty() {
            return Err(self.invalid(
                &s.span(),
                format!("`{key}` is empty"),
                format!("give a value for `{key}`"),
            ));
        }
        Ok(v)
    }
}

/// Turn a `toml` error into a located one-line [`SceneError`].
pub(crate) fn toml_error(e: &toml::de::Error, text: &str, path: &Path) -> SceneError {
    let loc = match e.span() {
        Some(span) => Location::at_offset(path, text, span.start),
        None => Location::at(path, 1, 1),
    };
    let msg = e.message().trim();
    if let Some(rest) = msg.strip_prefix("unknown field ") {
        let (field, expected) = rest.split_once(", ").unwrap_or((rest, ""));
        let fix = if expected.is_empty() {
            "remove it or check its spelling".to_string()
        } else {
            format!("remove it or check its spelling ({expected})")
        };
        return SceneError::new(
            ErrorKind::UnknownKey,
            loc,
            format!("unknown key {field}"),
            fix,
        );
    }
    let fix = if msg.starts_with("missing field") {
        "add the key (see DESIGN.md, \"Scene file\")"
    } else if msg.starts_with("invalid ") {
        "give the value the expected type (see DESIGN.md, \"Scene file\")"
    } else {
        "fix the TOML syntax"
    };
    SceneError::new(ErrorKind::Syntax, loc, msg, fix)
}

/// Parse and build a scene from `text`, read from `path` (used in messages and to resolve
/// relative paths), placing at most `tree_limit` trees at load (capped by [`MAX_TREES`]).
pub(crate) fn parse_scene(text: &str, path: &Path, tree_limit: usize) -> Result<Scene, SceneError> {
    let raw: RawScene = toml::from_str(text).map_err(|e| toml_error(&e, text, path))?;
    let cx = Ctx { text, path };
    if raw.species.len() > MAX_SPECIES {
        // Point at the first entry past the limit.
        let at = text
            .match_indices("[[species]]")
            .nth(MAX_SPECIES)
            .map_or(0, |(i, _)| i);
        return Err(SceneError::new(
            ErrorKind::Limit,
            cx.loc(&(at..at)),
            format!(
                "{} [[species]] entries, more than the limit of {MAX_SPECIES}",
                raw.species.len()
            ),
            "merge species that share a plant (use a positions CSV or density_map per stand)",
        ));
    }
    let terrain = build_terrain(&cx, raw.terrain)?;
    let placement = build_placement(&cx, raw.placement)?;
    let mut species = Vec::with_capacity(raw.species.len());
    let mut layouts = Vec::new();
    let mut layout_spans = Vec::new();
    let mut fixed: Vec<TreeInstance> = Vec::new();
    for (i, s) in raw.species.into_iter().enumerate() {
        let (s, growth) = build_species(&cx, i, s, &terrain, placement.seed)?;
        match growth {
            Growth::Density(layout, span) => {
                layouts.push(layout);
                layout_spans.push(span);
            }
            Growth::Fixed(trees) => fixed.extend(trees),
        }
        species.push(s);
    }
    for (i, t) in fixed.iter_mut().enumerate() {
        t.seed = i as u32;
    }
    let placed = match placement.method {
        // Tiled and Wang worlds are produced tile by tile by the renderer, never all at once here.
        PlacementMethod::Tiled | PlacementMethod::Wang => SeededForest::with_method(
            terrain.size,
            &layouts,
            placement.seed,
            placement.method,
            &fixed,
        )
        .and_then(|forest| {
            let limit = tree_limit.min(MAX_TREES);
            if fixed.len() > limit {
                return Err(PlacementError::TooManyTrees {
                    estimated: fixed.len() as f64,
                    limit: limit as f64,
                });
            }
            Ok((fixed, forest.map(Arc::new)))
        }),
        PlacementMethod::Poisson => {
            place_trees_within(&terrain, &layouts, &placement, &fixed, tree_limit)
                .map(|p| (p.trees, None))
        }
    };
    let (trees, seeded) = match placed {
        Ok(p) => p,
        Err(e) => {
            // Point at the species contributing the most trees.
            let area = terrain.size[0] * terrain.size[1] * 1e-4;
            let worst = (0..layouts.len())
                .max_by(|&a, &b| {
                    let d = |i: usize| layouts[i].density.mean_per_ha() * area;
                    d(a).total_cmp(&d(b))
                })
                .map_or(0..0, |i| layout_spans[i].clone());
            let fix = match e {
                PlacementError::TooManyTrees { .. } => {
                    "lower density_per_ha or the terrain's size_m"
                }
                PlacementError::TooManyCandidates { .. } => {
                    "use [placement] method = \"tiled\" or \"wang\", or lower the peak density"
                }
            };
            return Err(SceneError::new(
                ErrorKind::Limit,
                cx.loc(&worst),
                e.to_string(),
                fix,
            ));
        }
    };
    let camera = build_camera(&cx, raw.camera, &terrain)?;
    let technique_params = match &raw.technique {
        Some(tables) => tables
            .iter()
            .map(|(name, table)| settings(&cx, name, table))
            .collect::<Result<Vec<_>, _>>()?
            .concat(),
        None => Vec::new(),
    };
    let (lod_chain, lod_bands) = build_lod(&cx, raw.lod)?;
    Ok(Scene {
        sun: build_sun(&cx, raw.sun)?,
        sky: build_sky(&cx, raw.sky)?,
        fog: build_fog(&cx, raw.fog)?,
        camera,
        terrain,
        species,
        trees,
        seeded,
        world: build_world(&cx, raw.world)?,
        lod_chain,
        lod_bands,
        technique_params,
        source: Some(path.to_path_buf()),
    })
}

/// The settings of one parameter table for technique `name` (keys and values are checked
/// against the technique's schema by the renderer, which knows the techniques).
fn settings(cx: &Ctx, name: &str, table: &RawParams) -> Result<Vec<Setting>, SceneError> {
    table
        .iter()
        .map(|(key, v)| {
            let value = ParamValue::from_toml(v.get_ref()).map_err(|why| {
                cx.invalid(
                    &v.span(),
                    format!("[technique.{name}] {key}: {why}"),
                    "give a number, a boolean, a string or an array",
                )
            })?;
            Ok(Setting {
                technique: name.to_string(),
                key: key.clone(),
                value,
                origin: Origin::File(cx.loc(&v.span())),
            })
        })
        .collect()
}

/// `[lod] chain = [...]` (strings, parsed by the renderer) or `[[lod.band]]` tables.
fn build_lod(cx: &Ctx, raw: Option<RawLod>) -> Result<(Vec<String>, Vec<LodBand>), SceneError> {
    let Some(raw) = raw else {
        return Ok((Vec::new(), Vec::new()));
    };
    if let (false, Some(b)) = (raw.chain.is_empty(), raw.band.first()) {
        return Err(cx.invalid(
            &b.span(),
            "[lod] has both `chain` and `[[lod.band]]` tables",
            "keep one of them",
        ));
    }
    let mut bands = Vec::with_capacity(raw.band.len());
    for b in &raw.band {
        let span = b.span();
        let b = b.get_ref();
        let technique = cx.non_empty(&b.technique, "technique")?.to_string();
        let from = *b.from.get_ref();
        let to = b.to.as_ref().map_or(f32::INFINITY, |t| *t.get_ref());
        if !(from.is_finite() && from >= 0.0 && to > from) {
            return Err(cx.invalid(
                &b.from.span(),
                format!("[[lod.band]] {technique}: from = {from}, to = {to}"),
                "give 0 ≤ from < to (leave `to` out for an open end)",
            ));
        }
        bands.push(LodBand {
            params: settings(cx, &technique, &b.params)?,
            technique,
            from,
            to,
            origin: Origin::File(cx.loc(&span)),
        });
    }
    Ok((raw.chain, bands))
}

fn check_size(cx: &Ctx, s: &Spanned<Size2>) -> Result<[f32; 2], SceneError> {
    let v = s.get_ref().0;
    if v.iter()
        .any(|&x| !x.is_finite() || x <= 0.0 || x > MAX_TERRAIN_SIZE_M)
    {
        return Err(cx.invalid(
            &s.span(),
            format!("size_m = [{}, {}] is out of range", v[0], v[1]),
            format!("give metres in (0, {MAX_TERRAIN_SIZE_M}]"),
        ));
    }
    Ok(v)
}

fn build_terrain(cx: &Ctx, raw: Option<Spanned<RawTerrain>>) -> Result<Terrain, SceneError> {
    let default = ProceduralTerrain {
        seed: 1,
        size_m: [2000.0; 2],
        relief_m: 150.0,
    };
    let Some(raw) = raw else {
        return Ok(default.generate());
    };
    let span = raw.span();
    let t = raw.into_inner();
    match (t.procedural, t.heightmap) {
        (Some(_), Some(h)) => Err(cx.invalid(
            &h.span(),
            "terrain has both `procedural` and `heightmap`",
            "keep one of them",
        )),
        (proc_, None) => {
            if let Some(h) = &t.height_m {
                return Err(cx.invalid(
                    &h.span(),
                    "height_m applies to heightmaps",
                    "use relief_m inside procedural = { … }",
                ));
            }
            let p = proc_.map(|p| p.into_inner());
            let mut out = default;
            if let Some(p) = &p {
                out.seed = p.seed.unwrap_or(default.seed);
                if let Some(r) = &p.relief_m {
                    let v = *r.get_ref();
                    if !v.is_finite() || !(0.0..=100_000.0).contains(&v) {
                        return Err(cx.invalid(
                            &r.span(),
                            format!("relief_m = {v} is out of range"),
                            "give metres ≥ 0",
                        ));
                    }
                    out.relief_m = v;
                }
            }
            match (p.as_ref().and_then(|p| p.size_m.as_ref()), &t.size_m) {
                (Some(_), Some(outer)) => {
                    return Err(cx.invalid(
                        &outer.span(),
                        "size_m given twice",
                        "keep the one inside procedural = { … }",
                    ));
                }
                (Some(s), None) | (None, Some(s)) => out.size_m = check_size(cx, s)?,
                (None, None) => {}
            }
            Ok(out.generate())
        }
        (None, Some(h)) => {
            let Some(size) = &t.size_m else {
                return Err(cx.invalid(
                    &span,
                    "a heightmap terrain needs its extent",
                    "add size_m = [x, z] in metres",
                ));
            };
            let size = check_size(cx, size)?;
            let height_m = match &t.height_m {
                None => None,
                Some(r) => {
                    let [lo, hi] = r.get_ref().0;
                    let ok = |v: f32| v.is_finite() && v.abs() <= MAX_ELEVATION_M;
                    if !(ok(lo) && ok(hi)) || lo > hi {
                        return Err(cx.invalid(
                            &r.span(),
                            format!("height_m = [{}, {}] is not a valid range", crate::error::num(lo), crate::error::num(hi)),
                            format!(
                                "write [min, max] in metres with min ≤ max, both within ±{MAX_ELEVATION_M}"
                            ),
                        ));
                    }
                    Some([lo, hi])
                }
            };
            let file = cx.resolve(cx.non_empty(&h, "heightmap")?);
            let raster = read_gray(&file, Purpose::Heightmap, &cx.loc(&h.span()))?;
            raster.into_terrain(size, height_m).map_err(|()| {
                cx.invalid(
                    &span,
                    "this heightmap stores normalised samples; its height range is unknown",
                    "add height_m = [min, max] in metres",
                )
            })
        }
    }
}

fn build_placement(cx: &Ctx, raw: Option<RawPlacement>) -> Result<Placement, SceneError> {
    let mut p = Placement::default();
    let Some(raw) = raw else { return Ok(p) };
    p.seed = raw.seed.unwrap_or(p.seed);
    if let Some(m) = raw.method {
        p.method = match m.get_ref().as_str() {
            "poisson" => PlacementMethod::Poisson,
            "tiled" => PlacementMethod::Tiled,
            "wang" => PlacementMethod::Wang,
            other => {
                return Err(cx.invalid(
                    &m.span(),
                    format!("unknown placement method `{other}`"),
                    "use \"poisson\", \"tiled\" or \"wang\"",
                ));
            }
        };
    }
    Ok(p)
}

fn colour(
    cx: &Ctx,
    c: Option<Spanned<Nums<3>>>,
    default: [f32; 3],
    key: &str,
) -> Result<[f32; 3], SceneError> {
    let Some(c) = c else { return Ok(default) };
    let v = c.get_ref().0;
    if v.iter()
        .any(|x| !x.is_finite() || !(0.0..=MAX_COLOR).contains(x))
    {
        return Err(cx.invalid(
            &c.span(),
            format!("{key} has a component out of range or not a number"),
            format!("give linear RGB values in [0, {MAX_COLOR}]"),
        ));
    }
    Ok(v)
}

fn build_sun(cx: &Ctx, raw: Option<RawSun>) -> Result<Sun, SceneError> {
    let mut sun = Sun::default();
    let Some(raw) = raw else { return Ok(sun) };
    if let Some(a) = raw.azimuth_deg {
        let v = *a.get_ref();
        if !(v.is_finite() && (-360.0..=360.0).contains(&v)) {
            return Err(cx.invalid(
                &a.span(),
                format!("azimuth_deg = {v} is out of range"),
                "give degrees in [-360, 360] (clockwise from north)",
            ));
        }
        sun.azimuth_deg = v;
    }
    if let Some(e) = raw.elevation_deg {
        let v = *e.get_ref();
        if !(-90.0..=90.0).contains(&v) {
            return Err(cx.invalid(
                &e.span(),
                format!("elevation_deg = {v} is out of range"),
                "give degrees in [-90, 90]",
            ));
        }
        sun.elevation_deg = v;
    }
    sun.color = colour(cx, raw.color, sun.color, "color")?;
    Ok(sun)
}

fn build_sky(cx: &Ctx, raw: Option<RawSky>) -> Result<Sky, SceneError> {
    let d = Sky::default();
    let Some(raw) = raw else { return Ok(d) };
    let ground_contrast = match raw.ground_contrast {
        None => d.ground_contrast,
        Some(v) => {
            let a = *v.get_ref();
            if !(0.0..=4.0).contains(&a) {
                return Err(cx.invalid(
                    &v.span(),
                    format!("ground_contrast = {a} is out of range"),
                    "give 0 to 4 (BN12's a3; 0.5 is the default, 0 an evenly lit forest floor)",
                ));
            }
            a
        }
    };
    Ok(Sky {
        zenith: colour(cx, raw.zenith, d.zenith, "zenith")?,
        horizon: colour(cx, raw.horizon, d.horizon, "horizon")?,
        ground: colour(cx, raw.ground, d.ground, "ground")?,
        ground_occlusion: raw.ground_occlusion.unwrap_or(d.ground_occlusion),
        ground_contrast,
    })
}

/// Accepted `[world]` ranges.
const TILE_M: std::ops::RangeInclusive<f32> = 16.0..=4096.0;
const CACHE_MIB: std::ops::RangeInclusive<i64> = 16..=1 << 20;

fn build_world(cx: &Ctx, raw: Option<RawWorld>) -> Result<World, SceneError> {
    let mut w = World::default();
    let Some(raw) = raw else { return Ok(w) };
    if let Some(v) = &raw.tile_m {
        let t = *v.get_ref();
        if !TILE_M.contains(&t) {
            return Err(cx.invalid(
                &v.span(),
                format!("tile_m = {t} is out of range"),
                format!(
                    "give {} to {} metres (256 suits most worlds)",
                    TILE_M.start(),
                    TILE_M.end()
                ),
            ));
        }
        w.tile_m = t;
        w.prefetch_m = t;
    }
    for (v, slot, what) in [
        (
            &raw.tree_distance_m,
            &mut w.tree_distance_m,
            "tree_distance_m",
        ),
        (&raw.prefetch_m, &mut w.prefetch_m, "prefetch_m"),
    ] {
        if let Some(v) = v {
            let d = *v.get_ref();
            if d.is_nan() || d < 0.0 || (what == "prefetch_m" && !d.is_finite()) {
                return Err(cx.invalid(
                    &v.span(),
                    format!("{what} = {d} is not a distance"),
                    "give metres ≥ 0",
                ));
            }
            *slot = d;
        }
    }
    if let Some(v) = &raw.cache_mib {
        let m = *v.get_ref();
        if !CACHE_MIB.contains(&m) {
            return Err(cx.invalid(
                &v.span(),
                format!("cache_mib = {m} is out of range"),
                format!("give {} to {} MiB", CACHE_MIB.start(), CACHE_MIB.end()),
            ));
        }
        w.cache_mib = m as u32;
    }
    Ok(w)
}

fn build_fog(cx: &Ctx, raw: Option<RawFog>) -> Result<Fog, SceneError> {
    let mut fog = Fog::default();
    if let Some(h) = raw.and_then(|r| r.half_distance_m) {
        let v = *h.get_ref();
        if !v.is_finite() || v < 0.0 {
            return Err(cx.invalid(
                &h.span(),
                format!("half_distance_m = {v} is negative"),
                "give metres ≥ 0 (0 disables fog)",
            ));
        }
        fog.half_distance_m = v;
    }
    Ok(fog)
}

fn build_camera(cx: &Ctx, raw: Option<RawCamera>, terrain: &Terrain) -> Result<Camera, SceneError> {
    let mut cam = Camera::overview(terrain);
    let Some(raw) = raw else { return Ok(cam) };
    for (v, slot) in [
        (&raw.position, &mut cam.position),
        (&raw.look_at, &mut cam.look_at),
    ] {
        if let Some(v) = v {
            let p = Vec3::from(v.get_ref().0);
            if !p.is_finite() || p.abs().max_element() > 1e7 {
                return Err(cx.invalid(
                    &v.span(),
                    "camera coordinates must be finite and within 10,000 km",
                    "give [x, y, z] in metres",
                ));
            }
            *slot = p;
        }
    }
    if cam.position.distance(cam.look_at) < 1e-3 {
        let span = raw
            .look_at
            .as_ref()
            .or(raw.position.as_ref())
            .map_or(0..0, |s| s.span());
        return Err(cx.invalid(
            &span,
            "camera look_at equals its position",
            "look at a point away from the eye",
        ));
    }
    if let Some(f) = raw.fov_deg {
        let v = *f.get_ref();
        if !(1.0..=170.0).contains(&v) {
            return Err(cx.invalid(
                &f.span(),
                format!("fov_deg = {v} is out of range"),
                "give a vertical field of view in [1, 170] degrees",
            ));
        }
        cam.fov_deg = v;
    }
    Ok(cam)
}

/// Largest scene file read, bytes.
pub const MAX_SCENE_BYTES: u64 = 4 << 20;

impl Scene {
    /// Load a scene file (TOML, see DESIGN.md "Scene file").
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let text =
            crate::error::read_text(path, MAX_SCENE_BYTES, &Location::file(path), "scene file")?;
        Scene::parse(&text, path)
    }

    /// Build a scene from TOML `text` as if read from `path`: `path` names the file in errors
    /// and relative paths resolve against its folder.
    pub fn parse(text: &str, path: &Path) -> Result<Scene, SceneError> {
        parse_scene(text, path, MAX_TREES)
    }
}
