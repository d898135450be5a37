//! Arbitrary TOML-ish text never panics the parser; errors stay one line.

use proptest::prelude::*;
use sylvan_scene::Scene;

fn tomlish() -> impl Strategy<Value = String> {
    let piece = prop_oneof![
        Just("[terrain]\n".to_string()),
        Just("[[species]]\n".to_string()),
        Just("[sun]\n".to_string()),
        Just("[camera]\n".to_string()),
        Just("[placement]\n".to_string()),
        Just("procedural = { seed = 1, size_m = 50, relief_m = 5 }\n".to_string()),
        Just("preset = \"pine\"\n".to_string()),
        Just("density_per_ha = 30\n".to_string()),
        Just("height_m = [1, 2]\n".to_string()),
        Just("positions = \"nope.csv\"\n".to_string()),
        Just("method = \"tiled\"\n".to_string()),
        Just("method = \"wang\"\n".to_string()),
        Just("fov_deg = 1e30\n".to_string()),
        Just("elevation_deg = nan\n".to_string()),
        Just("size_m = [0, -1]\n".to_string()),
        Just("position = [1, 2]\n".to_string()),
        "[a-z_]{1,12} = [-0-9.e\"\\[\\], ]{0,12}\n",
        "[ -~\n]{0,20}",
        any::<String>(),
    ];
    prop::collection::vec(piece, 0..12).prop_map(|v| v.concat())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    #[test]
    fn arbitrary_text_never_panics(text in tomlish()) {
        if let Err(e) = Scene::parse(&text, "fuzz.toml".as_ref()) {
            let s = e.to_string();
            prop_assert!(!s.contains('\n'), "{}", s);
            prop_assert!(s.starts_with("fuzz.toml"), "{}", s);
        }
    }
}

/// The fuzz entry point refuses a valid scene that would place more than its tree limit (the
/// 2 km default terrain at 2,024 pines/ha under `poisson`: 810k trees, over libFuzzer's 10 s
/// under AddressSanitizer), quickly and with the usual one-line message.
#[test]
fn fuzz_entry_point_caps_the_trees_it_places() {
    let text = "[placement]\nmethod = \"poisson\"\n[[species]]\npreset = \"pine\"\ndensity_per_ha = 2024\n";
    let err = sylvan_scene::fuzzing::scene(text).expect_err("over the fuzz tree limit");
    let s = err.to_string();
    assert!(s.contains("20000") || s.contains("20,000"), "{s}");
    assert!(!s.contains('\n'), "{s}");
    // A small scene still parses through the same entry point.
    let small = "[terrain]\nprocedural = { seed = 1, size_m = 100, relief_m = 5 }\n[placement]\nmethod = \"poisson\"\n[[species]]\npreset = \"pine\"\ndensity_per_ha = 50\n";
    let scene = sylvan_scene::fuzzing::scene(small).expect("a small scene parses");
    assert!(!scene.trees.is_empty());
}
