//! Measuring the solver: accuracy against time, and stability in hard cases.
//!
//! Both studies are library code so that the `lamina study` commands and the tests run the
//! very same cases.

mod accuracy;
mod energy;
mod reference;
mod stability;

pub use accuracy::{
    AccuracyCase, AccuracyRow, AccuracyStudy, PRESS_DEPTH_M, REFERENCE_TOLERANCE, ReferenceSummary, accuracy_study,
};
pub use energy::{EnergyBreakdown, EnergyLedger, mechanical_energy};
pub use reference::{MAX_REFERENCE_STEPS, Reference, ReferenceError, max_distance};
pub use stability::{StabilityCase, StabilityRow, run_case, stability_cases};
