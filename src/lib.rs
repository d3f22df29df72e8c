//! Kami (髪): a GPU viewer and simulator for hair, fur and toon hair.
//!
//! The flow of data: a scene file (`scene`) is validated, groomed on the CPU into roots
//! (`groom::prepare`), bent on the GPU (`groom::cantilever`), and drawn by the passes of
//! `render` into a window or an offscreen texture. Every GPU kernel has an f64 CPU reference
//! beside it, used by the tests and the benchmarks.

pub mod error;
pub mod groom;
pub mod rng;
pub mod scene;

pub use error::{KamiError, Result};
pub use scene::Scene;
pub mod app;
pub mod bench;
pub mod gpu;
pub mod plot;
pub mod render;
pub mod shaders;
pub mod sim;
