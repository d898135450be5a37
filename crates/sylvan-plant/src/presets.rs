//! Built-in plants, written as `.lsys` files under `assets/plants/` and compiled in, sized for
//! forests on a software rasteriser (leaf cards carrying many leaves in their texture, wood only
//! for trunk and thick branches): `pine` (conical conifer, 13 whorls of drooping branches
//! covered with needle-spray cards, ≤ 6,000 triangles), `prunus` (broad rounded crown on a
//! short trunk, MNP01's test tree, leaf-cluster cards, ≤ 8,000) and `bush` (low and round,
//! ≤ 2,500).

/// Preset names.
pub const PRESETS: [&str; 3] = ["pine", "prunus", "bush"];

/// The `.lsys` source of a preset.
pub fn preset_source(name: &str) -> Option<&'static str> {
    match name {
        "pine" => Some(include_str!("../../../assets/plants/pine.lsys")),
        "prunus" => Some(include_str!("../../../assets/plants/prunus.lsys")),
        "bush" => Some(include_str!("../../../assets/plants/bush.lsys")),
        _ => None,
    }
}
