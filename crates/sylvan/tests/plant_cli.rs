//! `sylvan plant`: the CLI contract of DESIGN.md (one JSON object with `--stats`, `.glb`
//! export, one-line `error: FILE:LINE:COL: what — fix` on bad input).

use std::process::Command;

fn sylvan(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_sylvan"))
        .args(args)
        .output()
        .expect("run sylvan");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("sylvan-plant-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

#[test]
fn stats_is_one_json_object() {
    for preset in ["pine", "prunus", "bush", "chestnut", "beech"] {
        let (ok, out, err) = sylvan(&["plant", "--preset", preset, "--stats"]);
        assert!(ok, "{err}");
        assert_eq!(out.trim().lines().count(), 1);
        let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
        for key in [
            "internodes",
            "leaves",
            "triangles",
            "levels",
            "instances",
            "bbox_min",
            "bbox_max",
        ] {
            assert!(v.get(key).is_some(), "{preset}: missing {key} in {out}");
        }
        // Every preset draws a branching skeleton (twigs below `twig:` are carried by the
        // leaf cards) and stays within its triangle budget: 8,000 for the card presets,
        // 60k–250k for the trees of individual leaves (10k–25k leaves).
        assert!(v["internodes"].as_u64().unwrap() > 20, "{preset}: {out}");
        let (leaves, tris) = (
            v["leaves"].as_u64().unwrap(),
            v["triangles"].as_u64().unwrap(),
        );
        if matches!(preset, "chestnut" | "beech") {
            assert!((10_000..=25_000).contains(&leaves), "{preset}: {out}");
            assert!((60_000..=250_000).contains(&tris), "{preset}: {out}");
        } else {
            assert!(leaves > 500, "{preset}: {out}");
            assert!(tris <= 8000, "{preset}: {out}");
        }
        assert_eq!(v["bbox_min"].as_array().unwrap().len(), 3);
    }
}

#[test]
fn lsys_file_and_glb_round_trip() {
    let src = tmp("fig124a.lsys");
    std::fs::write(
        &src,
        "iterations: 5\nangle: 25.7\naxiom: F\nF -> F[+F]F[-F]F\n",
    )
    .unwrap();
    let (ok, out, err) = sylvan(&["plant", src.to_str().unwrap(), "--stats"]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(v["internodes"], 3125);
    let a = tmp("bush.glb");
    let b = tmp("bush2.glb");
    let (ok, _, err) = sylvan(&["plant", "--preset", "bush", "--out", a.to_str().unwrap()]);
    assert!(ok, "{err}");
    let (ok, out, err) = sylvan(&[
        "plant",
        a.to_str().unwrap(),
        "--out",
        b.to_str().unwrap(),
        "--stats",
    ]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(v["internodes"], 0);
    let (_, out2, _) = sylvan(&["plant", b.to_str().unwrap(), "--stats"]);
    let w: serde_json::Value = serde_json::from_str(out2.trim()).unwrap();
    assert_eq!(v["triangles"], w["triangles"]);
    assert_eq!(v["leaves"], w["leaves"]);
}

#[test]
fn bad_input_is_one_error_line() {
    let src = tmp("bad.lsys");
    std::fs::write(&src, "iterations: 2\nangle: 20\naxiom: F\nF -> F[+F\n").unwrap();
    let (ok, out, err) = sylvan(&["plant", src.to_str().unwrap(), "--stats"]);
    assert!(!ok);
    assert!(out.is_empty());
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.starts_with("error: ")
            && err.contains("bad.lsys:4:7: unbalanced '['")
            && err.contains(" — "),
        "{err}"
    );
    let (ok, _, err) = sylvan(&["plant", "--preset", "oak"]);
    assert!(
        !ok && err.starts_with("error: unknown plant preset 'oak'"),
        "{err}"
    );
    let (ok, _, err) = sylvan(&["plant"]);
    assert!(!ok && err.starts_with("error: no plant given"), "{err}");
    let glb = tmp("broken.glb");
    std::fs::write(&glb, b"not a gltf").unwrap();
    let (ok, _, err) = sylvan(&["plant", glb.to_str().unwrap()]);
    assert!(
        !ok && err.contains("broken.glb: malformed glTF") && err.lines().count() == 1,
        "{err}"
    );
}
