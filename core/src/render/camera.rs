//! The perspective camera and its projection to pixels.

use crate::input::{fmt_num, fmt_vec};
use glam::{DMat4, DVec2, DVec3};

use super::{RenderError, MAX_DIMENSION};

/// A pinhole perspective camera, in scene units (world space).
///
/// The camera sits at `position` and looks at `target`; `up` fixes the roll (it need not be
/// perpendicular to the view direction, only not parallel to it). `vertical_fov_deg` is the full
/// vertical field of view; the horizontal one follows from the aspect ratio `width / height`.
///
/// Pixel coordinates run from (0, 0) at the top-left corner of the image to (`width`, `height`)
/// at the bottom-right corner; pixel (i, j) covers [i, i + 1) × [j, j + 1) and its centre is
/// (i + ½, j + ½). A view-space point (x right, y up, d forward) projects to
///
/// u = W/2 · (1 + x / (d · tan(φh/2))),  v = H/2 · (1 − y / (d · tan(φv/2))),
///
/// with tan(φh/2) = tan(φv/2) · W/H.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// The eye point.
    pub position: DVec3,
    /// A point on the optical axis; the image centre looks at it.
    pub target: DVec3,
    /// The world direction that appears upwards in the image (need not be unit or orthogonal to
    /// the view direction, but must not be parallel to it).
    pub up: DVec3,
    /// Full vertical field of view in degrees, in (0, 180).
    pub vertical_fov_deg: f64,
    /// Image width in pixels, in 1..=[`MAX_DIMENSION`].
    pub width: u32,
    /// Image height in pixels, in 1..=[`MAX_DIMENSION`].
    pub height: u32,
}

/// The camera's orthonormal frame and projection constants, derived once per render.
#[derive(Debug, Clone, Copy)]
pub(crate) struct CameraFrame {
    pub position: DVec3,
    pub right: DVec3,
    pub up: DVec3,
    pub forward: DVec3,
    /// tan(φh/2).
    pub tan_half_h: f64,
    /// tan(φv/2).
    pub tan_half_v: f64,
    pub width: f64,
    pub height: f64,
}

impl CameraFrame {
    /// View-space coordinates (x right, y up, d forward) of a world point.
    #[inline]
    pub fn world_to_view(&self, p: DVec3) -> DVec3 {
        let r = p - self.position;
        DVec3::new(r.dot(self.right), r.dot(self.up), r.dot(self.forward))
    }

    /// Homogeneous clip coordinates (x / tan(φh/2), y / tan(φv/2), d) of a view-space point: the
    /// visible frustum is |xc| ≤ w, |yc| ≤ w with w = d.
    #[inline]
    pub fn view_to_clip(&self, v: DVec3) -> DVec3 {
        DVec3::new(v.x / self.tan_half_h, v.y / self.tan_half_v, v.z)
    }

    /// Pixel coordinates of a clip-space point with w > 0.
    #[inline]
    pub fn clip_to_pixel(&self, c: DVec3) -> DVec2 {
        DVec2::new(0.5 * self.width * (1.0 + c.x / c.z), 0.5 * self.height * (1.0 - c.y / c.z))
    }
}

