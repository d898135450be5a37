//! Issue #19's bad inputs: every case under `tests/data/bad/` (plus special files made here at
//! test time: `/dev/zero` symlinks, FIFOs) fails with exactly one `error:` line naming what is
//! wrong and a fix, no panic, a non-zero exit — and quickly, without reading gigabytes.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The bad-input corpus, copied into a fresh folder so special files can be added beside it.
fn corpus(test: &str) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bad");
    let dir = std::env::temp_dir().join(format!("sylvan-bad-inputs-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for e in std::fs::read_dir(&src).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), dir.join(e.file_name())).unwrap();
    }
    #[cfg(unix)]
    {
        for name in ["zero.bin", "zero.lsys", "zero.toml", "zero.csv", "zero.glb"] {
            std::os::unix::fs::symlink("/dev/zero", dir.join(name)).unwrap();
        }
        for name in ["fifo.lsys", "fifo.toml"] {
            let ok = Command::new("mkfifo").arg(dir.join(name)).status();
            assert!(ok.is_ok_and(|s| s.success()), "mkfifo");
        }
    }
    dir
}

/// Runs `sylvan` in `dir`; asserts one `error:` line containing every `want`, no panic, exit ≠ 0.
fn fails(dir: &Path, args: &[&str], want: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_sylvan"))
        .args(args)
        .current_dir(dir)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .output()
        .expect("run sylvan");
    let err = String::from_utf8_lossy(&out.stderr);
    let case = args.join(" ");
    assert!(!out.status.success(), "{case}: exit 0\n{err}");
    assert!(!err.contains("panicked"), "{case}: panic\n{err}");
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(lines.len(), 1, "{case}: want one error line\n{err}");
    for w in want {
        assert!(lines[0].contains(w), "{case}: want '{w}' in\n{}", lines[0]);
    }
    assert!(lines[0].contains(" — "), "{case}: no fix in\n{}", lines[0]);
}

#[test]
fn gltf_and_obj_imports() {
    let d = corpus("import");
    let plant = |file: &str, want: &[&str]| fails(&d, &["plant", file, "--stats"], want);
    plant(
        "gltf_stride_below_element.glb",
        &["byte stride 4 is smaller than its element (12 bytes)"],
    );
    plant(
        "gltf_node_fanout_2pow26.glb",
        &["more than 65536 node instances"],
    );
    plant(
        "gltf_buffer_uri_dev_zero.gltf",
        &["buffer", "zero.bin", "character device"],
    );
    plant("gltf_buffer_uri_bad_percent.gltf", &["no such file"]);
    // Found by `cargo fuzz` (gltf target): gltf-json's validation panicked.
    plant(
        "gltf_position_accessor_missing.gltf",
        &["POSITION names accessor 0, the file has 0"],
    );
    // Found by `cargo fuzz` (gltf target): the gltf reader hit `unreachable!`.
    plant(
        "gltf_float_indices.glb",
        &["indices accessor 1 is Vec3 of F32, which glTF does not allow there"],
    );
    plant(
        "obj_mtllib_dev_zero.obj",
        &["mtllib '/dev/zero'", "character device"],
    );
    plant("zero.glb", &["character device"]);
    plant("zero.lsys", &["character device"]);
    plant("fifo.lsys", &["FIFO"]);
}

#[test]
fn scene_values_and_files() {
    let d = corpus("scene");
    let render = |file: &str, want: &[&str]| {
        fails(
            &d,
            &["render", file, "--out", "out.png", "--size", "8x8"],
            want,
        )
    };
    render(
        "scene_azimuth_nan.toml",
        &["scene_azimuth_nan.toml:2:15: azimuth_deg = NaN"],
    );
    render(
        "scene_height_m_three_numbers.toml",
        &[":3:12:", "exactly 2 numbers"],
    );
    render(
        "scene_heightmap_range_3e38.toml",
        &[":4:12: height_m = [-3e38, 3e38]"],
    );
    render(
        "scene_tree_height_1e30.toml",
        &[":3:12: height_m = [1, 1e30]", "≤ 150"],
    );
    render(
        "scene_csv_height_1e30.toml",
        &["csv_height_1e30.csv:2:13: height 1e30 m"],
    );
    render(
        "scene_geotiff_3e38.toml",
        &["dem_samples_3e38.tif: sample at column 1, row 0 is 3e38 m"],
    );
    // Found by `cargo fuzz` (heightmap target): the tiff decoder panicked.
    render(
        "scene_geotiff_sample_format_empty.toml",
        &[
            "dem_sample_format_empty.tif: ",
            "TIFF tag 339 has no values",
        ],
    );
    render(
        "scene_preset_oak.toml",
        &["scene_preset_oak.toml:2:10: unknown plant preset `oak`"],
    );
    render(
        "scene_not_utf8.toml",
        &[
            "scene_not_utf8.toml:2:22: ",
            "not UTF-8",
            "save the file as UTF-8",
        ],
    );
    render(
        "scene_csv_dev_zero.toml",
        &[
            ":6:13: cannot read positions CSV zero.csv",
            "character device",
        ],
    );
    render("zero.toml", &["character device"]);
    render("fifo.toml", &["FIFO"]);
    let many: String = (0..2000)
        .map(|_| "[[species]]\npreset = \"bush\"\ndensity_per_ha = 1\n")
        .collect();
    std::fs::write(d.join("species_2000.toml"), many).unwrap();
    render(
        "species_2000.toml",
        &["species_2000.toml:193:1: 2000 [[species]] entries, more than the limit of 64"],
    );
}

#[test]
fn scene_presets_are_the_plant_presets() {
    for name in sylvan_scene::PRESETS {
        assert!(sylvan_plant::preset_source(name).is_some(), "{name}");
    }
}

#[test]
fn compare_refuses_huge_images_from_the_header() {
    let d = corpus("compare");
    fails(
        &d,
        &["compare", "png_12000x12000.png", "png_12000x12000.png"],
        &["12000x12000", "limit"],
    );
}

#[test]
fn clap_errors_are_one_line_with_where_to_look() {
    let d = corpus("clap");
    fails(
        &d,
        &["render", "--size"],
        &[
            "a value is required for '--size",
            "see `sylvan render --help`",
        ],
    );
    fails(
        &d,
        &["render", "--spp", "-1"],
        &["'-1'", "see `sylvan render --help`"],
    );
    fails(
        &d,
        &["frobnicate"],
        &["unrecognized subcommand", "see `sylvan --help`"],
    );
}
