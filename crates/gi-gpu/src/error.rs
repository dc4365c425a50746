//! The one error type of the GPU crate.

use thiserror::Error;

/// Everything that can go wrong while setting up the GPU, composing shaders or reading results
/// back. Validation errors of recorded commands are not here: wgpu reports those through the
/// device's uncaptured-error handler, which panics, because they are programming errors.
#[derive(Debug, Error)]
pub enum GpuError {
    /// No Vulkan adapter matched (or none exists at all).
    #[error(
        "no Vulkan adapter found{filter}; install mesa-vulkan-drivers and libvulkan1 for the \
         software rasterizer (lavapipe), or check the GPU driver",
        filter = .filter.as_ref().map(|f| format!(" whose name contains {f:?} (from GI_ADAPTER or the options)")).unwrap_or_default()
    )]
    NoAdapter {
        /// The adapter-name filter that was applied, if any.
        filter: Option<String>,
    },

    /// The adapter cannot provide a limit the product needs.
    #[error("adapter limit `{limit}` is {available}, but at least {needed} is needed")]
    LimitTooSmall {
        /// The `wgpu::Limits` field name.
        limit: &'static str,
        /// The value the options ask for.
        needed: u64,
        /// The value the adapter offers.
        available: u64,
    },

    /// The adapter lacks a feature the options require.
    #[error("adapter lacks required features {0:?}")]
    MissingFeature(wgpu::Features),

    /// The adapter refused to create a device.
    #[error("device request failed: {0}")]
    RequestDevice(String),

    /// A shader failed to load, compose or validate. `file` is relative to `shaders/`; `line` is
    /// 1-based, or 0 when the error has no source location (for example a missing file).
    #[error("{file}:{line}: {message}")]
    Shader {
        /// The shader file the error is located in (an imported module's file when the error
        /// lies there).
        file: String,
        /// 1-based line number of the error, 0 when unknown.
        line: u32,
        /// The full diagnostic, with the offending source line where one exists.
        message: String,
    },

    /// Reading a buffer back to the CPU failed.
    #[error("reading back buffer failed: {0}")]
    Readback(String),
}
