//! Fuzz target: a tree-positions CSV (`[placement] positions = "...csv"`) must give trees or a
//! one-line error, never panic. Run: `scripts/fuzz.sh positions_csv`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        sylvan_scene::fuzzing::positions_csv(text);
    }
});
