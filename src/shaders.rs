//! Every WGSL module, embedded at compile time. WGSL has no includes, so a module is its
//! `shaders/common/*.wgsl` pieces followed by its own file (same stem as its Rust module).
//! `tests/shader_validation.rs` runs naga over each entry of `ALL` without a GPU.

macro_rules! wgsl {
    ($($file:literal),+ $(,)?) => {
        concat!($(include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/shaders/", $file)), "\n"),+)
    };
}

/// Cantilever bending (groom).
pub const CANTILEVER: &str = wgsl!(
    "common/strands.wgsl",
    "common/ellipsoid.wgsl",
    "common/rotate.wgsl",
    "common/loads.wgsl",
    "cantilever.wgsl",
);

/// Projective dynamics (Anjyo section 3).
pub const PROJECTIVE: &str = wgsl!(
    "common/ellipsoid.wgsl",
    "common/rotate.wgsl",
    "common/random.wgsl",
    "projective.wgsl",
);

/// Fur generation (Van Gelder & Wilhelms).
pub const FUR_GEN: &str = wgsl!(
    "common/ellipsoid.wgsl",
    "common/random.wgsl",
    "common/deform.wgsl",
    "fur_gen.wgsl",
);

/// Fur drawing: ribbons and tubes with Van Gelder & Wilhelms' shading normals.
pub const FUR: &str = wgsl!(
    "common/strands.wgsl",
    "common/frame.wgsl",
    "common/random.wgsl",
    "common/coverage.wgsl",
    "fur.wgsl",
);

/// The fur mesh's skin.
pub const MESH: &str = wgsl!("common/frame.wgsl", "common/deform.wgsl", "mesh.wgsl");

/// Hair ribbons with Anjyo's anisotropic specular.
pub const STRANDS: &str = wgsl!(
    "common/strands.wgsl",
    "common/frame.wgsl",
    "common/random.wgsl",
    "common/coverage.wgsl",
    "strands.wgsl",
);

/// The head ellipsoid.
pub const HEAD: &str = wgsl!("common/frame.wgsl", "head.wgsl");

/// Supersampling resolve.
pub const DOWNSAMPLE: &str = wgsl!("downsample.wgsl");

/// (name, source) of every module, for validation.
pub const ALL: &[(&str, &str)] = &[
    ("cantilever", CANTILEVER),
    ("projective", PROJECTIVE),
    ("fur_gen", FUR_GEN),
    ("fur", FUR),
    ("mesh", MESH),
    ("strands", STRANDS),
    ("head", HEAD),
    ("downsample", DOWNSAMPLE),
];
