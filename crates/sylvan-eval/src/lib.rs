//! sylvan-eval
