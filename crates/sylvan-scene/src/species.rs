//! `[[species]]` entries: plant source, height range, and exactly one of `density_per_ha`,
//! `density_map` (scaled by `density_per_ha`) or `positions`.

use crate::csv::read_positions;
use crate::default::preset_height_m;
use crate::error::{ErrorKind, SceneError};
use crate::file::{Ctx, Span};
use crate::heightmap::{Purpose, read_gray};
use crate::placement::{
    DEFAULT_DENSITY_PER_HA, Density, DensityMap, MAX_DENSITY_PER_HA, SpeciesLayout,
};
use crate::types::{PlantSource, Species, Terrain, TreeInstance};
use serde::Deserialize;
use toml::Spanned;

/// The plant presets `sylvan-plant` builds (its `preset_source`), checked when the scene is read
/// so an unknown one names its scene line.
pub const PRESETS: [&str; 5] = ["pine", "prunus", "bush", "chestnut", "beech"];

/// Tallest tree accepted, metres (the tallest living tree is ~116 m): species `height_m` and a
/// positions CSV's `height` column are checked against it.
pub const MAX_TREE_HEIGHT_M: f32 = 150.0;

/// A `[[species]]` table as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawSpecies {
    name: Option<String>,
    plant: Option<Spanned<String>>,
    preset: Option<Spanned<String>>,
    height_m: Option<Spanned<crate::file::Nums<2>>>,
    density_per_ha: Option<Spanned<f32>>,
    density_map: Option<Spanned<String>>,
    positions: Option<Spanned<String>>,
}

/// How a species' trees come about.
pub(crate) enum Growth {
    /// Placed by density; the span locates the density in the scene file for limit errors.
    Density(SpeciesLayout, Span),
    /// Given row by row in a positions CSV.
    Fixed(Vec<TreeInstance>),
}

/// Validate the `i`-th species; `seed` is the placement seed (for CSV heights and rotations).
pub(crate) fn build_species(
    cx: &Ctx,
    i: usize,
    s: Spanned<RawSpecies>,
    terrain: &Terrain,
    seed: u64,
) -> Result<(Species, Growth), SceneError> {
    let span = s.span();
    let s = s.into_inner();
    let index = i as u32;
    let plant = match (&s.plant, &s.preset) {
        (Some(_), Some(p)) => {
            return Err(cx.invalid(
                &p.span(),
                "a species has both `plant` and `preset`",
                "keep one of them",
            ));
        }
        (Some(p), None) => PlantSource::File(cx.resolve(cx.non_empty(p, "plant")?)),
        (None, Some(p)) => {
            let name = cx.non_empty(p, "preset")?;
            if !PRESETS.contains(&name) {
                return Err(cx.invalid(
                    &p.span(),
                    format!("unknown plant preset `{name}`"),
                    format!("use one of: {}", PRESETS.join(", ")),
                ));
            }
            PlantSource::Preset(name.to_string())
        }
        (None, None) => {
            return Err(cx.invalid(
                &span,
                "this species has no plant",
                "add plant = \"file.lsys\" (or .glb/.obj) or preset = \"pine\" | \"prunus\" | \"bush\"",
            ));
        }
    };
    if let (PlantSource::File(file), Some(p)) = (&plant, &s.plant)
        && !file.exists()
    {
        return Err(SceneError::new(
            ErrorKind::Io,
            cx.loc(&p.span()),
            format!("plant file {} not found", file.display()),
            "check the path (relative paths resolve against the scene file's folder)",
        ));
    }
    let height_m = match &s.height_m {
        None => preset_height_m(&plant),
        Some(h) => {
            let [lo, hi] = h.get_ref().0;
            if !(lo.is_finite() && hi.is_finite()) || lo <= 0.0 || lo > hi || hi > MAX_TREE_HEIGHT_M
            {
                return Err(cx.invalid(
                    &h.span(),
                    format!(
                        "height_m = [{}, {}] is not a valid range",
                        crate::error::num(lo),
                        crate::error::num(hi)
                    ),
                    format!("write [min, max] in metres with 0 < min ≤ max ≤ {MAX_TREE_HEIGHT_M}"),
                ));
            }
            [lo, hi]
        }
    };
    let name = s.name.clone().unwrap_or_else(|| match &plant {
        PlantSource::Preset(p) => p.clone(),
        PlantSource::File(f) => f
            .file_stem()
            .map_or(format!("species{i}"), |s| s.to_string_lossy().into()),
    });
    let density_scale = match &s.density_per_ha {
        None => None,
        Some(d) => {
            let v = *d.get_ref();
            if !v.is_finite() || v < 0.0 {
                return Err(cx.invalid(
                    &d.span(),
                    format!("density_per_ha = {v} is negative or not a number"),
                    "give trees per hectare ≥ 0",
                ));
            }
            if v > MAX_DENSITY_PER_HA {
                return Err(SceneError::new(
                    ErrorKind::Limit,
                    cx.loc(&d.span()),
                    format!("density_per_ha = {v} exceeds the limit of {MAX_DENSITY_PER_HA}"),
                    "trees per hectare, at most one tree per m²",
                ));
            }
            Some((v, d.span()))
        }
    };
    let growth = match (&s.positions, &s.density_map) {
        (Some(_), Some(m)) => {
            return Err(cx.invalid(
                &m.span(),
                "`positions` and `density_map` are exclusive",
                "keep one of them",
            ));
        }
        (Some(p), None) => {
            if let Some((_, dspan)) = &density_scale {
                return Err(cx.invalid(
                    dspan,
                    "`positions` and `density_per_ha` are exclusive",
                    "remove density_per_ha: the CSV gives every tree",
                ));
            }
            let file = cx.resolve(cx.non_empty(p, "positions")?);
            let seed = seed.wrapping_add(i as u64);
            let at = cx.loc(&p.span());
            Growth::Fixed(read_positions(&file, &at, terrain, index, height_m, seed)?)
        }
        (None, Some(m)) => {
            let file = cx.resolve(cx.non_empty(m, "density_map")?);
            let raster = read_gray(&file, Purpose::DensityMap, &cx.loc(&m.span()))?;
            let map = DensityMap {
                resolution: [raster.width, raster.height],
                values: raster.values,
            };
            let max_per_ha = density_scale
                .as_ref()
                .map_or(DEFAULT_DENSITY_PER_HA, |d| d.0);
            let density = Density::Map { map, max_per_ha };
            Growth::Density(
                SpeciesLayout {
                    species: index,
                    height_m,
                    density,
                },
                m.span(),
            )
        }
        (None, None) => {
            let Some((v, dspan)) = density_scale else {
                return Err(cx.invalid(
                    &span,
                    format!("species `{name}` says nowhere to grow"),
                    "add one of density_per_ha = N, density_map = \"map.png\" or positions = \"stand.csv\"",
                ));
            };
            let density = Density::PerHectare(v);
            Growth::Density(
                SpeciesLayout {
                    species: index,
                    height_m,
                    density,
                },
                dspan,
            )
        }
    };
    Ok((
        Species {
            name,
            plant,
            height_m,
        },
        growth,
    ))
}
