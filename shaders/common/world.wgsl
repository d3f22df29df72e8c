// The world every simulation kernel binds at group 3: one bind group per scene, owned by the
// stage (`systems::world::WorldGpu`), uploaded once: the head's hull, the
// External Force Field's grid and cells, the mesh head's signed distance field; and per
// submission the samples of what changes within a frame (`world_steps`: gravity plus keyed
// wind, the gust scale, the head's pose), indexed from each kernel's own slot. A kernel's
// module is composed by `wgsl!(world; ...)` (src/shaders.rs): forces/eff.wgsl (EffGrid,
// eff_field), common/ellipsoid.wgsl and common/sdf.wgsl (HeadHull), which read the globals
// `eff`, `eff_cells` and `sdf_data` declared here, then this file, then the kernel's own.

// Twin of GpuWorld (tests/it/gpu_twins.rs checks it) in src/systems/world.rs.
struct World {
    // xyz the head ellipsoid's centre, w 1 when the hull is the SDF in sdf_data
    // (`HeadHull::gpu_params`).
    hull_center: vec4<f32>,
    // xyz the ellipsoid's radii, w 0.
    hull_radii: vec4<f32>,
}

// Twin of GpuWorldStep: the world at one time (fractional frames), evaluated once in f64
// by the stage's Forces (systems::world::WorldSteps::sample).
struct WorldStep {
    // xyz gravity + keyed wind (summed in f64), w the EFF's gust scale (0 without an EFF)
    force: vec4<f32>,
    // the head's pose and its inverse
    head: mat4x4<f32>,
    head_inv: mat4x4<f32>,
}

@group(3) @binding(0) var<uniform> world: World;
// The field at gust scale 1 (outside.w = 1): kernels scale it by their substep's gust.
@group(3) @binding(1) var<uniform> eff: EffGrid;
@group(3) @binding(2) var<storage, read> eff_cells: array<vec4<f32>>;
// The SDF's words (`HeadHull::gpu_sdf`; a placeholder on an ellipsoid head, never read).
@group(3) @binding(3) var<storage, read> sdf_data: array<f32>;
// This submission's samples; a kernel's own slot holds the indices it reads.
@group(3) @binding(4) var<storage, read> world_steps: array<WorldStep>;

// The scene's head hull (the SDF when world.hull_center.w = 1 and SDF_HEAD is on).
fn world_hull() -> HeadHull {
    return head_hull(world.hull_center, world.hull_radii);
}
