//! The renderer's error type.

/// Errors from preparing or drawing a frame. Display is one line with a fix.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// GPU-side failure or limit.
    #[error(transparent)]
    Gpu(#[from] sylvan_gpu::GpuError),
    /// A plant could not be loaded or is malformed.
    #[error("{0}")]
    Plant(String),
    /// `--technique` names nothing known.
    #[error(
        "unknown technique '{0}' — use one of: geometry, boxtree, hbt, billboard-cloud, zfield, shadermap, auto"
    )]
    UnknownTechnique(String),
    /// A known technique that this build does not implement yet.
    #[error("technique '{0}' is not implemented yet — use --technique geometry")]
    NotImplemented(&'static str),
    /// An invalid option value.
    #[error("{0}")]
    Option(String),
}
