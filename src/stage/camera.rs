//! A perspective camera from the scene file, with near and far planes fitted to the scene's
//! bounds so depth precision goes where the hair is.

use crate::scene::CameraDesc;
use glam::{DVec3, Mat4};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: DVec3,
    pub target: DVec3,
    pub up: DVec3,
    /// Vertical field of view, radians.
    pub fov_y: f64,
}

impl Camera {
    pub fn from_desc(d: &CameraDesc) -> Camera {
        Camera {
            eye: DVec3::from(d.eye),
            target: DVec3::from(d.target),
            up: DVec3::from(d.up),
            fov_y: d.fov_y.to_radians(),
        }
    }

    /// Near and far planes enclosing a sphere of `radius` about `center`.
    pub fn clip_planes(&self, center: DVec3, radius: f64) -> (f64, f64) {
        let fwd = (self.target - self.eye).normalize();
        let dist = (center - self.eye).dot(fwd);
        let far = (dist + radius * 1.05).max(1e-3);
        let near = (dist - radius * 1.05).max(far * 1e-3);
        (near, far)
    }

    /// View-projection for an aspect ratio (width / height), wgpu depth range 0..1.
    pub fn view_proj(&self, aspect: f64, near: f64, far: f64) -> Mat4 {
        use glam::dcamera::rh;
        let view = rh::view::look_at_mat4(self.eye, self.target, self.up);
        let proj = rh::proj::directx::perspective(self.fov_y, aspect, near, far);
        (proj * view).as_mat4()
    }

    /// Focal length in pixels for an image `height` pixels tall: a world length l at
    /// distance z covers l * focal / z pixels.
    pub fn focal_px(&self, height: u32) -> f64 {
        0.5 * height as f64 / (0.5 * self.fov_y).tan()
    }
}
