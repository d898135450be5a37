//! Camera paths for `bench --path` and the viewer: a TOML file of timed keys,
//!
//! ```toml
//! interpolation = "catmull-rom"   # or "linear" (default)
//! fov_deg = 55                    # default for keys without their own
//!
//! [[key]]
//! t = 0.0                         # seconds, strictly increasing
//! position = [0, 120, -900]
//! look_at = [0, 40, 0]
//! ```
//!
//! sampled at any time (clamped to the first and last key).

use crate::error::{ErrorKind, Location, SceneError};
use crate::file::toml_error;
use crate::types::Camera;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::Path;
use toml::Spanned;

/// How positions and targets move between keys.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Interpolation {
    /// Straight segments, constant speed within each.
    #[default]
    Linear,
    /// A uniform Catmull–Rom spline through the keys (smooth; ends extrapolated linearly).
    CatmullRom,
}

/// One key of a camera path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraKey {
    /// Time in seconds.
    pub t: f32,
    /// The camera at that time.
    pub camera: Camera,
}

/// A timed sequence of cameras.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraPath {
    /// How to move between keys.
    pub interpolation: Interpolation,
    /// At least one key, in strictly increasing time.
    pub keys: Vec<CameraKey>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPath {
    #[serde(default)]
    interpolation: Interpolation,
    #[serde(default = "default_fov")]
    fov_deg: Spanned<f32>,
    #[serde(default)]
    key: Vec<RawKey>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawKey {
    t: Spanned<f32>,
    position: Spanned<[f32; 3]>,
    look_at: Spanned<[f32; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    fov_deg: Option<Spanned<f32>>,
}

fn default_fov() -> Spanned<f32> {
    Spanned::new(0..0, 55.0)
}

/// Largest camera coordinate accepted, metres (as in the scene file's `[camera]`).
const MAX_COORD_M: f32 = 1e7;

impl CameraPath {
    /// Read a camera path file.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        let text = crate::error::read_text(
            path,
            crate::file::MAX_SCENE_BYTES,
            &Location::file(path),
            "camera path",
        )?;
        Self::parse(&text, path)
    }

    /// Parse camera path TOML `text`, as if read from `path` (named in errors).
    pub fn parse(text: &str, path: &Path) -> Result<Self, SceneError> {
        let raw: RawPath = toml::from_str(text).map_err(|e| toml_error(&e, text, path))?;
        let invalid = |offset: usize, what: String, fix: &str| {
            SceneError::new(
                ErrorKind::InvalidValue,
                Location::at_offset(path, text, offset),
                what,
                fix,
            )
        };
        if raw.key.is_empty() {
            return Err(invalid(
                0,
                "the camera path has no keys".into(),
                "add [[key]] tables with t, position, look_at",
            ));
        }
        let fov_ok = |f: &Spanned<f32>| -> Result<f32, SceneError> {
            let v = *f.get_ref();
            if (1.0..=170.0).contains(&v) {
                Ok(v)
            } else {
                Err(invalid(
                    f.span().start,
                    format!("fov_deg = {v} is out of range"),
                    "give a vertical field of view in [1, 170] degrees",
                ))
            }
        };
        let default_fov = fov_ok(&raw.fov_deg)?;
        let mut keys = Vec::with_capacity(raw.key.len());
        for k in &raw.key {
            let t = *k.t.get_ref();
            if !t.is_finite() || t < 0.0 {
                return Err(invalid(
                    k.t.span().start,
                    format!("key time t = {t} is not a time"),
                    "give seconds from the start of the path (0 or more)",
                ));
            }
            if let Some(prev) = keys.last().map(|p: &CameraKey| p.t)
                && t <= prev
            {
                return Err(invalid(
                    k.t.span().start,
                    format!("key time t = {t} is not after the previous key ({prev})"),
                    "give strictly increasing times in seconds",
                ));
            }
            let fov = k.fov_deg.as_ref().map_or(Ok(default_fov), fov_ok)?;
            let coords = |v: &Spanned<[f32; 3]>, name: &str| -> Result<Vec3, SceneError> {
                let p = Vec3::from(*v.get_ref());
                if p.is_finite() && p.abs().max_element() <= MAX_COORD_M {
                    Ok(p)
                } else {
                    Err(invalid(
                        v.span().start,
                        format!("{name} must be finite and within 10,000 km"),
                        "give [x, y, z] in metres",
                    ))
                }
            };
            let camera = Camera {
                position: coords(&k.position, "position")?,
                look_at: coords(&k.look_at, "look_at")?,
                fov_deg: fov,
            };
            if camera.position.distance(camera.look_at) < 1e-3 {
                return Err(invalid(
                    k.look_at.span().start,
                    "this key's look_at equals its position".into(),
                    "look at a point away from the eye",
                ));
            }
            keys.push(CameraKey { t, camera });
        }
        Ok(Self {
            interpolation: raw.interpolation,
            keys,
        })
    }

    /// Write the path as TOML (the format [`CameraPath::load`] reads).
    pub fn save(&self, path: &Path) -> Result<(), SceneError> {
        let raw = RawPath {
            interpolation: self.interpolation,
            fov_deg: default_fov(),
            key: self
                .keys
                .iter()
                .map(|k| RawKey {
                    t: Spanned::new(0..0, k.t),
                    position: Spanned::new(0..0, k.camera.position.into()),
                    look_at: Spanned::new(0..0, k.camera.look_at.into()),
                    fov_deg: Some(Spanned::new(0..0, k.camera.fov_deg)),
                })
                .collect(),
        };
        let text = toml::to_string(&raw).expect("camera paths serialise");
        std::fs::write(path, text).map_err(|e| {
            SceneError::new(
                ErrorKind::Io,
                Location::file(path),
                format!("cannot write camera path ({e})"),
                "check the folder exists and is writable",
            )
        })
    }

    /// Time of the last key, seconds.
    pub fn duration(&self) -> f32 {
        self.keys.last().map_or(0.0, |k| k.t)
    }

    /// The camera at time `t` seconds (clamped to the keys' range).
    pub fn sample(&self, t: f32) -> Camera {
        let keys = &self.keys;
        let last = keys.len() - 1;
        if t <= keys[0].t || last == 0 {
            return keys[0].camera;
        }
        if t >= keys[last].t {
            return keys[last].camera;
        }
        let i = keys.partition_point(|k| k.t <= t) - 1;
        let (a, b) = (&keys[i], &keys[i + 1]);
        let u = (t - a.t) / (b.t - a.t);
        let fov_deg = a.camera.fov_deg + (b.camera.fov_deg - a.camera.fov_deg) * u;
        match self.interpolation {
            Interpolation::Linear => Camera {
                position: a.camera.position.lerp(b.camera.position, u),
                look_at: a.camera.look_at.lerp(b.camera.look_at, u),
                fov_deg,
            },
            Interpolation::CatmullRom => {
                let get = |f: fn(&Camera) -> Vec3| {
                    let p1 = f(&a.camera);
                    let p2 = f(&b.camera);
                    let p0 = if i > 0 {
                        f(&keys[i - 1].camera)
                    } else {
                        2.0 * p1 - p2
                    };
                    let p3 = if i + 2 <= last {
                        f(&keys[i + 2].camera)
                    } else {
                        2.0 * p2 - p1
                    };
                    catmull_rom(p0, p1, p2, p3, u)
                };
                Camera {
                    position: get(|c| c.position),
                    look_at: get(|c| c.look_at),
                    fov_deg,
                }
            }
        }
    }
}

