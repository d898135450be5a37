//! Every bad input gives ONE line `FILE:LINE:COL: what — fix` with the right file and position.

mod common;

use common::{scene_file, temp_dir};
use sylvan_scene::{ErrorKind, Scene, SceneError};

fn load_err(name: &str, text: &str) -> (SceneError, String) {
    let path = scene_file(name, text);
    let e = Scene::load(&path).expect_err("should fail");
    let s = e.to_string();
    println!("{s}");
    assert!(!s.contains('\n'), "one line: {s}");
    assert!(s.contains(" — "), "has a fix: {s}");
    (e, s)
}

/// The message starts with `…/scene.toml:LINE:COL: ` and mentions `needle`.
fn assert_at(s: &str, line_col: &str, needle: &str) {
    let prefix = format!("scene.toml:{line_col}: ");
    assert!(s.contains(&prefix), "expected {prefix} in {s}");
    assert!(s.contains(needle), "expected {needle:?} in {s}");
}

#[test]
fn missing_scene_file() {
    let path = temp_dir("missing").join("nope.toml");
    let e = Scene::load(&path).unwrap_err();
    assert_eq!(e.kind, ErrorKind::Io);
    let s = e.to_string();
    assert!(s.contains("nope.toml: cannot read scene file"), "{s}");
    assert!(!s.contains('\n'));
}

#[test]
fn malformed_toml() {
    let (e, s) = load_err(
        "malformed",
        "[sun]\nazimuth_deg = 140\nelevation_deg = = 3\n",
    );
    assert_eq!(e.kind, ErrorKind::Syntax);
    assert!(s.contains("scene.toml:3:"), "{s}");
}

#[test]
fn unknown_key() {
    let (e, s) = load_err("unknown", "[sun]\nazimuth_deg = 140\n  elevaton_deg = 30\n");
    assert_eq!(e.kind, ErrorKind::UnknownKey);
    assert_at(&s, "3:3", "unknown key `elevaton_deg`");
    let (_, s) = load_err(
        "unknown-table",
        "[terrain]\nprocedural = { seed = 1, sise_m = 100 }\n",
    );
    assert_at(&s, "2:26", "sise_m");
    let (_, s) = load_err("unknown-top", "[sunn]\n");
    assert_at(&s, "1:2", "sunn");
}

#[test]
fn wrong_type() {
    let (e, s) = load_err("type", "[camera]\nfov_deg = \"wide\"\n");
    assert_eq!(e.kind, ErrorKind::Syntax);
    assert_at(&s, "2:11", "");
}

#[test]
fn heightmap_that_is_not_an_image() {
    let dir = temp_dir("not-image");
    std::fs::write(dir.join("dem.png"), "this is text").unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(
        &path,
        "[terrain]\nheightmap = \"dem.png\"\nsize_m = [100, 100]\nheight_m = [0, 10]\n",
    )
    .unwrap();
    let e = Scene::load(&path).unwrap_err();
    assert_eq!(e.kind, ErrorKind::Image);
    let s = e.to_string();
    assert!(
        s.contains("dem.png: not a 16-bit PNG or GeoTIFF heightmap ("),
        "{s}"
    );
    assert!(!s.contains('\n'));
    // A missing heightmap points at the scene file's value.
    std::fs::write(
        &path,
        "[terrain]\nheightmap = \"gone.png\"\nsize_m = [100, 100]\n",
    )
    .unwrap();
    let s = Scene::load(&path).unwrap_err().to_string();
    assert!(
        s.contains("scene.toml:2:13: cannot read") && s.contains("gone.png"),
        "{s}"
    );
}

#[test]
fn negative_density() {
    let text = "[[species]]\nname = \"pine\"\npreset = \"pine\"\ndensity_per_ha =  -5\n";
    let (e, s) = load_err("negative", text);
    assert_eq!(e.kind, ErrorKind::InvalidValue);
    assert_at(&s, "4:19", "density_per_ha");
}

#[test]
fn bad_height_ranges() {
    let base = "[[species]]\npreset = \"pine\"\ndensity_per_ha = 1\n";
    let (_, s) = load_err("h-order", &format!("{base}height_m = [20, 10]\n"));
    assert_at(&s, "4:12", "height_m = [20, 10]");
    let (_, s) = load_err("h-zero", &format!("{base}height_m = [0, 10]\n"));
    assert_at(&s, "4:12", "height_m = [0, 10]");
    let (_, s) = load_err("h-neg", &format!("{base}height_m = [-3, -1]\n"));
    assert_at(&s, "4:12", "height_m");
}

