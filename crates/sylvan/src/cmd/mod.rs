//! One module per subcommand: flags → validated config → library calls.

pub mod bake;
pub mod bench;
pub mod common;
pub mod compare;
pub mod params;
pub mod plant;
pub mod render;
pub mod stats;
pub mod view;
