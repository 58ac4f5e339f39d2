//! One module per subcommand, and the scene loading `simulate` and `export` share.

pub mod bench;
pub mod bench_one;
pub mod export;
pub mod gen;
pub mod import;
pub mod merge;
pub mod report;
pub mod simulate;
pub mod solve;
pub mod view;
mod world;
