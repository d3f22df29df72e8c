//! The cameras and lights `kami bench look` renders each scene under, beside the scene's
//! own: a close-up where the hair fills most of the frame (whole-scene framing leaves half
//! the picture to the background, and a viewer judges hair up close), and a light from the
//! side and from behind (rim light and transmission, where a hair model is least tested).

use crate::error::{KamiError, Result};
use crate::formats::Groom;
use crate::scene::{CameraDesc, Light};
use crate::stage::camera::Camera;
use crate::systems::Scene;
use glam::DVec3;

/// A camera the bench renders from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    /// The scene file's camera.
    Scene,
    /// [`close_up`]: the scene camera's eye, turned and narrowed onto the hair.
    Close,
}

impl View {
    pub const ALL: [View; 2] = [View::Scene, View::Close];
    pub fn name(self) -> &'static str {
        match self {
            View::Scene => "scene",
            View::Close => "close",
        }
    }
    pub fn parse(s: &str) -> Option<View> {
        View::ALL.into_iter().find(|v| v.name() == s)
    }
}

/// A key light the bench renders under (the ambient stays the scene's).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lighting {
    /// The scene file's light.
    Key,
    /// From the camera's right, square to the view, a little above: [`lit`].
    Side,
    /// From behind the hair, a little above: a rim light, seen through the hair.
    Back,
}

impl Lighting {
    pub const ALL: [Lighting; 3] = [Lighting::Key, Lighting::Side, Lighting::Back];
    pub fn name(self) -> &'static str {
        match self {
            Lighting::Key => "key",
            Lighting::Side => "side",
            Lighting::Back => "back",
        }
    }
    pub fn parse(s: &str) -> Option<Lighting> {
        Lighting::ALL.into_iter().find(|v| v.name() == s)
    }
}

/// How far above the horizontal (along the camera's up) the side and back lights sit: tan
/// of about 17 degrees, enough that the back light grazes the crown rather than only the
/// silhouette.
pub const LIGHT_RISE: f64 = 0.3;

/// The camera's frame: forward, right and up (orthonormal; Mitsuba's and Kami's look-at).
fn frame(c: &CameraDesc) -> (DVec3, DVec3, DVec3) {
    let cam = Camera::from_desc(c);
    let fwd = (cam.target - cam.eye).normalize();
    let right = fwd.cross(cam.up).normalize();
    (fwd, right, right.cross(fwd))
}

/// The light of `lighting` for `scene` seen from `camera`: `direction` points towards the
/// light (as in the scene file), intensity, ambient and colour are the scene's.
pub fn lit(scene: &Scene, camera: &CameraDesc, lighting: Lighting) -> Light {
    let (fwd, right, up) = frame(camera);
    let towards = match lighting {
        Lighting::Key => return scene.light.clone(),
        Lighting::Side => right + LIGHT_RISE * up,
        Lighting::Back => fwd + LIGHT_RISE * up,
    }
    .normalize();
    Light {
        direction: towards.to_array(),
        ..scene.light.clone()
    }
}

/// The close-up window's size: this share of the hair's projected extent (its 5th to 95th
/// percentile box, the smaller side) fills the frame's height.
pub const CLOSE_SHARE: f64 = 0.5;

/// The value at quantile `q` of `v` (sorted in place).
fn quantile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// The close-up camera of `scene` for `groom` (Kami's strands at the compared frame) at
/// `aspect` (width / height): the scene camera's eye and up, turned towards the middle of
/// the hair's near side (the per-axis median, on screen, of the strand points nearer than
/// the median depth: the side the camera sees) and narrowed so [`CLOSE_SHARE`] of the
/// hair's projected extent fills the frame, the window kept inside that extent. Fails,
/// naming the scene, where fewer than 16 strand points are in the scene camera's frame.
pub fn close_up(scene: &Scene, groom: &Groom, aspect: f64, source: &str) -> Result<CameraDesc> {
    let c = &scene.camera;
    let (fwd, right, up) = frame(c);
    let eye = DVec3::from(c.eye);
    let t = (0.5 * c.fov_y.to_radians()).tan();
    // Normalised device coordinates (x right, y up, -1..1) and depth of every point in frame.
    let pts: Vec<(f64, f64, f64)> = groom
        .points
        .iter()
        .filter_map(|p| {
            let q = DVec3::from(p.map(f64::from)) - eye;
            let z = q.dot(fwd);
            let (x, y) = (q.dot(right) / (z * t * aspect), q.dot(up) / (z * t));
            (z > 0.0 && x.abs() <= 1.0 && y.abs() <= 1.0).then_some((x, y, z))
        })
        .collect();
    if pts.len() < 16 {
        return Err(KamiError::Data {
            path: source.into(),
            line: None,
            message: format!(
                "{} strand points are in the camera's frame at frame 0 (16 needed): the bench \
                 cannot aim a close-up at the hair; point `camera` at it",
                pts.len()
            ),
        });
    }
    let mut zs: Vec<f64> = pts.iter().map(|p| p.2).collect();
    let z_mid = quantile(&mut zs, 0.5);
    let near: Vec<_> = pts.iter().filter(|p| p.2 <= z_mid).collect();
    let mut nx: Vec<f64> = near.iter().map(|p| p.0).collect();
    let mut ny: Vec<f64> = near.iter().map(|p| p.1).collect();
    let (cx, cy) = (quantile(&mut nx, 0.5), quantile(&mut ny, 0.5));
    let mut xs: Vec<f64> = pts.iter().map(|p| p.0).collect();
    let mut ys: Vec<f64> = pts.iter().map(|p| p.1).collect();
    let (x0, x1) = (quantile(&mut xs, 0.05), quantile(&mut xs, 0.95));
    let (y0, y1) = (quantile(&mut ys, 0.05), quantile(&mut ys, 0.95));
    // Half the window's height in NDC (its half-width in x is the same, the aspect kept).
    let s = (0.5 * CLOSE_SHARE * (x1 - x0).min(y1 - y0)).clamp(1e-3, 1.0);
    let keep = |c: f64, lo: f64, hi: f64| {
        if hi - lo > 2.0 * s {
            c.clamp(lo + s, hi - s)
        } else {
            0.5 * (lo + hi)
        }
    };
    let (cx, cy) = (keep(cx, x0, x1), keep(cy, y0, y1));
    let ray = fwd + cx * t * aspect * right + cy * t * up;
    Ok(CameraDesc {
        eye: c.eye,
        // On the centre ray at the near side's median depth (clip planes stay the scene's).
        target: (eye + z_mid * ray).to_array(),
        up: c.up,
        fov_y: (2.0 * (s * t).atan()).to_degrees(),
    })
}
