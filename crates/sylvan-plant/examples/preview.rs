//! Renders a plant to a PNG with a tiny CPU rasteriser (orthographic side view, z-buffer,
//! alpha-tested textured leaves, Lambert shading): a quick look at presets without a GPU.
//!
//! `cargo run -p sylvan-plant --release --example preview -- pine out.png [size] [azimuth]`

use glam::{Vec2, Vec3};
use sylvan_plant::{Mesh, Plant};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let src = args.get(1).map(String::as_str).unwrap_or("pine");
    let out = args.get(2).map(String::as_str).unwrap_or("preview.png");
    let size: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(512);
    let az: f32 = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(0.0);
    let plant = if sylvan_plant::PRESETS.contains(&src) {
        sylvan_plant::preset(src)
    } else {
        sylvan_plant::load(std::path::Path::new(src))
    };
    let plant = match plant {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let img = render(&plant, size, az.to_radians());
    img.save(out).expect("write png");
    println!("{}", serde_json_like(&plant));
    if let Some(path) = std::env::var_os("SYLVAN_TEXTURE") {
        let t = &plant.leaf_texture;
        if let Some(img) = image::RgbaImage::from_raw(t.width, t.height, t.rgba.clone()) {
            img.save(path).expect("write texture");
        }
    }
    if std::env::var_os("SYLVAN_OBJECTS").is_some() {
        for (i, o) in plant.instancing.objects.iter().enumerate() {
            println!(
                "object {i}: level {} uses {} wood tris {} instances {}",
                o.level,
                o.uses,
                o.wood.triangle_count(),
                o.instances.len()
            );
        }
    }
}

fn serde_json_like(p: &Plant) -> String {
    format!("{:?}", p.stats())
}

fn render(p: &Plant, n: u32, az: f32) -> image::RgbaImage {
    let (bmin, bmax) = (Vec3::from(p.bbox_min), Vec3::from(p.bbox_max));
    let c = (bmin + bmax) * 0.5;
    let ext = (bmax - bmin).max_element() * 0.55;
    let (s, co) = az.sin_cos();
    let right = Vec3::new(co, 0.0, -s);
    let fwd = Vec3::new(s, 0.0, co);
    let light = Vec3::new(0.4, 0.8, 0.45).normalize();
    let project = |q: Vec3| {
        let d = q - c;
        Vec3::new(
            (d.dot(right) / ext * 0.5 + 0.5) * n as f32,
            (0.5 - d.y / ext * 0.5) * n as f32,
            d.dot(fwd),
        )
    };
    let mut img = image::RgbaImage::from_pixel(n, n, image::Rgba([200, 215, 230, 255]));
    let mut z = vec![f32::INFINITY; (n * n) as usize];
    let tex = &p.leaf_texture;
    for (mesh, leaf) in [(&p.wood, false), (&p.leaves, true)] {
        raster(mesh, leaf, &project, light, tex, &mut img, &mut z, n);
    }
    img
}

#[allow(clippy::too_many_arguments)]
fn raster(
    m: &Mesh,
    leaf: bool,
    project: &dyn Fn(Vec3) -> Vec3,
    light: Vec3,
    tex: &sylvan_plant::LeafTexture,
    img: &mut image::RgbaImage,
    z: &mut [f32],
    n: u32,
) {
    for t in m.indices.chunks_exact(3) {
        let v: Vec<Vec3> = t
            .iter()
            .map(|&i| project(Vec3::from(m.positions[i as usize])))
            .collect();
        let uv: Vec<Vec2> = t.iter().map(|&i| Vec2::from(m.uvs[i as usize])).collect();
        let nrm = Vec3::from(m.normals[t[0] as usize]);
        let col = Vec3::from(m.colors[t[0] as usize]);
        let shade = if leaf {
            0.35 + 0.65 * nrm.dot(light).abs()
        } else {
            0.3 + 0.7 * nrm.dot(light).max(0.0)
        };
        let (minx, maxx) = (
            v.iter().map(|p| p.x).fold(f32::MAX, f32::min).max(0.0) as i32,
            v.iter()
                .map(|p| p.x)
                .fold(f32::MIN, f32::max)
                .min(n as f32 - 1.0) as i32,
        );
        let (miny, maxy) = (
            v.iter().map(|p| p.y).fold(f32::MAX, f32::min).max(0.0) as i32,
            v.iter()
                .map(|p| p.y)
                .fold(f32::MIN, f32::max)
                .min(n as f32 - 1.0) as i32,
        );
        let area = (v[1].x - v[0].x) * (v[2].y - v[0].y) - (v[2].x - v[0].x) * (v[1].y - v[0].y);
        if area.abs() < 1e-9 {
            continue;
        }
        for y in miny..=maxy {
            for x in minx..=maxx {
                let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                let w0 = ((v[1].x - px) * (v[2].y - py) - (v[2].x - px) * (v[1].y - py)) / area;
                let w1 = ((v[2].x - px) * (v[0].y - py) - (v[0].x - px) * (v[2].y - py)) / area;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let depth = w0 * v[0].z + w1 * v[1].z + w2 * v[2].z;
                let idx = (y as u32 * n + x as u32) as usize;
                if depth >= z[idx] {
                    continue;
                }
                let mut c = col;
                if leaf && tex.width > 0 {
                    let u = uv[0] * w0 + uv[1] * w1 + uv[2] * w2;
                    let tx =
                        ((u.x.clamp(0.0, 1.0) * (tex.width - 1) as f32) as u32).min(tex.width - 1);
                    let ty = ((u.y.clamp(0.0, 1.0) * (tex.height - 1) as f32) as u32)
                        .min(tex.height - 1);
                    let o = ((ty * tex.width + tx) * 4) as usize;
                    if tex.rgba[o + 3] < 128 {
                        continue;
                    }
                    let lin = |b: u8| (b as f32 / 255.0).powf(2.2);
                    c *= Vec3::new(lin(tex.rgba[o]), lin(tex.rgba[o + 1]), lin(tex.rgba[o + 2]));
                }
                z[idx] = depth;
                let c = (c * shade).powf(1.0 / 2.2) * 255.0;
                img.put_pixel(
                    x as u32,
                    y as u32,
                    image::Rgba([
                        c.x.min(255.0) as u8,
                        c.y.min(255.0) as u8,
                        c.z.min(255.0) as u8,
                        255,
                    ]),
                );
            }
        }
    }
}
