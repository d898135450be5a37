//! Fuzz target: `.lsys` parser + deriver + turtle + mesher must never panic, and must stay
//! within the declared string limit. Run: `cargo +nightly fuzz run lsystem`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(src) = std::str::from_utf8(data) else { return };
    let Ok(mut ls) = sylvan_plant::LSystem::parse(src, "fuzz.lsys") else { return };
    // Keep each input fast; the limits themselves are exercised by the tests.
    ls.limit = ls.limit.min(20_000);
    ls.iterations = ls.iterations.min(12);
    if let Ok(word) = ls.derive() {
        assert!(word.len() <= ls.limit);
        let _ = sylvan_plant::from_lsystem(&ls, "fuzz");
    }
});
