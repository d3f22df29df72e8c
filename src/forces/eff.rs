//! The External Force Field (Kazama et al. section 3.3): a voxel grid of wind forces around
//! the head. STUB: the EFF helper fills this file (see the contract in its brief); the
//! signatures below are the contract other modules code against.

use crate::error::Result;
use crate::scene::strips::Sampling;
use glam::DVec3;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The scene's EFF block.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffDesc {
    /// Centre of the grid (world units).
    #[serde(default)]
    pub center: [f64; 3],
    /// Edge length of the cubic grid (60 cm in the paper).
    #[serde(default = "default_extent")]
    pub extent: f64,
    /// Cells per axis.
    #[serde(default = "default_resolution")]
    pub resolution: [u32; 3],
}

fn default_extent() -> f64 {
    60.0
}
fn default_resolution() -> [u32; 3] {
    [12, 12, 12]
}

/// A built grid: every cell has a force.
#[derive(Clone, Debug, PartialEq)]
pub struct Eff {
    pub desc: EffDesc,
}

impl Eff {
    /// Build the grid from the scene block (cells filled by the paper's two rules).
    pub fn build(desc: &EffDesc) -> Result<Eff> {
        Ok(Eff { desc: desc.clone() })
    }

    /// The force at world point `p` (outside the grid: the outside force).
    pub fn sample(&self, _p: DVec3, _sampling: Sampling) -> DVec3 {
        DVec3::ZERO
    }
}

/// Read files the block names (relative to `dir`, the scene file's folder) so that building
/// the grid cannot fail later; errors name the file.
pub fn resolve(_desc: &mut EffDesc, _dir: &Path) -> Result<()> {
    Ok(())
}
