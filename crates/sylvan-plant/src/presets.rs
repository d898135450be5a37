//! Built-in plants, written as `.lsys` files under `assets/plants/` and compiled in:
//! `pine` (conifer with whorls of needle-covered branches; MNP01 §7's pine: ~30 main branches,
//! ~300 boughs, ~30,000 needles drawn as needle-tuft quads), `prunus` (broad-leaved, MNP01's
//! test tree) and `bush` (low and round).

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
