//! One module per subcommand: flags → validated config → library calls.

pub mod compare;
pub mod plant;
