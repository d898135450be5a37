//! Fuzz target: Wavefront OBJ import must give a plant or a one-line error, never panic or
//! allocate without bound. Run: `scripts/fuzz.sh obj`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    sylvan_plant::fuzzing::obj(data);
});
