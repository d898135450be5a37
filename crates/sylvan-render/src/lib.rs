//! sylvan-render