/// Uniform Catmull–Rom between `p1` (u = 0) and `p2` (u = 1).
fn catmull_rom(p0: Vec3, p1: Vec3, p2: Vec3, p3: Vec3, u: f32) -> Vec3 {
    let (u2, u3) = (u * u, u * u * u);
    0.5 * (2.0 * p1
        + (p2 - p0) * u
        + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * u2
        + (3.0 * p1 - p0 - 3.0 * p2 + p3) * u3)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "interpolation = \"catmull-rom\"\n\n[[key]]\nt = 0\nposition = [0, 10, 0]\n\
        look_at = [0, 0, 100]\n\n[[key]]\nt = 2\nposition = [20, 10, 0]\nlook_at = [20, 0, 100]\n\
        fov_deg = 45\n\n[[key]]\nt = 4\nposition = [40, 30, 0]\nlook_at = [40, 0, 100]\n";

    #[test]
    fn samples_hit_keys_and_interpolate() {
        let p = CameraPath::parse(TEXT, Path::new("fly.toml")).unwrap();
        assert_eq!(p.interpolation, Interpolation::CatmullRom);
        assert_eq!(p.duration(), 4.0);
        assert_eq!(p.sample(-1.0).position, Vec3::new(0.0, 10.0, 0.0));
        assert!(
            p.sample(2.0)
                .position
                .abs_diff_eq(Vec3::new(20.0, 10.0, 0.0), 1e-5)
        );
        assert_eq!(p.sample(9.0).position, Vec3::new(40.0, 30.0, 0.0));
        assert_eq!(p.sample(1.0).fov_deg, 50.0);
        let mid = p.sample(1.0).position;
        assert!(
            (mid.x - 10.0).abs() < 1.0 && mid.y < 10.0,
            "smooth, dips before rising: {mid}"
        );
        let linear = CameraPath {
            interpolation: Interpolation::Linear,
            ..p.clone()
        };
        assert_eq!(linear.sample(3.0).position, Vec3::new(30.0, 20.0, 0.0));
    }

    #[test]
    fn save_then_load_round_trips() {
        let p = CameraPath::parse(TEXT, Path::new("fly.toml")).unwrap();
        let file =
            std::env::temp_dir().join(format!("sylvan-scene-path-{}.toml", std::process::id()));
        p.save(&file).unwrap();
        let q = CameraPath::load(&file).unwrap();
        std::fs::remove_file(&file).ok();
        assert_eq!(p, q);
    }

    #[test]
    fn bad_paths_give_located_errors() {
        let e = CameraPath::parse("", Path::new("p.toml"))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("p.toml:1:1: the camera path has no keys"),
            "{e}"
        );
        let bad = "[[key]]\nt = 1\nposition = [0, 0, 0]\nlook_at = [1, 0, 0]\n[[key]]\nt = 1\nposition = [0, 0, 0]\nlook_at = [1, 0, 0]\n";
        let e = CameraPath::parse(bad, Path::new("p.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("p.toml:6:5: key time t = 1"), "{e}");
        let e = CameraPath::parse("[[key]]\nt = 0\npos = 1\n", Path::new("p.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("p.toml:3:1: unknown key `pos`"), "{e}");
    }

    /// Every field of a key is range-checked, the error at the field (issue #19).
    #[test]
    fn out_of_range_fields_give_located_errors() {
        let key = |t: &str, pos: &str, fov: &str| {
            format!("[[key]]\nt = {t}\nposition = {pos}\nlook_at = [1, 0, 0]\n{fov}")
        };
        let err = |text: &str| {
            CameraPath::parse(text, Path::new("p.toml"))
                .unwrap_err()
                .to_string()
        };
        for (text, want) in [
            (
                key("-1", "[0, 0, 0]", ""),
                "p.toml:2:5: key time t = -1 is not a time — ",
            ),
            (
                key("nan", "[0, 0, 0]", ""),
                "p.toml:2:5: key time t = NaN is not a time — ",
            ),
            (
                key("inf", "[0, 0, 0]", ""),
                "p.toml:2:5: key time t = inf is not a time — ",
            ),
            (
                key("0", "[0, nan, 0]", ""),
                "p.toml:3:12: position must be finite and within 10,000 km — ",
            ),
            (
                key("0", "[0, 1e30, 0]", ""),
                "p.toml:3:12: position must be finite and within 10,000 km — ",
            ),
            (
                key("0", "[0, 0, 0]", "fov_deg = 0.5\n"),
                "p.toml:5:11: fov_deg = 0.5 is out of range — ",
            ),
            (
                key("0", "[0, 0, 0]", "fov_deg = nan\n"),
                "p.toml:5:11: fov_deg = NaN is out of range — ",
            ),
            (
                format!("fov_deg = 171\n{}", key("0", "[0, 0, 0]", "")),
                "p.toml:1:11: fov_deg = 171 is out of range — ",
            ),
            (
                key("0", "[1, 0, 0]", ""),
                "p.toml:4:11: this key's look_at equals its position — ",
            ),
        ] {
            let e = err(&text);
            assert!(e.starts_with(want), "{text}\n{e}");
            assert_eq!(e.lines().count(), 1, "{e}");
        }
    }
}
