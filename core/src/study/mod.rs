//! Measuring the solver: accuracy against time, and stability in hard cases.
//!
//! Both studies are library code so that the `lamina study` commands and the tests run the
//! very same cases.

mod accuracy;
mod energy;
mod stability;

pub use accuracy::{AccuracyCase, AccuracyRow, accuracy_study};
pub use energy::{EnergyBreakdown, EnergyLedger, mechanical_energy};
pub use stability::{StabilityCase, StabilityRow, run_case, stability_cases};
