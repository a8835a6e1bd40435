//! Errors a user can cause (bad files, bad options) and ones the machine can (no adapter).

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("{path}: {message}")]
    Scene { path: PathBuf, message: String },
    #[error("{0}")]
    Options(String),
    #[error(
        "no GPU adapter found (Vulkan, Metal or DX12). On Debian/Ubuntu without a GPU driver, \
         install Mesa's software Vulkan (lavapipe): sudo apt-get install mesa-vulkan-drivers"
    )]
    NoAdapter,
    #[error("GPU error: {0}")]
    Gpu(String),
    #[error("{path}: {message}")]
    Output { path: PathBuf, message: String },
}

pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    pub fn scene(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Error::Scene { path: path.into(), message: message.into() }
    }
}
