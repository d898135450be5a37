//! Heightmap, density map and positions import: orientation (column 0 → X = 0, row 0 → Z = 0),
//! value mapping, and the example scene.

mod common;

use common::temp_dir;
use std::path::Path;
use sylvan_scene::{PlantSource, Scene};

const W: u32 = 3;
const H: u32 = 2;

fn scene_with_heightmap(dir: &Path, file: &str, extra: &str) -> Scene {
    let path = dir.join("scene.toml");
    let text = format!("[terrain]\nheightmap = \"{file}\"\nsize_m = [20, 10]\n{extra}");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// Heights at the six grid points, in the order of `pixels` (row-major, row 0 first).
fn corners(s: &Scene) -> Vec<f32> {
    let mut out = Vec::new();
    for row in 0..H {
        for col in 0..W {
            out.push(s.terrain.height_at(col as f32 * 10.0, row as f32 * 10.0));
        }
    }
    out
}

#[test]
fn png16_heightmap_round_trip() {
    let dir = temp_dir("png16");
    let pixels: Vec<u16> = vec![0, 65535, 32768, 1000, 2000, 65535];
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(W, H, pixels.clone())
        .unwrap()
        .save(dir.join("dem.png"))
        .unwrap();
    let s = scene_with_heightmap(&dir, "dem.png", "height_m = [100, 200]\n");
    assert_eq!(s.terrain.resolution, [W, H]);
    assert_eq!(s.terrain.size, [20.0, 10.0]);
    let want: Vec<f32> = pixels
        .iter()
        .map(|&p| 100.0 + 100.0 * p as f32 / 65535.0)
        .collect();
    for (got, want) in corners(&s).iter().zip(&want) {
        assert!((got - want).abs() < 1e-3, "{got} vs {want}");
    }
    // Column 0 is X = 0, row 0 is Z = 0.
    assert_eq!(s.terrain.height_at(0.0, 0.0), 100.0);
    assert!((s.terrain.height_at(10.0, 0.0) - 200.0).abs() < 1e-3);
    // Missing height_m is an error for normalised samples.
    let path = dir.join("scene.toml");
    std::fs::write(
        &path,
        "[terrain]\nheightmap = \"dem.png\"\nsize_m = [20, 10]\n",
    )
    .unwrap();
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(
        e.contains("scene.toml:1:1") && e.contains("height_m"),
        "{e}"
    );
}

#[test]
fn png8_heightmap_is_accepted() {
    let dir = temp_dir("png8");
    let pixels: Vec<u8> = vec![0, 255, 51, 0, 0, 102];
    image::GrayImage::from_raw(W, H, pixels)
        .unwrap()
        .save(dir.join("dem.png"))
        .unwrap();
    let s = scene_with_heightmap(&dir, "dem.png", "height_m = [0, 50]\n");
    let got = corners(&s);
    assert!(
        (got[1] - 50.0).abs() < 1e-4
            && (got[2] - 10.0).abs() < 1e-4
            && (got[5] - 20.0).abs() < 1e-4
    );
}

#[test]
fn rgb_png_is_rejected_with_the_file_name() {
    let dir = temp_dir("rgb");
    image::RgbImage::new(4, 4)
        .save(dir.join("dem.png"))
        .unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(
        &path,
        "[terrain]\nheightmap = \"dem.png\"\nsize_m = 10\nheight_m = [0, 1]\n",
    )
    .unwrap();
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(
        e.contains("dem.png: not a 16-bit PNG or GeoTIFF heightmap (") && e.contains("Rgb"),
        "{e}"
    );
}

fn write_tiff<C: tiff::encoder::colortype::ColorType>(path: &Path, data: &[C::Inner])
where
    [C::Inner]: tiff::encoder::TiffValue,
{
    let mut file = std::fs::File::create(path).unwrap();
    let mut enc = tiff::encoder::TiffEncoder::new(&mut file).unwrap();
    enc.write_image::<C>(W, H, data).unwrap();
}

#[test]
fn geotiff_float_heights_are_taken_as_is() {
    let dir = temp_dir("tif-f32");
    let heights = [12.5f32, -3.0, 7.0, 100.0, f32::NAN, 40.0];
    write_tiff::<tiff::encoder::colortype::Gray32Float>(&dir.join("dem.tif"), &heights);
    let s = scene_with_heightmap(&dir, "dem.tif", "");
    let got = corners(&s);
    // NaN (no data) becomes the lowest valid height.
    assert_eq!(got, vec![12.5, -3.0, 7.0, 100.0, -3.0, 40.0]);
    // With height_m, the data's range is stretched onto it.
    let s = scene_with_heightmap(&dir, "dem.tif", "height_m = [0, 206]\n");
    assert_eq!(s.terrain.min_max(), (0.0, 206.0));
    assert!((s.terrain.height_at(0.0, 0.0) - 31.0).abs() < 1e-3);
}

#[test]
fn geotiff_u16_maps_onto_height_m() {
    let dir = temp_dir("tif-u16");
    let pixels: Vec<u16> = vec![0, 65535, 0, 0, 65535, 0];
    write_tiff::<tiff::encoder::colortype::Gray16>(&dir.join("dem.tif"), &pixels);
    let s = scene_with_heightmap(&dir, "dem.tif", "height_m = [10, 30]\n");
    assert_eq!(corners(&s), vec![10.0, 30.0, 10.0, 10.0, 30.0, 10.0]);
}

#[test]
fn density_map_modulates_placement() {
    let dir = temp_dir("density-map");
    // Left half white, right half black (columns 0..8 of 16).
    let pixels: Vec<u8> = (0..16 * 16)
        .map(|i| if i % 16 < 8 { 255 } else { 0 })
        .collect();
    image::GrayImage::from_raw(16, 16, pixels)
        .unwrap()
        .save(dir.join("map.png"))
        .unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(
        &path,
        "[terrain]\nprocedural = { size_m = 300, relief_m = 0 }\n\
         [[species]]\npreset = \"pine\"\ndensity_map = \"map.png\"\ndensity_per_ha = 300\n",
    )
    .unwrap();
    let s = Scene::load(&path).unwrap();
    // White covers X < 140 (column 7 of 15 → X = 140), fading to black by X = 160.
    assert!(s.trees.iter().all(|t| t.position.x < 160.0));
    let left = s.trees.iter().filter(|t| t.position.x < 140.0).count() as f32;
    let expected = 300.0 * 140.0 * 300.0 / 10_000.0;
    assert!(
        (left - expected).abs() < 0.1 * expected,
        "{left} vs {expected}"
    );
}

#[test]
fn example_scene_loads() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/scenes/example.toml");
    let s = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.species.len(), 3);
    assert_eq!(s.species[1].name, "orchard");
    assert_eq!(s.species[1].plant, PlantSource::Preset("prunus".into()));
    assert_eq!(s.terrain.size, [800.0, 600.0]);
    assert_eq!(s.lod_chain[0], "geometry:0-60");
    assert_eq!(s.sun.azimuth_deg, 220.0);
    assert_eq!(s.fog.half_distance_m, 2500.0);
    assert_eq!(s.camera.fov_deg, 55.0);
    assert_eq!(s.source.as_deref(), Some(path.as_path()));
    // The orchard comes from stand.csv, positions and heights as written.
    let csv = std::fs::read_to_string(path.with_file_name("stand.csv")).unwrap();
    let rows: Vec<Vec<f32>> = csv
        .lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .skip(1)
                .take(3)
                .map(|v| v.parse().unwrap())
                .collect()
        })
        .collect();
    let orchard: Vec<_> = s.trees.iter().filter(|t| t.species == 1).collect();
    assert_eq!(orchard.len(), rows.len());
    for (t, r) in orchard.iter().zip(&rows) {
        assert_eq!((t.position.x, t.position.z, t.height), (r[0], r[1], r[2]));
        assert_eq!(t.position.y, s.terrain.height_at(r[0], r[1]));
    }
    let pines = s.trees.iter().filter(|t| t.species == 0).count() as f32;
    let expected = 120.0 * 48.0;
    assert!(
        (pines - expected).abs() < 0.1 * expected,
        "{pines} vs {expected}"
    );
}

/// Fuzz finding (heightmap target): a GeoTIFF whose SampleFormat tag holds no values made the
/// `tiff` decoder index out of bounds (a panic). Now refused before decoding, one line.
#[test]
fn geotiff_with_an_empty_tag_is_refused() {
    let dir = temp_dir("tif-empty-tag");
    let bad = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../sylvan/tests/data/bad/dem_sample_format_empty.tif");
    std::fs::copy(bad, dir.join("dem.tif")).unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(
        &path,
        "[terrain]\nheightmap = \"dem.tif\"\nsize_m = [20, 10]\n",
    )
    .unwrap();
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(e.contains("dem.tif: "), "{e}");
    assert!(e.contains("(TIFF tag 339 has no values) — "), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
}
