//! Shared helpers: a fresh temporary folder per test.

#![allow(dead_code)]

use std::path::PathBuf;

/// A new empty folder under the system temp dir, unique to this process and `name`.
pub fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sylvan-scene-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Write `scene.toml` (and nothing else) into a fresh folder; return its path.
pub fn scene_file(name: &str, text: &str) -> PathBuf {
    let path = temp_dir(name).join("scene.toml");
    std::fs::write(&path, text).unwrap();
    path
}
