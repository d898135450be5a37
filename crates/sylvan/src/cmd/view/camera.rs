//! The viewer's camera: fly (WASD/QE move, mouse look, speed on the wheel), orbit around a picked
//! tree (drag to turn, wheel to zoom), and camera paths — played back, or recorded from whatever
//! the camera does and saved in the TOML format `bench --path` replays.
//!
//! Plain CPU state driven by input calls and `update(dt)`; tested without a window.
//! Angles follow the scene conventions: yaw from +Z towards +X, pitch up from the horizon.

use glam::{Mat4, Vec3, Vec4};
use sylvan_scene::{Camera, CameraKey, CameraPath, Interpolation, TreeInstance};

/// What drives the camera.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Free flight.
    Fly,
    /// Turning around a point (a picked tree).
    Orbit,
    /// Following the loaded camera path.
    Path,
}

/// Movement keys held down.
#[derive(Debug, Clone, Copy, Default)]
pub struct Held {
    /// W.
    pub forward: bool,
    /// S.
    pub back: bool,
    /// A.
    pub left: bool,
    /// D.
    pub right: bool,
    /// E.
    pub up: bool,
    /// Q.
    pub down: bool,
    /// Shift: 4× speed.
    pub fast: bool,
}

/// Seconds between recorded keys.
pub const RECORD_INTERVAL_S: f32 = 0.25;
/// Slowest and fastest fly speeds (m/s).
pub const SPEED_RANGE: (f32, f32) = (0.5, 2000.0);
const MAX_PITCH: f32 = 1.55;
/// Longest time step the camera integrates at once (a slow software frame must not teleport).
const MAX_STEP_S: f32 = 0.1;

/// Camera state and its controllers.
#[derive(Debug, Clone)]
pub struct Controller {
    /// Who drives the camera now.
    pub mode: Mode,
    /// Eye (fly mode).
    pub position: Vec3,
    /// Heading, radians from +Z towards +X.
    pub yaw: f32,
    /// Radians above the horizon.
    pub pitch: f32,
    /// Vertical field of view, degrees.
    pub fov_deg: f32,
    /// Fly speed, m/s (the wheel scales it).
    pub speed: f32,
    /// Orbit centre.
    pub orbit_target: Vec3,
    /// Orbit radius, metres.
    pub orbit_distance: f32,
    /// The picked tree (index into the scene's trees), if any.
    pub picked: Option<usize>,
    /// Keys held.
    pub held: Held,
    /// The camera path to play.
    pub path: Option<CameraPath>,
    /// Where on the path (seconds).
    pub path_time: f32,
    recording: Option<(f32, Vec<CameraKey>)>,
    record_clock: f32,
}

impl Controller {
    /// A fly camera at `camera`.
    pub fn new(camera: Camera) -> Self {
        let mut c = Self {
            mode: Mode::Fly,
            position: camera.position,
            yaw: 0.0,
            pitch: 0.0,
            fov_deg: camera.fov_deg,
            speed: 20.0,
            orbit_target: camera.look_at,
            orbit_distance: camera.position.distance(camera.look_at).max(1.0),
            picked: None,
            held: Held::default(),
            path: None,
            path_time: 0.0,
            recording: None,
            record_clock: 0.0,
        };
        c.look_along(camera.look_at - camera.position);
        c
    }

