//! The `lamina` command line: one module per subcommand.

pub mod bench_effects;
pub mod bench_yardstick;
pub mod demo;
pub mod fit;
pub mod generate;
pub mod haptic_link;
pub mod machine;
pub mod plot;
pub mod profile;
pub mod publish;
pub mod run;
pub mod study;
pub mod yardstick_cmd;
