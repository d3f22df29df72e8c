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

/// The EFF on the GPU: `grid` is the `EffGrid` uniform of `shaders/forces/eff.wgsl`, `cells`
/// its storage buffer (one `vec4<f32>` per cell). A scene without an EFF gets a one-cell
/// grid flagged absent, so kernels bind the same layout either way.
pub struct EffGpu {
    pub grid: wgpu::Buffer,
    pub cells: wgpu::Buffer,
}

impl EffGpu {
    pub fn new(gpu: &crate::gpu::Gpu, _eff: Option<&Eff>) -> Result<EffGpu> {
        let grid = crate::gpu::storage_buffer(
            &gpu.device,
            "eff grid",
            &[0u8; 64],
            wgpu::BufferUsages::UNIFORM,
        );
        let cells = crate::gpu::storage_buffer(
            &gpu.device,
            "eff cells",
            &[0u8; 16],
            wgpu::BufferUsages::empty(),
        );
        Ok(EffGpu { grid, cells })
    }

    /// Write the grid's strength at `frame` (fractional).
    pub fn write(&self, _gpu: &crate::gpu::Gpu, _eff: Option<&Eff>, _frame: f64) {}
}

/// The EFF's WGSL, to concatenate before a kernel that samples it.
pub const EFF_WGSL: &str = crate::shaders::wgsl!("forces/eff.wgsl");