    fn look_along(&mut self, dir: Vec3) {
        let d = dir.normalize_or(Vec3::Z);
        self.yaw = d.x.atan2(d.z);
        self.pitch = d.y.clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH);
    }

    fn forward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(cp * sy, sp, cp * cy)
    }

    /// The camera to render now.
    pub fn camera(&self) -> Camera {
        match self.mode {
            Mode::Fly => Camera {
                position: self.position,
                look_at: self.position + self.forward() * 10.0,
                fov_deg: self.fov_deg,
            },
            Mode::Orbit => Camera {
                position: self.orbit_target - self.forward() * self.orbit_distance,
                look_at: self.orbit_target,
                fov_deg: self.fov_deg,
            },
            Mode::Path => match &self.path {
                Some(p) => p.sample(self.path_time),
                None => Camera {
                    position: self.position,
                    look_at: self.position + self.forward() * 10.0,
                    fov_deg: self.fov_deg,
                },
            },
        }
    }

    /// Switches mode, starting the new one from the current camera.
    pub fn set_mode(&mut self, mode: Mode) {
        if mode == self.mode || (mode == Mode::Path && self.path.is_none()) {
            return;
        }
        let cam = self.camera();
        self.mode = mode;
        match mode {
            Mode::Fly => {
                self.position = cam.position;
                self.fov_deg = cam.fov_deg;
                self.look_along(cam.look_at - cam.position);
            }
            Mode::Orbit => {
                self.orbit_distance = cam.position.distance(self.orbit_target).max(1.0);
                self.look_along(self.orbit_target - cam.position);
            }
            Mode::Path => self.path_time = 0.0,
        }
    }

    /// Orbits around `target` (a picked tree's crown), from where the camera is now.
    pub fn orbit_around(&mut self, target: Vec3, tree: Option<usize>) {
        let eye = self.camera().position;
        self.mode = Mode::Orbit;
        self.orbit_target = target;
        self.picked = tree;
        self.orbit_distance = eye.distance(target).clamp(2.0, 5000.0);
        self.look_along(target - eye);
    }

    /// Mouse movement in pixels while looking (fly) or dragging (orbit).
    pub fn mouse_drag(&mut self, dx: f32, dy: f32) {
        const RADIANS_PER_PIXEL: f32 = 0.004;
        self.yaw -= dx * RADIANS_PER_PIXEL;
        self.pitch = (self.pitch - dy * RADIANS_PER_PIXEL).clamp(-MAX_PITCH, MAX_PITCH);
        if self.mode == Mode::Path {
            self.set_mode(Mode::Fly);
        }
    }

    /// Wheel notches (positive = away from the user): fly speed, or orbit distance.
    pub fn wheel(&mut self, notches: f32) {
        match self.mode {
            Mode::Orbit => {
                self.orbit_distance =
                    (self.orbit_distance * 0.85f32.powf(notches)).clamp(2.0, 5000.0)
            }
            _ => {
                self.speed =
                    (self.speed * 1.25f32.powf(notches)).clamp(SPEED_RANGE.0, SPEED_RANGE.1)
            }
        }
    }

    /// Advances by `dt` seconds: flies with the held keys, plays the path, records keys.
    pub fn update(&mut self, dt: f32) {
        let dt = dt.clamp(0.0, MAX_STEP_S);
        let h = self.held;
        let axis = |p: bool, n: bool| (p as i32 - n as i32) as f32;
        let (f, r, u) = (
            axis(h.forward, h.back),
            axis(h.right, h.left),
            axis(h.up, h.down),
        );
        if (f, r, u) != (0.0, 0.0, 0.0) {
            if self.mode != Mode::Fly {
                self.set_mode(Mode::Fly);
            }
            let fwd = self.forward();
            let right = fwd.cross(Vec3::Y).normalize_or(Vec3::X);
            let speed = self.speed * if h.fast { 4.0 } else { 1.0 };
            self.position += (fwd * f + right * r + Vec3::Y * u) * speed * dt;
        }
        if self.mode == Mode::Path
            && let Some(p) = &self.path
        {
            let d = p.duration();
            self.path_time = if d > 0.0 {
                (self.path_time + dt) % d
            } else {
                0.0
            };
        }
        self.record_clock += dt;
        let now = self.record_clock;
        let cam = self.camera();
        if let Some((start, keys)) = &mut self.recording {
            let t = now - *start;
            if keys.last().is_none_or(|k| t - k.t >= RECORD_INTERVAL_S) {
                keys.push(CameraKey { t, camera: cam });
            }
        }
    }

    /// Starts recording the camera (a key every [`RECORD_INTERVAL_S`] of camera time).
    pub fn start_recording(&mut self) {
        self.recording = Some((
            self.record_clock,
            vec![CameraKey {
                t: 0.0,
                camera: self.camera(),
            }],
        ));
    }

    /// Whether a recording runs, and how many keys it has.
    pub fn recording_keys(&self) -> Option<usize> {
        self.recording.as_ref().map(|(_, k)| k.len())
    }

    /// Stops recording; the path (Catmull–Rom through the keys) when it has at least two keys.
    pub fn stop_recording(&mut self) -> Option<CameraPath> {
        let (_, mut keys) = self.recording.take()?;
        let now = self.record_clock;
        keys.retain(|k| k.camera.position != k.camera.look_at);
        if let Some(last) = keys.last()
            && keys.len() == 1
            && now > last.t
        {
            let camera = last.camera;
            keys.push(CameraKey { t: now, camera });
        }
        (keys.len() >= 2).then_some(CameraPath {
            interpolation: Interpolation::CatmullRom,
            keys,
        })
    }
}

/// The world-space ray through normalised window coordinates (`x`, `y` in [0, 1], y down) of a
/// view with clip matrix `view_proj` (reversed Z: depth 1 at the near plane).
pub fn ray_through(view_proj: Mat4, x: f32, y: f32) -> (Vec3, Vec3) {
    let inv = view_proj.inverse();
    let (nx, ny) = (x * 2.0 - 1.0, 1.0 - y * 2.0);
    let unproject = |z: f32| {
        let p = inv * Vec4::new(nx, ny, z, 1.0);
        p.truncate() / p.w
    };
    let near = unproject(1.0);
    let further = unproject(0.5);
    (near, (further - near).normalize_or(Vec3::NEG_Z))
}

