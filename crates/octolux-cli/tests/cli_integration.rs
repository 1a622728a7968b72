//! The command line's integration tests, one module per subject, built as one binary (one crate
//! to compile and link instead of one per file). Each runs the `octolux` binary.

mod common;

mod bad_input_cli;
mod bench_cli;
mod cli;
mod default_gi;
mod lpv_cli;
mod probes_cli;
mod readme_commands;
mod vct_cli;
mod vct_compare_cli;
mod view_cli;
mod vpl_cli;
