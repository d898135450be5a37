//! Built-in plants, written as `.lsys` files under `assets/plants/` and compiled in, sized for
//! forests on a software rasteriser (leaf cards carrying many leaves in their texture, wood only
//! for trunk and thick branches): `pine` (conical conifer, 13 whorls of drooping branches
//! covered with needle-spray cards, ≤ 6,000 triangles), `prunus` (broad rounded crown on a
//! short trunk, MNP01's test tree, leaf-cluster cards, ≤ 8,000) and `bush` (low and round,
//! ≤ 2,500) — and two broadleaf trees with individual leaves (GPSS07's kind of tree): each
//! leaf a real leaf mesh on its petiole with front, back and normal-map images (see
//! `leaves: chestnut|beech` and `blade:` in docs/lsystem.md): `chestnut` (broad rounded-oval
//! crown on a sturdy trunk, serrated oblong leaves of 8 triangles) and `beech` (tall domed oval
//! crown, small ovate leaves of 4 triangles in flat sprays).

/// Preset names.
pub const PRESETS: [&str; 5] = ["pine", "prunus", "bush", "chestnut", "beech"];

/// The `.lsys` source of a preset.
pub fn preset_source(name: &str) -> Option<&'static str> {
    match name {
        "pine" => Some(include_str!("../../../assets/plants/pine.lsys")),
        "prunus" => Some(include_str!("../../../assets/plants/prunus.lsys")),
        "bush" => Some(include_str!("../../../assets/plants/bush.lsys")),
        "chestnut" => Some(include_str!("../../../assets/plants/chestnut.lsys")),
        "beech" => Some(include_str!("../../../assets/plants/beech.lsys")),
        _ => None,
    }
}
