//! One module per subcommand.

pub mod bench;
pub mod gen;
pub mod import;
pub mod merge;
pub mod simulate;
pub mod solve;
pub mod view;
