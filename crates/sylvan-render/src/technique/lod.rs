//! Technique `auto`: the level-of-detail chain — a technique per distance band, each tree drawn
//! by the band its distance from the eye falls in, with a cross-fade across each boundary (the
//! far technique's presence rises from 0 to 1 over ±[`FADE`] of the boundary distance while the
//! near one's falls, so no tree pops). Bands come from the scene's `[lod] chain`, e.g.
//! `["geometry:0-60", "boxtree:60-"]`; without one, [`DEFAULT_CHAIN`].
//!
//! Each band keeps its own instance list, refilled from the frame's culled instances every
//! frame (no allocation), and its technique is prepared once like a stand-alone one.

use crate::RenderError;
use crate::instances::{GpuTreeInstance, Instances};
use crate::technique::TechniqueKind;
use glam::Vec3;

/// The chain used when a scene has no `[lod] chain`.
pub const DEFAULT_CHAIN: [&str; 2] = ["geometry:0-40", "boxtree:40-"];

/// Half-width of the cross-fade at a band boundary, relative to the boundary distance.
pub const FADE: f32 = 0.1;

/// Techniques a chain may use in this build.
pub const CHAIN_TECHNIQUES: [TechniqueKind; 3] = [
    TechniqueKind::Geometry,
    TechniqueKind::BoxTree,
    TechniqueKind::Hbt,
];

/// One band of the chain, parsed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Band {
    /// The technique drawing this band.
    pub technique: TechniqueKind,
    /// Start distance (metres).
    pub start: f32,
    /// End distance (metres, `f32::INFINITY` for an open end).
    pub end: f32,
}

/// Parses `[lod] chain` entries (`"name:start-end"`, end may be empty): bands must be
/// contiguous, start at 0, end open, and use techniques this build implements.
pub fn parse_chain(entries: &[String]) -> Result<Vec<Band>, RenderError> {
    let default: Vec<String> = DEFAULT_CHAIN.iter().map(|s| s.to_string()).collect();
    let entries = if entries.is_empty() {
        &default
    } else {
        entries
    };
    let mut bands: Vec<Band> = Vec::with_capacity(entries.len());
    for e in entries {
        let bad = |why: &str| {
            RenderError::Option(format!(
                "[lod] chain entry '{e}': {why} — write entries as \"technique:START-END\", e.g. \"boxtree:60-\""
            ))
        };
        let (name, range) = e.split_once(':').ok_or_else(|| bad("no ':'"))?;
        let technique = TechniqueKind::parse(name.trim())?;
        if !CHAIN_TECHNIQUES.contains(&technique) {
            return Err(RenderError::Option(format!(
                "[lod] chain entry '{e}': technique '{}' is not implemented yet — use geometry, boxtree or hbt in the chain",
                technique.name()
            )));
        }
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
        if !(start.is_finite() && start >= 0.0 && end > start) {
            return Err(bad("distances must satisfy 0 ≤ START < END"));
        }
        match bands.last() {
            Some(prev) if prev.end != start => {
                return Err(bad(&format!(
                    "the previous band ends at {}, this one starts at {start}",
                    prev.end
                )));
            }
            None if start != 0.0 => return Err(bad("the first band must start at 0")),
            _ => {}
        }
        bands.push(Band {
            technique,
            start,
            end,
        });
    }
    if bands.last().is_some_and(|b| b.end.is_finite()) {
        let last = entries.last().map(String::as_str).unwrap_or("");
        return Err(RenderError::Option(format!(
            "[lod] chain entry '{last}': the last band must be open-ended so far trees are drawn — end it with '-', e.g. \"boxtree:60-\""
        )));
    }
    Ok(bands)
}

fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Presence of band `i` for a tree at `distance`: 1 inside the band, cross-fading over ±FADE
/// of each inner boundary; the presences of all bands sum to 1.
pub fn presence(bands: &[Band], i: usize, distance: f32) -> f32 {
    let b = &bands[i];
    let rise = if i == 0 {
        1.0
    } else {
        smoothstep(b.start * (1.0 - FADE), b.start * (1.0 + FADE), distance)
    };
    let fall = if i + 1 == bands.len() {
        1.0
    } else {
        1.0 - smoothstep(b.end * (1.0 - FADE), b.end * (1.0 + FADE), distance)
    };
    rise * fall
}

/// Fills each band's instance list from the frame's.
pub(crate) fn split(
    gpu: &sylvan_gpu::Gpu,
    bands: &[Band],
    lists: &mut [Instances],
    master: &Instances,
    eye: Vec3,
) {
    for (i, list) in lists.iter_mut().enumerate() {
        list.fill_from(gpu, master, |r: &GpuTreeInstance| {
            let d = Vec3::new(r.base_scale[0], r.base_scale[1], r.base_scale[2]).distance(eye);
            presence(bands, i, d)
        });
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
            &["zfield:0-"],
            &["nope:0-"],
            &["geometry:0-x"],
        ] {
            let e = chain(bad).unwrap_err().to_string();
            assert!(e.contains('—'), "{e}");
        }
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