impl Camera {
    /// A camera that frames an object whose axis-aligned bounds are `bounds_min`..`bounds_max`,
    /// looking along `view_direction` (from the camera towards the object, need not be unit).
    ///
    /// The camera aims at the centre c of the box and backs off until the box's bounding sphere
    /// (radius r = ½ |max − min|) just fits the narrower of the two fields of view:
    ///
    /// position = c − (r / sin(φ/2)) · d̂,  φ = min(φv, φh),  tan(φh/2) = tan(φv/2) · W/H.
    ///
    /// The sphere touches the image border only in the narrower direction, so the object itself
    /// keeps a margin. When `up` is parallel to the view direction another axis is used (world
    /// +Y, or +Z when looking along Y), so any non-zero `up` gives a valid camera.
    ///
    /// # Errors
    /// - [`RenderError::InvalidBounds`]: a NaN or infinite corner, `min > max` on some axis, or
    ///   zero extent (a single point);
    /// - [`RenderError::InvalidCamera`]: a zero or non-finite `view_direction` or `up`, a field
    ///   of view outside (0°, 180°);
    /// - [`RenderError::InvalidSize`]: `width` or `height` outside 1..=[`MAX_DIMENSION`].
    pub fn frame(
        bounds_min: DVec3,
        bounds_max: DVec3,
        view_direction: DVec3,
        up: DVec3,
        vertical_fov_deg: f64,
        width: u32,
        height: u32,
    ) -> Result<Camera, RenderError> {
        let bounds_err = |requirement| RenderError::InvalidBounds { min: bounds_min, max: bounds_max, requirement };
        if !bounds_min.is_finite() || !bounds_max.is_finite() {
            return Err(bounds_err("the corners must be finite"));
        }
        if bounds_min.cmpgt(bounds_max).any() {
            return Err(bounds_err("min must not exceed max on any axis"));
        }
        let radius = 0.5 * (bounds_max - bounds_min).length();
        if radius <= 0.0 {
            return Err(bounds_err("the bounds must have a non-zero extent"));
        }
        check_size(width, height)?;
        check_fov(vertical_fov_deg)?;
        let forward = unit_direction("view_direction", view_direction)?;
        let up = unit_direction("up", up)?;
        let up = if up.cross(forward).length_squared() < 1e-12 {
            if forward.y.abs() < 0.9 {
                DVec3::Y
            } else {
                DVec3::Z
            }
        } else {
            up
        };
        let tan_half_v = (0.5 * vertical_fov_deg.to_radians()).tan();
        let tan_half_h = tan_half_v * f64::from(width) / f64::from(height);
        let half_angle = tan_half_v.min(tan_half_h).atan();
        let distance = radius / half_angle.sin();
        let centre = 0.5 * (bounds_min + bounds_max);
        Ok(Camera { position: centre - distance * forward, target: centre, up, vertical_fov_deg, width, height })
    }

    /// Checks every field.
    ///
    /// # Errors
    /// [`RenderError::InvalidSize`] for a width or height outside 1..=[`MAX_DIMENSION`];
    /// [`RenderError::InvalidCamera`] for a non-finite position, target or up, a target equal to
    /// the position, an up parallel to the view direction, or a field of view outside
    /// (0°, 180°).
    pub fn validate(&self) -> Result<(), RenderError> {
        self.derive().map(|_| ())
    }

    /// The world-to-view matrix (right-handed, looking down −Z, as `DMat4::look_at_rh`): view
    /// space has x right, y up and the camera looking along −z.
    ///
    /// # Errors
    /// As [`validate`](Self::validate).
    pub fn view_matrix(&self) -> Result<DMat4, RenderError> {
        let f = self.derive()?;
        Ok(DMat4::look_to_rh(f.position, f.forward, f.up))
    }

    /// Pixel coordinates (u, v) of a world point, or `None` when the point is not in front of
    /// the camera (view depth ≤ 0). Points outside the image give coordinates outside
    /// [0, W] × [0, H].
    ///
    /// # Errors
    /// As [`validate`](Self::validate).
    pub fn project(&self, point: DVec3) -> Result<Option<DVec2>, RenderError> {
        let f = self.derive()?;
        let v = f.world_to_view(point);
        Ok((v.z > 0.0).then(|| f.clip_to_pixel(f.view_to_clip(v))))
    }

    /// The unit world direction of the ray from the eye through the pixel-space point (u, v)
    /// (e.g. (i + ½, j + ½) for the centre of pixel (i, j)); the inverse of
    /// [`project`](Self::project).
    ///
    /// # Errors
    /// As [`validate`](Self::validate).
    pub fn ray_direction(&self, u: f64, v: f64) -> Result<DVec3, RenderError> {
        let f = self.derive()?;
        let x = (2.0 * u / f.width - 1.0) * f.tan_half_h;
        let y = (1.0 - 2.0 * v / f.height) * f.tan_half_v;
        Ok((f.forward + x * f.right + y * f.up).normalize())
    }

