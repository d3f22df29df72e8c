//! Library errors. Every failure a user can cause (a bad scene, a missing adapter, a scene
//! too large for the GPU) is a variant here with a message that says what to change; the
//! binary adds context with `anyhow`.

use std::path::PathBuf;

/// Errors from loading, grooming and rendering scenes.
#[derive(Debug, thiserror::Error)]
pub enum KamiError {
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },

    /// RON syntax or type error, with the place it broke.
    #[error("{path}:{line}:{col}: {message}")]
    Parse {
        path: String,
        line: usize,
        col: usize,
        message: String,
    },

    /// A value that parsed but is not allowed; `file` names the scene file when it came
    /// from one (empty for scenes built in code).
    #[error(
        "invalid scene{}: `{field}` = {value}: {allowed}",
        if file.is_empty() { String::new() } else { format!(" {file}") }
    )]
    Invalid {
        file: String,
        field: String,
        value: String,
        allowed: String,
    },

    #[error(
        "no GPU adapter found{backend_note}. Kami runs on software adapters too: install \
         Mesa's llvmpipe (`apt-get install -y libegl-mesa0 libgl1-mesa-dri`) for OpenGL or \
         lavapipe (`apt-get install -y mesa-vulkan-drivers`) for Vulkan, or unset KAMI_BACKEND"
    )]
    NoAdapter { backend_note: String },

    #[error("KAMI_BACKEND={0:?} is not a backend Kami knows: use `vulkan`, `gl`, `metal`, `dx12` or leave it unset")]
    BadBackend(String),

    #[error("the GPU device could not be created: {0}")]
    Device(String),

    /// The scene needs more than the adapter allows (buffer, texture or dispatch size).
    #[error("{what} needs {needed}, but this adapter allows at most {limit}: {hint}")]
    TooLarge {
        what: String,
        needed: u64,
        limit: u64,
        hint: String,
    },

    /// A GPU operation failed (validation error, device lost, readback failure).
    #[error("GPU error: {0}")]
    Gpu(String),

    #[error("cannot write image {path}: {message}")]
    Image { path: PathBuf, message: String },

    /// A mesh file that cannot be used, with the line where it broke when known.
    #[error("mesh {path}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Mesh {
        path: String,
        line: Option<usize>,
        message: String,
    },

    /// A data file that cannot be used (marker CSV, EFF grid, BVH capture, strand file),
    /// with the line (1-based) where it broke when known.
    #[error("{path}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Data {
        path: String,
        line: Option<usize>,
        message: String,
    },

    /// The viewer's window or surface could not be created.
    #[error("window: {0}")]
    Window(String),

    /// A command-line option that cannot be applied (`--set` with an unknown key or bad
    /// value, a bench's options that contradict each other).
    #[error("{0}")]
    Option(String),
}

pub type Result<T, E = KamiError> = std::result::Result<T, E>;
