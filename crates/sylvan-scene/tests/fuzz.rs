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
