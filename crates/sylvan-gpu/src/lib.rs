//! sylvan-gpu
