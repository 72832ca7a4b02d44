//! The `lamina` command line: one module per subcommand.

pub mod bench_effects;
pub mod bench_yardstick;
pub mod machine;
pub mod run;
pub mod yardstick_cmd;
