//! Sakai's toon wisps: skeletons (`crate::scene::wisps`) interpolated by natural cubic
//! splines and converted to Bézier segments (`curve`), the blobby density around them
//! (`field`, the f64 reference of the ray march), mass springs with RK4 (`springs`, on the
//! GPU in `springs_gpu`) and the depth-camera fingertip tracker that draws skeletons
//! (`fingers`).

pub mod curve;
pub mod field;
pub mod fingers;
pub mod springs;
pub mod springs_gpu;