    /// Validates and derives the orthonormal frame.
    pub(crate) fn derive(&self) -> Result<CameraFrame, RenderError> {
        check_size(self.width, self.height)?;
        check_fov(self.vertical_fov_deg)?;
        for (field, v) in [("position", self.position), ("target", self.target), ("up", self.up)] {
            if !v.is_finite() {
                return Err(camera_err(field, v, "must be finite"));
            }
        }
        let axis = self.target - self.position;
        let forward =
            axis.try_normalize().ok_or_else(|| camera_err("target", self.target, "must differ from the camera position"))?;
        let right = forward.cross(self.up);
        if right.length_squared() <= 1e-24 * self.up.length_squared().max(f64::MIN_POSITIVE) {
            return Err(camera_err("up", self.up, "must be non-zero and not parallel to the view direction (target − position)"));
        }
        let right = right.normalize();
        let up = right.cross(forward);
        let tan_half_v = (0.5 * self.vertical_fov_deg.to_radians()).tan();
        let (width, height) = (f64::from(self.width), f64::from(self.height));
        Ok(CameraFrame {
            position: self.position,
            right,
            up,
            forward,
            tan_half_h: tan_half_v * width / height,
            tan_half_v,
            width,
            height,
        })
    }
}

fn camera_err(field: &'static str, value: DVec3, requirement: &'static str) -> RenderError {
    RenderError::InvalidCamera { field, value: fmt_vec(&value.to_array()), requirement }
}

fn check_size(width: u32, height: u32) -> Result<(), RenderError> {
    let ok = |n: u32| (1..=MAX_DIMENSION).contains(&n);
    if ok(width) && ok(height) {
        Ok(())
    } else {
        Err(RenderError::InvalidSize { width, height, max: MAX_DIMENSION })
    }
}

fn check_fov(fov: f64) -> Result<(), RenderError> {
    if fov.is_finite() && fov > 0.0 && fov < 180.0 {
        Ok(())
    } else {
        Err(RenderError::InvalidCamera {
            field: "vertical_fov_deg",
            value: fmt_num(fov),
            requirement: "the field of view must be finite and strictly between 0 and 180 degrees",
        })
    }
}

