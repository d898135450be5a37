//! Fuzz target: heightmap and density-map bytes (16-bit PNG, GeoTIFF) must decode to a terrain
//! or give a one-line error, never panic or allocate past the header's checked size.
//! Run: `scripts/fuzz.sh heightmap`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    sylvan_scene::fuzzing::heightmap(data);
});
