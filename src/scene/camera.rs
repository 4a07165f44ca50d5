//! A pinhole camera. The field of view is measured along the image's smaller axis
//! (Mitsuba's `fovAxis = smaller`), so the Cornell box camera matches Mitsuba's.

use glam::Vec3;

use super::config::CameraEntry;
use crate::error::{Error, Result};
use crate::geom::Ray;

#[derive(Clone, Debug)]
pub struct Camera {
    pub position: Vec3,
    pub forward: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub tan_half: f32,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// From a `[camera]` entry; errors name the key.
    pub fn from_entry(e: &CameraEntry, path: &std::path::Path) -> Result<Camera> {
        let bad = |key: &str, message: &str| Error::SceneValue {
            path: path.into(),
            key: format!("camera.{key}"),
            message: message.into(),
        };
        for (key, v) in [("position", e.position), ("target", e.target), ("up", e.up)] {
            if v.iter().any(|c| !c.is_finite()) {
                return Err(bad(key, &format!("{v:?} must be finite")));
            }
        }
        if !(e.fov > 0.0 && e.fov < 180.0) {
            return Err(bad("fov", "must be in (0, 180) degrees"));
        }
        for (key, v) in [("width", e.width), ("height", e.height)] {
            if v == 0 || v > 16384 {
                return Err(bad(key, &format!("{v} is outside 1..=16384 pixels")));
            }
        }
        let d = Vec3::from(e.target).as_dvec3() - Vec3::from(e.position).as_dvec3();
        let Some(forward) = crate::geom::unit_vector(d) else {
            return Err(bad("target", "must differ from position"));
        };
        let Some(up) = crate::geom::unit_vector(Vec3::from(e.up).as_dvec3()) else {
            return Err(bad("up", "has zero length"));
        };
        let right = forward.cross(up).normalize_or_zero();
        if right == Vec3::ZERO || forward.cross(up).length() < 1e-6 {
            return Err(bad("up", "must not be parallel to the viewing direction"));
        }
        Ok(Camera {
            position: e.position.into(),
            forward,
            right,
            up: right.cross(forward),
            tan_half: (e.fov.to_radians() * 0.5).tan(),
            width: e.width,
            height: e.height,
        })
    }

    /// A camera looking at a bounding box from its −z side.
    pub fn framing(lo: Vec3, hi: Vec3) -> Camera {
        let c = (lo + hi) * 0.5;
        let r = (hi - lo).length() * 0.5;
        let e = CameraEntry {
            position: (c - Vec3::Z * (r * 2.8)).into(),
            target: c.into(),
            up: [0.0, 1.0, 0.0],
            fov: 40.0,
            width: 256,
            height: 256,
        };
        Camera::from_entry(&e, std::path::Path::new("")).expect("a framing camera is valid")
    }

    /// The primary ray through the point `(px, py)` of the image (pixel units, y down).
    pub fn ray(&self, px: f32, py: f32) -> Ray {
        let m = self.width.min(self.height) as f32;
        let x = (2.0 * px - self.width as f32) / m * self.tan_half;
        let y = (self.height as f32 - 2.0 * py) / m * self.tan_half;
        Ray {
            o: self.position,
            d: (self.forward + self.right * x + self.up * y).normalize(),
        }
    }
}
