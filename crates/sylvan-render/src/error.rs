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
        "unknown technique '{0}' — use one of: {names}{hint}",
        names = crate::technique::registry::names().join(", "),
        hint = crate::technique::registry::nearest_hint(.0)
    )]
    UnknownTechnique(String),
    /// A technique parameter: unknown key, wrong type or out of range (the message names
    /// where it was set).
    #[error("{0}")]
    Param(String),
    /// An invalid option value.
    #[error("{0}")]
    Option(String),
}
