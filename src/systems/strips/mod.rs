//! Kazama, Sugisaki and Morishima's directable strips: the Hair Object Model (layered reed
//! strips, `hom`), its motion on damped angular springs (eq 1; the f64 reference in
//! `dynamics`, the WGSL kernel in `dynamics_gpu`), ribbons built on the GPU from the control
//! points and drawn with a generated strand texture (`ribbon`, `texture`), the marker
//! capture round trip that fits the EFF (`capture`) and key-frame editing (`keyframe`).

pub mod capture;
pub mod dynamics;
pub mod dynamics_gpu;
pub mod hom;
pub mod panel;
pub mod ribbon;
pub mod texture;

use glam::DVec3;

/// One strip of the Hair Object Model at rest, in the head's rest frame: what `hom` builds
/// from the scene's layers and what the dynamics and the ribbons start from.
#[derive(Clone, Debug, PartialEq)]
pub struct RestStrip {
    /// Index of its layer in `Strips::layers`.
    pub layer: u32,
    /// Control points, root first (`sticks + 1` of them); the root lies on the head.
    pub points: Vec<DVec3>,
    /// Outward head normal at the root (the chain's first stick is measured from it).
    pub normal: DVec3,
    /// Ribbon width at the root and at the tip.
    pub width: [f64; 2],
    /// Multiplier of the motion's stiffness (the layer's).
    pub stiffness: f64,
    pub color: [f32; 3],
}