/// The tree whose crown (a sphere around the upper half of the tree) the ray hits first.
pub fn pick_tree(origin: Vec3, dir: Vec3, trees: &[TreeInstance]) -> Option<usize> {
    let mut best: Option<(f32, usize)> = None;
    for (i, t) in trees.iter().enumerate() {
        let centre = t.position + Vec3::Y * (t.height * 0.6);
        let radius = t.height * 0.35;
        let oc = centre - origin;
        let along = oc.dot(dir);
        if along <= 0.0 {
            continue;
        }
        if oc.length_squared() - along * along <= radius * radius
            && best.is_none_or(|(d, _)| along < d)
        {
            best = Some((along, i));
        }
    }
    best.map(|(_, i)| i)
}

/// Where the orbit centre of tree `t` is (its crown).
pub fn crown(t: &TreeInstance) -> Vec3 {
    t.position + Vec3::Y * (t.height * 0.6)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera {
            position: Vec3::new(0.0, 10.0, 0.0),
            look_at: Vec3::new(0.0, 10.0, 100.0),
            fov_deg: 50.0,
        }
    }

    #[test]
    fn starts_where_the_scene_camera_is_and_flies_forward() {
        let mut c = Controller::new(cam());
        let start = c.camera();
        assert!(start.position.abs_diff_eq(cam().position, 1e-5));
        let dir = (start.look_at - start.position).normalize();
        assert!(dir.abs_diff_eq(Vec3::Z, 1e-5), "{dir}");
        c.speed = 10.0;
        c.held.forward = true;
        for _ in 0..10 {
            c.update(0.05);
        }
        assert!(
            c.position.abs_diff_eq(Vec3::new(0.0, 10.0, 5.0), 1e-4),
            "{}",
            c.position
        );
        // A huge frame time is clamped: no teleport.
        c.update(10.0);
        assert!((c.position.z - 6.0).abs() < 1e-4, "{}", c.position);
        c.held = Held {
            right: true,
            ..Held::default()
        };
        c.update(0.1);
        // Facing +Z with Y up, right is -X.
        assert!(c.position.x < -0.9, "{}", c.position);
    }

    #[test]
    fn mouse_right_turns_right_and_wheel_scales_speed() {
        let mut c = Controller::new(cam());
        c.mouse_drag(100.0, 0.0);
        let dir = c.camera().look_at - c.camera().position;
        assert!(dir.x < 0.0, "turned towards -X (right): {dir}");
        let s = c.speed;
        c.wheel(2.0);
        assert!((c.speed - s * 1.5625).abs() < 1e-3);
        c.wheel(-1000.0);
        assert_eq!(c.speed, SPEED_RANGE.0);
    }

    #[test]
    fn orbit_keeps_the_target_centred() {
        let mut c = Controller::new(cam());
        let target = Vec3::new(0.0, 5.0, 50.0);
        c.orbit_around(target, Some(3));
        let a = c.camera();
        assert_eq!(a.look_at, target);
        let d = a.position.distance(target);
        c.mouse_drag(300.0, 0.0);
        let b = c.camera();
        assert!((b.position.distance(target) - d).abs() < 1e-3);
        assert!(b.position.distance(a.position) > 1.0);
        c.wheel(1.0);
        assert!(c.camera().position.distance(target) < d);
    }

    #[test]
    fn records_and_plays_back_a_path() {
        let mut c = Controller::new(cam());
        c.start_recording();
        c.held.forward = true;
        for _ in 0..20 {
            c.update(0.05);
        }
        let path = c.stop_recording().expect("a path");
        assert!(path.keys.len() >= 4, "{}", path.keys.len());
        assert!((path.duration() - 1.0).abs() < 0.06, "{}", path.duration());
        let end = path.sample(path.duration());
        assert!(end.position.z > 15.0, "{}", end.position);
        c.path = Some(path);
        c.set_mode(Mode::Path);
        c.held = Held::default();
        assert!(c.camera().position.abs_diff_eq(cam().position, 1e-4));
    }

    #[test]
    fn picks_the_nearest_tree_on_the_ray() {
        let tree = |z: f32| TreeInstance {
            position: Vec3::new(0.0, 0.0, z),
            height: 10.0,
            rotation: 0.0,
            species: 0,
            seed: 0,
        };
        let trees = [tree(50.0), tree(20.0), tree(-20.0)];
        let origin = Vec3::new(0.0, 6.0, 0.0);
        assert_eq!(pick_tree(origin, Vec3::Z, &trees), Some(1));
        assert_eq!(pick_tree(origin, Vec3::X, &trees), None);
        let view = sylvan_render::frame::View {
            eye: origin,
            target: Vec3::new(0.0, 6.0, 10.0),
            fov_y: 1.0,
            aspect: 1.5,
            near: 0.25,
            far: 1000.0,
        };
        let (o, d) = ray_through(view.view_proj(), 0.5, 0.5);
        assert!(o.abs_diff_eq(origin, 0.5), "{o}");
        assert!(d.abs_diff_eq(Vec3::Z, 1e-3), "{d}");
    }
}