#[test]
fn too_many_trees() {
    let text = "[terrain]\nprocedural = { size_m = 100000, relief_m = 0 }\n\n\
                [[species]]\npreset = \"pine\"\ndensity_per_ha = 500\n";
    let (e, s) = load_err("too-many", text);
    assert_eq!(e.kind, ErrorKind::Limit);
    assert_at(&s, "6:18", "more than the limit of 2000000");
}

#[test]
fn empty_or_missing_plant() {
    let (_, s) = load_err(
        "empty-plant",
        "[[species]]\nplant = \"\"\ndensity_per_ha = 1\n",
    );
    assert_at(&s, "2:9", "`plant` is empty");
    let (_, s) = load_err(
        "empty-preset",
        "[[species]]\npreset = \"  \"\ndensity_per_ha = 1\n",
    );
    assert_at(&s, "2:10", "`preset` is empty");
    let (_, s) = load_err(
        "no-plant",
        "[sun]\n\n[[species]]\nname = \"x\"\ndensity_per_ha = 1\n",
    );
    assert!(
        s.contains("scene.toml:3:") || s.contains("scene.toml:4:"),
        "{s}"
    );
    assert!(s.contains("no plant"), "{s}");
    let (_, s) = load_err(
        "both",
        "[[species]]\nplant = \"a.lsys\"\npreset = \"pine\"\n",
    );
    assert_at(&s, "3:10", "both");
    let (_, s) = load_err(
        "missing-plant-file",
        "[[species]]\nplant = \"nothere.lsys\"\ndensity_per_ha = 1\n",
    );
    assert_at(&s, "2:9", "nothere.lsys");
}

#[test]
fn nowhere_to_grow_and_exclusive_keys() {
    let (_, s) = load_err("nowhere", "[[species]]\npreset = \"pine\"\n");
    assert!(s.contains("nowhere to grow"), "{s}");
    let (_, s) = load_err(
        "excl",
        "[[species]]\npreset = \"pine\"\npositions = \"a.csv\"\ndensity_per_ha = 3\n",
    );
    assert_at(&s, "4:18", "exclusive");
}

#[test]
fn bad_csv_rows() {
    let dir = temp_dir("csv-rows");
    let path = dir.join("scene.toml");
    std::fs::write(
        &path,
        "[terrain]\nprocedural = { size_m = 100 }\n[[species]]\npreset = \"bush\"\npositions = \"stand.csv\"\n",
    )
    .unwrap();
    let cases = [
        (
            "x,y\n1,2\n3,4x\n",
            "stand.csv:3:3: `4x` in column `y` is not a number",
        ),
        (
            "x,y,height\n1,2,3\n4,5\n",
            "stand.csv:3:4: the row has 2 fields; column `height` is missing",
        ),
        (
            "x,y\n1,2\n50,100.5\n",
            "stand.csv:3:4: position (50, 100.5) is outside the terrain",
        ),
        (
            "name,y\na,1\n",
            "stand.csv:1:1: the header has no `x` column",
        ),
    ];
    for (csv, want) in cases {
        std::fs::write(dir.join("stand.csv"), csv).unwrap();
        let e = Scene::load(&path).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Csv);
        let s = e.to_string();
        assert!(s.contains(want), "expected {want:?} in {s}");
        assert!(!s.contains('\n'));
    }
    std::fs::remove_file(dir.join("stand.csv")).unwrap();
    let s = Scene::load(&path).unwrap_err().to_string();
    assert!(
        s.contains("scene.toml:5:13: cannot read positions CSV"),
        "{s}"
    );
}

#[test]
fn out_of_range_values() {
    let (_, s) = load_err("elev", "[sun]\nelevation_deg = 120\n");
    assert_at(&s, "2:17", "elevation_deg");
    let (_, s) = load_err("fov", "[camera]\nfov_deg = 0\n");
    assert_at(&s, "2:11", "fov_deg");
    let (_, s) = load_err("method", "[placement]\nmethod = \"random\"\n");
    assert_at(&s, "2:10", "random");
    let (_, s) = load_err("size", "[terrain]\nprocedural = { size_m = -5 }\n");
    assert_at(&s, "2:25", "size_m");
    let (_, s) = load_err("size3", "[terrain]\nprocedural = { size_m = [1, 2, 3] }\n");
    assert!(s.contains("scene.toml:2:"), "{s}");
    let (_, s) = load_err("contrast", "[sky]\nground_contrast = 9\n");
    assert_at(&s, "2:19", "ground_contrast");
    let (_, s) = load_err("occlusion", "[sky]\nground_occlusion = 1\n");
    assert!(s.contains("scene.toml:2:"), "{s}");
}
