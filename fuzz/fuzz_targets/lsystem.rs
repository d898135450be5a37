//! Fuzz target: `.lsys` parser + deriver + turtle + mesher must never panic, and a derived word
//! must stay within its declared limit. Run: `scripts/fuzz.sh lsystem`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(src) = std::str::from_utf8(data) {
        sylvan_plant::fuzzing::lsystem(src);
    }
});
