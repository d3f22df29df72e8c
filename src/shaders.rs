//! Every WGSL module, embedded at compile time. WGSL has no includes, so a module is its
//! `shaders/common/*.wgsl` pieces followed by its own file (`shaders/<owner>/<stem>.wgsl`,
//! the same stem as the Rust module that runs it). The stage's modules are listed here;
//! each hair system lists its own in its `Kind`, and the stage assembles the registry
//! (`stage::shaders`): this module sits below everything that includes WGSL, so it names
//! no kind. `tests/it/shader_validation.rs` runs naga over every module in the registry
//! without a GPU, and checks that every file under `shaders/` is in one.

/// Concatenate shader files (paths under `shaders/`) into one WGSL source.
macro_rules! wgsl {
    // A simulation kernel: the world it binds at group 3 (`shaders/common/world.wgsl`, with
    // the EFF and head-hull functions that read it) before the kernel's own files.
    (world; $($file:literal),+ $(,)?) => {
        $crate::shaders::wgsl!(
            "forces/eff.wgsl",
            "common/ellipsoid.wgsl",
            "common/sdf.wgsl",
            "common/world.wgsl",
            $($file),+
        )
    };
    // A kind's compute rasteriser for thin strands over a scene depth (`depth`:
    // "common/depth_single.wgsl" or "common/depth_msaa.wgsl"): the shared kernels
    // (`common/splat.wgsl`) after the kind's files, which give it its strands and nodes.
    (splat $depth:literal; $($file:literal),+ $(,)?) => {
        $crate::shaders::wgsl!(
            $depth,
            "common/strands.wgsl",
            "common/frame.wgsl",
            "common/shadow.wgsl",
            "common/hair_bsdf.wgsl",
            "common/strand_drawn.wgsl",
            $($file),+,
            "common/splat.wgsl",
        )
    };
    ($($file:literal),+ $(,)?) => {
        concat!($(include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/shaders/", $file)), "\n"),+)
    };
}
pub(crate) use wgsl;

/// The head ellipsoid.
pub const HEAD: &str = wgsl!("common/frame.wgsl", "common/shadow.wgsl", "stage/head.wgsl");

/// The physical shading mode's hair BSDF alone (each kind's shading modules include it; the
/// contract test `tests/it/hair_bsdf.rs` adds a compute entry point).
pub const HAIR_BSDF: &str = wgsl!("common/hair_bsdf.wgsl");

/// Per-strand variation alone with the hash it reads (the strand shaders include it; the
/// contract test `tests/it/look_variation.rs` adds a compute entry point).
pub const STRAND_VARY: &str = wgsl!("common/random.wgsl", "common/strand_vary.wgsl");

/// The MSAA coverage mask of sub-pixel hair alone with the hash it reads (the hair draw
/// shaders include it; the contract test `tests/it/coverage.rs` adds a compute entry point).
pub const COVERAGE_MASK: &str = wgsl!("common/random.wgsl", "common/coverage_mask.wgsl");

/// Supersampling resolve.
pub const DOWNSAMPLE: &str = wgsl!("stage/downsample.wgsl");

/// The stage's own modules (the registry, `stage::shaders`, adds the forces' and every
/// kind's).
pub const STAGE: &[(&str, &str)] = &[
    ("stage/head", HEAD),
    ("stage/downsample", DOWNSAMPLE),
    ("stage/shadow", SHADOW),
    ("stage/bandwidth", BANDWIDTH),
];

/// `kami bench scale`'s bandwidth probe: a vec4 streaming copy in compute.
pub const BANDWIDTH: &str = wgsl!("stage/bandwidth.wgsl");

/// The shadow pass's resolve and probe (`stage::shadow`).
pub const SHADOW: &str = wgsl!(
    "common/frame.wgsl",
    "common/shadow.wgsl",
    "stage/shadow.wgsl"
);
