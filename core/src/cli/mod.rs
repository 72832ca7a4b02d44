//! The `lamina` command line: one module per subcommand.

pub mod bench_yardstick;
pub mod machine;
pub mod yardstick_cmd;
