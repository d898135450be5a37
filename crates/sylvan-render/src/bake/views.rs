//! Orthographic bake views and the planes they map onto, shared by the baker and the runtime
//! so that a texel baked at (s, t) is drawn at exactly the point it was seen from.

use glam::{Mat4, Vec3, Vec4};

/// A plane through a box's centre, with the rectangle the box projects to along its normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneFrame {
    /// Box centre (model space).
    pub centre: Vec3,
    /// Image right axis (unit, in the plane).
    pub u: Vec3,
    /// Image up axis (unit, in the plane).
    pub v: Vec3,
    /// Plane normal (unit); the "front" image is seen from `+f`.
    pub f: Vec3,
    /// Half extents of the box's projection along `u`, `v` and `f` (metres, at least 1 mm).
    pub half: Vec3,
}

impl PlaneFrame {
    /// The plane with normal `normal` through the centre of the box `min..max`, framing the
    /// box's orthographic projection tightly. `v` is world up projected into the plane (or +Z
    /// for horizontal planes); `u = v × f`, so the image is not mirrored when seen from `+f`.
    pub fn for_box(normal: Vec3, min: Vec3, max: Vec3) -> Self {
        let (u, v, f) = image_axes(normal);
        let h = ((max - min) * 0.5).max(Vec3::ZERO);
        let extent = |a: Vec3| (a.abs() * h).element_sum().max(1e-3);
        Self {
            centre: (min + max) * 0.5,
            u,
            v,
            f,
            half: Vec3::new(extent(u), extent(v), extent(f)),
        }
    }

    /// A square frame with normal `normal` enclosing the sphere of `radius` about `centre`:
    /// every direction's view of the sphere gets the same image scale and depth range (the
    /// image axes are those of [`PlaneFrame::for_box`]).
    pub fn for_sphere(normal: Vec3, centre: Vec3, radius: f32) -> Self {
        let (u, v, f) = image_axes(normal);
        Self {
            centre,
            u,
            v,
            f,
            half: Vec3::splat(radius.max(1e-3)),
        }
    }

    /// The orthographic projection that maps the framed rectangle to clip space, seen from the
    /// `+f` side (`side = 1`) or the `-f` side (`side = -1`). Both sides share the same image
    /// axes, so texel (s, t) of either image lies at the same point of the plane; depth 0 is the
    /// face nearest the camera, 1 the far face.
    pub fn view_proj(&self, side: f32) -> Mat4 {
        let c = self.centre;
        let row_x = (self.u / self.half.x).extend(-self.u.dot(c) / self.half.x);
        let row_y = (self.v / self.half.y).extend(-self.v.dot(c) / self.half.y);
        // z = (hf − side·f·(p − c)) / (2 hf)
        let k = -side / (2.0 * self.half.z);
        let row_z = (self.f * k).extend(0.5 - k * self.f.dot(c));
        let row_w = Vec4::new(0.0, 0.0, 0.0, 1.0);
        Mat4::from_cols(row_x, row_y, row_z, row_w).transpose()
    }

    /// Model-space point of image coordinates `(s, t)` in [0, 1]² (t = 0 at the top), on the
    /// plane.
    pub fn point(&self, s: f32, t: f32) -> Vec3 {
        self.centre
            + self.u * ((2.0 * s - 1.0) * self.half.x)
            + self.v * ((1.0 - 2.0 * t) * self.half.y)
    }
}

/// Image axes `(u, v, f)` of a plane with normal `normal`: `v` is world up projected into the
/// plane (or +Z for near-horizontal planes), `u = v × f`.
fn image_axes(normal: Vec3) -> (Vec3, Vec3, Vec3) {
    let f = normal.normalize();
    let up = if f.y.abs() < 0.99 { Vec3::Y } else { Vec3::Z };
    let v = (up - f * up.dot(f)).normalize();
    (v.cross(f), v, f)
}

/// Plane normals of LCV04's two arrangements.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PlaneLayout {
    /// Fig. 3: three axis-aligned planes through the box centre, an image per side (6 images).
    Axis,
    /// Fig. 6: six diagonally aligned planes, each containing one box axis and a diagonal of
    /// the faces across it; one image per plane, seen mirrored from behind (6 images).
    Diagonal,
    /// Not LCV04: the naive baseline — one image baked from +Z, drawn on a quad that turns
    /// about the vertical axis to face the viewer (a classic billboard).
    Billboard,
}

