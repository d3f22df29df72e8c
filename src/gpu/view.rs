//! View math shared by the stage, the viewer and the kinds' mouse tools: a perspective
//! camera (near and far planes fitted to the scene's bounds so depth precision goes where
//! the hair is) and a projection onto a viewport in pixels. Plain glam math; it lives in the
//! leaf so systems can project without importing the stage (`stage::camera` reads a
//! `Camera` from the scene file).

use glam::{DMat4, DVec2, DVec3, DVec4, Mat4};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: DVec3,
    pub target: DVec3,
    pub up: DVec3,
    /// Vertical field of view, radians.
    pub fov_y: f64,
}

impl Camera {
    /// Near and far planes enclosing a sphere of `radius` about `center`.
    pub fn clip_planes(&self, center: DVec3, radius: f64) -> (f64, f64) {
        let fwd = (self.target - self.eye).normalize();
        let dist = (center - self.eye).dot(fwd);
        let far = (dist + radius * 1.05).max(1e-3);
        let near = (dist - radius * 1.05).max(far * 1e-3);
        (near, far)
    }

    /// View-projection in f64 for an aspect ratio (width / height), wgpu depth range 0..1.
    pub fn view_proj_f64(&self, aspect: f64, near: f64, far: f64) -> DMat4 {
        use glam::dcamera::rh;
        let view = rh::view::look_at_mat4(self.eye, self.target, self.up);
        let proj = rh::proj::directx::perspective(self.fov_y, aspect, near, far);
        proj * view
    }

    /// The same as the f32 matrix the shaders see.
    pub fn view_proj(&self, aspect: f64, near: f64, far: f64) -> Mat4 {
        self.view_proj_f64(aspect, near, far).as_mat4()
    }

    /// Focal length in pixels for an image `height` pixels tall: a world length l at
    /// distance z covers l * focal / z pixels.
    pub fn focal_px(&self, height: u32) -> f64 {
        0.5 * height as f64 / (0.5 * self.fov_y).tan()
    }
}

/// Where points land on screen: `mvp` takes a point (in the model's frame) to clip space
/// (wgpu: depth 0..1), and the viewport is `size` pixels, origin top left, y down. The
/// viewer hands the kinds' mouse tools and overlays two of these each frame: with the
/// head's pose and without it (`systems::ui::Host`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenView {
    pub mvp: DMat4,
    pub size: DVec2,
}

impl ScreenView {
    pub fn new(mvp: DMat4, size: DVec2) -> ScreenView {
        ScreenView { mvp, size }
    }

    /// The viewer's view: `camera` (near and far planes fitted to `bounds` as the stage
    /// does), the model pose `model`, a viewport `size` pixels. The view-projection is the
    /// stage's own (`Camera::view_proj`) kept in f64: a point lands where it is drawn (to
    /// f32 rounding), and a node dragged in a plane parallel to the screen stays in it
    /// (`tests/it/wisps_edit.rs`; the f32 matrix moved it by 1e-9 of its depth).
    pub fn from_camera(
        camera: &Camera,
        model: DMat4,
        size: DVec2,
        bounds: (DVec3, f64),
    ) -> ScreenView {
        let (near, far) = camera.clip_planes(bounds.0, bounds.1);
        let aspect = size.x / size.y.max(1e-9);
        ScreenView {
            mvp: camera.view_proj_f64(aspect, near, far) * model,
            size,
        }
    }

    /// (x, y) in pixels and the depth (normalised device z) of `p`; None behind the eye or
    /// when not finite.
    pub fn project(&self, p: DVec3) -> Option<DVec3> {
        let c = self.mvp * p.extend(1.0);
        if c.w.is_nan() || c.w <= 1e-12 {
            return None;
        }
        let n = c.truncate() / c.w;
        let out = DVec3::new(
            (n.x + 1.0) * 0.5 * self.size.x,
            (1.0 - n.y) * 0.5 * self.size.y,
            n.z,
        );
        out.is_finite().then_some(out)
    }

    /// The point at pixel `px` and normalised depth `depth` (the inverse of `project`).
    pub fn unproject(&self, px: DVec2, depth: f64) -> Option<DVec3> {
        let ndc = DVec4::new(
            px.x / self.size.x * 2.0 - 1.0,
            1.0 - px.y / self.size.y * 2.0,
            depth,
            1.0,
        );
        let c = self.mvp.inverse() * ndc;
        if c.w.abs() < 1e-300 {
            return None;
        }
        let p = c.truncate() / c.w;
        p.is_finite().then_some(p)
    }

    /// World units per pixel at `p`, across the screen (None behind the eye).
    pub fn units_per_px(&self, p: DVec3) -> Option<f64> {
        let s = self.project(p)?;
        let a = self.unproject(s.truncate(), s.z)?;
        let b = self.unproject(s.truncate() + DVec2::X, s.z)?;
        let u = (b - a).length();
        (u.is_finite() && u > 0.0).then_some(u)
    }

    /// Radius in pixels of a sphere of radius `r` about `p` (for the overlays' circles).
    pub fn radius_px(&self, p: DVec3, r: f64) -> Option<f64> {
        Some(r / self.units_per_px(p)?)
    }
}
