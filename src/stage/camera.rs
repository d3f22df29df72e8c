//! The scene file's camera. The camera's view math lives in `gpu::view` (systems project
//! with it without importing the stage); reading it from a scene is the stage's.

pub use crate::gpu::view::Camera;
use crate::scene::CameraDesc;
use glam::DVec3;

impl Camera {
    pub fn from_desc(d: &CameraDesc) -> Camera {
        Camera {
            eye: DVec3::from(d.eye),
            target: DVec3::from(d.target),
            up: DVec3::from(d.up),
            fov_y: d.fov_y.to_radians(),
        }
    }
}
