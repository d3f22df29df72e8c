//! Orbit camera for the viewer: orbit about a target, pan, zoom, and frame the scene. Starts
//! from the scene file's camera and can be written back into it when saving.

use crate::scene::CameraDesc;
use crate::stage::camera::Camera;
use glam::DVec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    pub target: DVec3,
    pub distance: f64,
    /// Azimuth about +y, radians.
    pub yaw: f64,
    /// Elevation, radians (kept short of the poles).
    pub pitch: f64,
    /// Vertical field of view, radians.
    pub fov_y: f64,
}

const PITCH_LIMIT: f64 = 1.5;

impl OrbitCamera {
    pub fn from_desc(d: &CameraDesc) -> OrbitCamera {
        let target = DVec3::from(d.target);
        let offset = DVec3::from(d.eye) - target;
        let distance = offset.length().max(1e-6);
        OrbitCamera {
            target,
            distance,
            yaw: offset.z.atan2(offset.x),
            pitch: (offset.y / distance)
                .clamp(-1.0, 1.0)
                .asin()
                .clamp(-PITCH_LIMIT, PITCH_LIMIT),
            fov_y: d.fov_y.to_radians(),
        }
    }

    pub fn eye(&self) -> DVec3 {
        let (sp, cp) = self.pitch.sin_cos();
        let (sy, cy) = self.yaw.sin_cos();
        self.target + self.distance * DVec3::new(cp * cy, sp, cp * sy)
    }

    pub fn camera(&self) -> Camera {
        Camera {
            eye: self.eye(),
            target: self.target,
            up: DVec3::Y,
            fov_y: self.fov_y,
        }
    }

    /// The scene-file form (for saving a tuned view).
    pub fn desc(&self) -> CameraDesc {
        let e = self.eye();
        CameraDesc {
            eye: [e.x, e.y, e.z],
            target: [self.target.x, self.target.y, self.target.z],
            up: [0.0, 1.0, 0.0],
            fov_y: self.fov_y.to_degrees(),
        }
    }

    /// Orbit by a mouse drag of (dx, dy) pixels.
    pub fn orbit(&mut self, dx: f64, dy: f64) {
        self.yaw += dx * 0.008;
        self.pitch = (self.pitch + dy * 0.008).clamp(-PITCH_LIMIT, PITCH_LIMIT);
    }

    /// Pan by a drag of (dx, dy) pixels in a view `height` pixels tall: the target point
    /// follows the cursor.
    pub fn pan(&mut self, dx: f64, dy: f64, height: f64) {
        let eye = self.eye();
        let fwd = (self.target - eye).normalize();
        let right = fwd.cross(DVec3::Y).normalize_or(DVec3::X);
        let up = right.cross(fwd);
        let per_px = 2.0 * self.distance * (0.5 * self.fov_y).tan() / height.max(1.0);
        self.target += (-dx * right + dy * up) * per_px;
    }

    /// Zoom: `steps` > 0 moves closer.
    pub fn zoom(&mut self, steps: f64) {
        self.distance = (self.distance * (-0.12 * steps).exp()).clamp(1e-3, 1e7);
    }

    /// Fit a bounding sphere in view.
    pub fn frame(&mut self, center: DVec3, radius: f64) {
        self.target = center;
        self.distance = radius.max(1e-6) / (0.5 * self.fov_y).sin() * 1.05;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_the_scene_camera_and_frames() {
        let d = CameraDesc {
            eye: [40.0, 10.0, 30.0],
            target: [0.0, -1.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y: 35.0,
        };
        let c = OrbitCamera::from_desc(&d);
        assert!((c.eye() - DVec3::from(d.eye)).length() < 1e-9);
        let mut f = c;
        f.frame(DVec3::new(1.0, 2.0, 3.0), 10.0);
        // The sphere fits the vertical field of view.
        let half = (10.0 / f.distance).asin();
        assert!(half <= 0.5 * f.fov_y + 1e-9);
        let mut z = c;
        z.zoom(3.0);
        assert!(z.distance < c.distance);
        let mut o = c;
        o.orbit(1e6, 1e6);
        assert!(o.pitch <= PITCH_LIMIT);
    }
}
