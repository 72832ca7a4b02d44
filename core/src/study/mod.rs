//! Measuring the solver: accuracy against time, stability in hard cases, the limb's
//! indentation force against published tissue, and how an incision gapes.
//!
//! Both studies are library code so that the `lamina study` commands and the tests run the
//! very same cases.

mod accuracy;
mod coupling;
mod energy;
mod incision;
mod indentation;
mod reference;
mod stability;

pub use accuracy::{
    AccuracyCase, AccuracyRow, AccuracyStudy, PRESS_DEPTH_M, REFERENCE_TOLERANCE, ReferenceSummary, accuracy_study,
};
pub use coupling::{CouplingRow, coupling_sweep};
pub use energy::{EnergyBreakdown, EnergyLedger, mechanical_energy};
pub use incision::{INCISION_FACTOR_TICKS, IncisionCase, IncisionError, IncisionResult, incision_study};
pub use indentation::{
    IndentationCurve, IndentationError, PUBLISHED_MODULI, PublishedModulus, TISSUE_POISSON, effective_modulus,
    hertz_force, indentation, indentation_of_model,
};
pub use reference::{MAX_REFERENCE_STEPS, Reference, ReferenceError, max_distance};
pub use stability::{
    MULTIRATE_ROW, StabilityCase, StabilityRow, multirate_settings, run_case, run_case_multirate, stability_cases,
};
