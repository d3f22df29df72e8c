//! Every WGSL module, embedded at compile time. WGSL has no includes, so a module is its
//! `shaders/common/*.wgsl` pieces followed by its own file (`shaders/<owner>/<stem>.wgsl`,
//! the same stem as the Rust module that runs it). The stage's modules are listed here;
//! each hair system lists its own in its `Kind`. `tests/shader_validation.rs` runs naga
//! over every module in `all()` without a GPU, and checks that every file under `shaders/`
//! is in one.

/// Concatenate shader files (paths under `shaders/`) into one WGSL source.
macro_rules! wgsl {
    ($($file:literal),+ $(,)?) => {
        concat!($(include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/shaders/", $file)), "\n"),+)
    };
}
pub(crate) use wgsl;

/// The head ellipsoid.
pub const HEAD: &str = wgsl!("common/frame.wgsl", "stage/head.wgsl");

/// Supersampling resolve.
pub const DOWNSAMPLE: &str = wgsl!("stage/downsample.wgsl");

/// The stage's own modules.
pub const STAGE: &[(&str, &str)] = &[
    ("stage/head", HEAD),
    ("stage/downsample", DOWNSAMPLE),
    ("forces/eff", crate::forces::eff::EFF_MODULE),
];

/// (path, source) of every module: the stage's and every hair system's.
pub fn all() -> Vec<(&'static str, &'static str)> {
    let mut all = STAGE.to_vec();
    for kind in crate::systems::KINDS {
        all.extend_from_slice(kind.shaders);
    }
    all
}