impl PlaneLayout {
    /// Both layouts, for parsing and tests.
    pub const ALL: [(&'static str, PlaneLayout); 3] = [
        ("axis", PlaneLayout::Axis),
        ("diagonal", PlaneLayout::Diagonal),
        ("billboard", PlaneLayout::Billboard),
    ];

    /// The plane normals.
    pub fn normals(self) -> Vec<Vec3> {
        let s = std::f32::consts::FRAC_1_SQRT_2;
        match self {
            PlaneLayout::Axis => vec![Vec3::X, Vec3::Y, Vec3::Z],
            PlaneLayout::Diagonal => vec![
                Vec3::new(s, 0.0, s),
                Vec3::new(s, 0.0, -s),
                Vec3::new(s, s, 0.0),
                Vec3::new(s, -s, 0.0),
                Vec3::new(0.0, s, s),
                Vec3::new(0.0, s, -s),
            ],
            PlaneLayout::Billboard => vec![Vec3::Z],
        }
    }

    /// The planes of the box `min..max`, as baked and drawn. A billboard frames the box's
    /// circumscribed vertical cylinder, so the quad covers the box from any azimuth.
    pub fn frames(self, min: Vec3, max: Vec3) -> Vec<PlaneFrame> {
        let (min, max) = match self {
            PlaneLayout::Billboard => {
                let c = (min + max) * 0.5;
                let h = (max - min) * 0.5;
                let r = h.x.hypot(h.z);
                (
                    Vec3::new(c.x - r, min.y, c.z - r),
                    Vec3::new(c.x + r, max.y, c.z + r),
                )
            }
            _ => (min, max),
        };
        self.normals()
            .into_iter()
            .map(|n| PlaneFrame::for_box(n, min, max))
            .collect()
    }

    /// Images baked per plane: 2 (front and back) for the axis cross, 1 for diagonal planes.
    pub fn sides(self) -> u32 {
        match self {
            PlaneLayout::Axis => 2,
            PlaneLayout::Diagonal | PlaneLayout::Billboard => 1,
        }
    }

    /// Images per box.
    pub fn images(self) -> u32 {
        self.normals().len() as u32 * self.sides()
    }

    /// The name used in flags and files.
    pub fn name(self) -> &'static str {
        match self {
            PlaneLayout::Axis => "axis",
            PlaneLayout::Diagonal => "diagonal",
            PlaneLayout::Billboard => "billboard",
        }
    }

    /// Parses `axis` or `diagonal`.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.iter().find(|(n, _)| *n == s).map(|(_, l)| *l)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_maps_box_to_unit_cube() {
        let (min, max) = (Vec3::new(-1.0, 0.0, -2.0), Vec3::new(3.0, 5.0, 1.0));
        for layout in [
            PlaneLayout::Axis,
            PlaneLayout::Diagonal,
            PlaneLayout::Billboard,
        ] {
            for p in layout.frames(min, max) {
                for side in [1.0f32, -1.0] {
                    let m = p.view_proj(side);
                    for i in 0..8 {
                        let c = Vec3::new(
                            if i & 1 == 0 { min.x } else { max.x },
                            if i & 2 == 0 { min.y } else { max.y },
                            if i & 4 == 0 { min.z } else { max.z },
                        );
                        let q = m.project_point3(c);
                        assert!(q.x.abs() <= 1.0001 && q.y.abs() <= 1.0001, "{q}");
                        assert!((-1e-4..=1.0001).contains(&q.z), "{q}");
                    }
                    // The camera-side face is at depth 0.
                    let near = p.centre + p.f * side * p.half.z;
                    assert!(m.project_point3(near).z.abs() < 1e-4);
                    // Image (s, t) ↔ clip (2s − 1, 1 − 2t) on both sides.
                    let q = m.project_point3(p.point(0.25, 0.75));
                    assert!((q.x + 0.5).abs() < 1e-4 && (q.y + 0.5).abs() < 1e-4, "{q}");
                }
                assert!((p.u.cross(p.v) - p.f).length() < 1e-5, "right-handed frame");
            }
        }
    }
}
