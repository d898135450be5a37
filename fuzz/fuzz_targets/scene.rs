//! Fuzz target: the TOML scene file and the camera-path file (both TOML) must parse to a scene
//! or a one-line error, never panic. Run: `scripts/fuzz.sh scene`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = sylvan_scene::fuzzing::scene(text);
        sylvan_scene::fuzzing::camera_path(text);
    }
});