fn unit_direction(field: &'static str, v: DVec3) -> Result<DVec3, RenderError> {
    if !v.is_finite() {
        return Err(camera_err(field, v, "must be finite"));
    }
    v.try_normalize().ok_or_else(|| camera_err(field, v, "must be non-zero"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera {
            position: DVec3::new(0.0, 0.0, 5.0),
            target: DVec3::ZERO,
            up: DVec3::Y,
            vertical_fov_deg: 90.0,
            width: 200,
            height: 100,
        }
    }

    #[test]
    fn target_projects_to_the_image_centre() {
        let p = cam().project(DVec3::ZERO).unwrap().unwrap();
        assert!((p - DVec2::new(100.0, 50.0)).length() < 1e-12);
    }

    #[test]
    fn fov_edge_projects_to_the_image_border() {
        // 90° vertical fov: tan 45° = 1, so y = d at depth d is the top edge (v = 0).
        let c = cam();
        let top = c.project(DVec3::new(0.0, 5.0, 0.0)).unwrap().unwrap();
        assert!((top - DVec2::new(100.0, 0.0)).length() < 1e-12, "{top}");
        // Horizontal half-angle tangent is 2 (aspect 2): x = 2d is the right edge.
        let right = c.project(DVec3::new(10.0, 0.0, 0.0)).unwrap().unwrap();
        assert!((right - DVec2::new(200.0, 50.0)).length() < 1e-12, "{right}");
        assert!(c.project(DVec3::new(0.0, 0.0, 6.0)).unwrap().is_none());
    }

    #[test]
    fn ray_direction_inverts_project() {
        let c = Camera { up: DVec3::new(0.3, 1.0, 0.1), ..cam() };
        for &(u, v) in &[(0.5, 0.5), (13.25, 80.0), (199.0, 1.0)] {
            let d = c.ray_direction(u, v).unwrap();
            let p = c.project(c.position + 7.0 * d).unwrap().unwrap();
            assert!((p - DVec2::new(u, v)).length() < 1e-9, "{u},{v} -> {p}");
        }
    }

    #[test]
    fn view_matrix_matches_look_at() {
        let c = cam();
        let m = c.view_matrix().unwrap();
        let expect = DMat4::look_at_rh(c.position, c.target, c.up);
        assert!(m.abs_diff_eq(expect, 1e-12));
    }

    #[test]
    fn frame_fits_the_bounding_sphere() {
        let (lo, hi) = (DVec3::splat(-1.0), DVec3::splat(1.0));
        let c = Camera::frame(lo, hi, DVec3::new(0.0, 0.0, -2.0), DVec3::Y, 60.0, 300, 200).unwrap();
        let r = 3f64.sqrt();
        // Narrower (vertical) half-angle 30°: distance r / sin 30° = 2r.
        assert!((c.position - DVec3::new(0.0, 0.0, 2.0 * r)).length() < 1e-12);
        assert_eq!(c.target, DVec3::ZERO);
        // A portrait image is limited by the horizontal field of view instead.
        let p = Camera::frame(lo, hi, DVec3::NEG_Z, DVec3::Y, 60.0, 100, 200).unwrap();
        let half_h = ((30f64).to_radians().tan() * 0.5).atan();
        assert!((p.position.z - r / half_h.sin()).abs() < 1e-12);
        // Every box corner projects inside the image.
        for corner in 0..8 {
            let q = DVec3::new(
                if corner & 1 == 0 { -1.0 } else { 1.0 },
                if corner & 2 == 0 { -1.0 } else { 1.0 },
                if corner & 4 == 0 { -1.0 } else { 1.0 },
            );
            let px = p.project(q).unwrap().unwrap();
            assert!((0.0..=100.0).contains(&px.x) && (0.0..=200.0).contains(&px.y), "{px}");
        }
    }

    #[test]
    fn frame_replaces_a_parallel_up() {
        let c = Camera::frame(DVec3::ZERO, DVec3::ONE, DVec3::NEG_Y, DVec3::Y, 40.0, 10, 10).unwrap();
        assert!(c.validate().is_ok());
        let c = Camera::frame(DVec3::ZERO, DVec3::ONE, DVec3::X, DVec3::X, 40.0, 10, 10).unwrap();
        assert_eq!(c.up, DVec3::Y);
    }

    #[test]
    fn invalid_cameras_are_rejected() {
        let bad_fov = |fov| Camera { vertical_fov_deg: fov, ..cam() }.validate().unwrap_err().to_string();
        for fov in [0.0, -10.0, 180.0, 200.0, f64::NAN] {
            assert!(bad_fov(fov).contains("vertical_fov_deg"), "{}", bad_fov(fov));
        }
        let e = Camera { width: 0, ..cam() }.validate().unwrap_err();
        assert!(matches!(e, RenderError::InvalidSize { width: 0, .. }));
        let e = Camera { height: MAX_DIMENSION + 1, ..cam() }.validate().unwrap_err();
        assert!(matches!(e, RenderError::InvalidSize { .. }));
        let e = Camera { target: cam().position, ..cam() }.validate().unwrap_err();
        assert!(e.to_string().contains("target"), "{e}");
        let e = Camera { up: DVec3::Z, ..cam() }.validate().unwrap_err();
        assert!(e.to_string().contains("up"), "{e}");
        let e = Camera { up: DVec3::ZERO, ..cam() }.validate().unwrap_err();
        assert!(e.to_string().contains("up"), "{e}");
        let e = Camera { position: DVec3::new(f64::NAN, 0.0, 0.0), ..cam() }.validate().unwrap_err();
        assert!(e.to_string().contains("position"), "{e}");
        let e = Camera::frame(DVec3::ONE, DVec3::ZERO, DVec3::Z, DVec3::Y, 40.0, 10, 10).unwrap_err();
        assert!(matches!(e, RenderError::InvalidBounds { .. }), "{e}");
        let e = Camera::frame(DVec3::ONE, DVec3::ONE, DVec3::Z, DVec3::Y, 40.0, 10, 10).unwrap_err();
        assert!(matches!(e, RenderError::InvalidBounds { .. }), "{e}");
        let e = Camera::frame(DVec3::ZERO, DVec3::ONE, DVec3::ZERO, DVec3::Y, 40.0, 10, 10).unwrap_err();
        assert!(e.to_string().contains("view_direction"), "{e}");
    }
}
