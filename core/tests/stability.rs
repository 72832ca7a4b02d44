//! The hard cases of `lamina study stability`, one test each: every integrator, and multirate
//! stepping, stays finite and bounded and never holds more energy than was put in.

use lamina_core::solver::IntegratorKind;
use lamina_core::study::{
    MULTIRATE_ROW, StabilityCase, StabilityRow, coupling_sweep, run_case, run_case_multirate, stability_cases,
};

/// The case's row with every integrator, then with multirate stepping.
fn rows(case: &StabilityCase) -> impl Iterator<Item = StabilityRow> + '_ {
    IntegratorKind::ALL.into_iter().map(|k| run_case(case, k)).chain(std::iter::once(run_case_multirate(case)))
}

fn check(name: &str) -> Vec<StabilityRow> {
    let cases = stability_cases();
    let case = cases.iter().find(|c| c.name == name).expect("case exists");
    rows(case)
        .inspect(|row| {
            assert!(row.finite, "{name}/{}: non-finite state", row.integrator);
            assert!(row.max_displacement_m < 0.3, "{name}/{}: unbounded, {} m", row.integrator, row.max_displacement_m);
            assert!(
                row.energy_excess < 0.05,
                "{name}/{}: energy grew beyond the work put in: {}",
                row.integrator,
                row.energy_excess
            );
        })
        .collect()
}

/// The case at `ratio` stays finite and bounded with every integrator and with multirate
/// stepping, and really reaches the ratio: skin springs in their stiff phase, the stiffest
/// tangent `ratio` times the softest (fat's). Energy never exceeds the work put in for the
/// rows `energy_bounded` names (by integrator name).
fn check_ratio(name: &str, ratio: f64, energy_bounded: fn(&str) -> bool) {
    let cases = stability_cases();
    let case = cases.iter().find(|c| c.name == name).expect("case exists");
    for row in rows(case) {
        assert!(row.finite && row.max_displacement_m < 0.3, "{row:?}");
        assert_eq!((row.frozen, row.rollbacks), (0, 0), "{row:?}");
        if energy_bounded(row.integrator) {
            assert!(row.energy_excess < 0.05, "energy grew beyond the work put in: {row:?}");
        }
        assert!(row.stiff_phase_springs > 0, "the pull put skin springs into their stiff phase: {row:?}");
        let reached = row.loaded_stiffness_ratio / ratio;
        assert!(
            (0.99..=1.01).contains(&reached),
            "loaded ratio {} against {ratio}: {row:?}",
            row.loaded_stiffness_ratio
        );
    }
}

// Multirate stepping stays finite and bounded in the stiffness-ratio cases but is not held to
// the energy bound: every exchange moves the region's ring to the bulk's state in one jump, and
// with skin 10^4-10^6 times stiffer than fat the jump loads the ring's skin springs (energy
// excess 0.30, 0.80 and 0.98 of the energy scale at 1e4, 1e5 and 1e6; 3 cm region, ratio 8).
#[test]
fn stiffness_ratio_1e4_stays_stable_works() {
    check_ratio("stiffness_ratio_1e4", 1e4, |k| k != MULTIRATE_ROW);
}

#[test]
fn stiffness_ratio_1e5_stays_stable_works() {
    check_ratio("stiffness_ratio_1e5", 1e5, |k| k != MULTIRATE_ROW);
}

#[test]
fn stiffness_ratio_1e6_stays_stable_works() {
    // At 10^6, symplectic Euler and velocity Verlet (290 sub-steps at 0.9 of the critical
    // step) gain energy of the order of the energy scale while springs cross their turning
    // point near rest, and stay bounded; RK4 and the implicit schemes do not.
    check_ratio("stiffness_ratio_1e6", 1e6, |k| {
        !matches!(IntegratorKind::parse(k), Some(IntegratorKind::SymplecticEuler | IntegratorKind::VelocityVerlet))
            && k != MULTIRATE_ROW
    });
}

#[test]
fn step_10x_explicit_limit_substeps_automatically_works() {
    for row in check("step_10x_explicit_limit") {
        if !IntegratorKind::parse(row.integrator).is_some_and(IntegratorKind::is_explicit) {
            assert_eq!(row.substeps, 1, "implicit schemes take the frame in one step: {row:?}");
        } else {
            assert!(
                row.substeps > 1 && row.substep_over_critical <= 1.0,
                "explicit schemes must sub-step below their limit: {row:?}"
            );
        }
        assert_eq!(row.rollbacks, 0, "{row:?}");
    }
}

#[test]
fn fixed_step_10x_explicit_limit_is_caught_by_the_guard_works() {
    // One explicit step at 10x the critical step per frame: frames go bad, the guard rolls
    // them back and re-steps them (more sub-steps, then implicit Euler); implicit schemes need
    // no rollback. The
    // guard judges a frame by speed and displacement caps, so an explicit frame can gain some
    // energy and still pass: the energy bound holds for the implicit schemes only here.
    let cases = stability_cases();
    let case = cases.iter().find(|c| c.name == "fixed_step_10x_explicit_limit").expect("case exists");
    for row in rows(case) {
        assert!(row.finite && row.max_displacement_m < 0.3, "the guard keeps it bounded: {row:?}");
        assert_eq!(row.substeps, 1, "{row:?}");
        if IntegratorKind::parse(row.integrator).is_some_and(IntegratorKind::is_explicit) {
            assert!(row.substep_over_critical > 2.0, "the step really is beyond the limit: {row:?}");
            assert!(row.rollbacks > 0, "the guard caught the explicit steps: {row:?}");
            assert_eq!(row.rollbacks, row.by_substeps + row.by_implicit + row.frozen, "{row:?}");
        } else {
            assert_eq!(row.rollbacks, 0, "implicit schemes are stable at 10x: {row:?}");
            assert!(row.energy_excess < 0.05, "{row:?}");
        }
    }
}

#[test]
fn fixed_step_10x_without_guard_diverges_explicit_only_fails() {
    let cases = stability_cases();
    let case = cases.iter().find(|c| c.name == "fixed_step_10x_unguarded").expect("case exists");
    for row in rows(case) {
        if IntegratorKind::parse(row.integrator).is_some_and(IntegratorKind::is_explicit) {
            assert!(!row.finite || row.max_displacement_m > 1.0, "an explicit step at 10x its limit diverges: {row:?}");
        } else {
            assert!(row.finite && row.max_displacement_m < 0.3, "implicit schemes stay bounded: {row:?}");
            assert!(row.energy_excess < 0.05, "{row:?}");
        }
    }
}

#[test]
fn pull_3x_rest_length_stays_stable_works() {
    for row in check("pull_3x_rest_length") {
        assert!(row.max_stretch_ratio > 3.0, "the case must really pull past 3x: {row:?}");
    }
}

#[test]
fn zero_length_and_inverted_springs_stay_stable_works() {
    check("zero_length_and_inverted_springs");
}

#[test]
fn coincident_nodes_stay_stable_works() {
    check("coincident_nodes");
}

#[test]
fn tool_through_skin_stays_stable_works() {
    for row in check("tool_through_skin") {
        // The 5 mm sphere meets the skin's point shell with a penalty pressure of (300 N/m) per
        // node's share of skin, at most ~0.17 N before it is through (pi k h d^2 peaks at
        // d = 2r/3): it pushes the skin millimetres, not centimetres.
        assert!(row.max_displacement_m > 0.001, "the tool really pushed the tissue aside: {row:?}");
    }
}

#[test]
fn sudden_large_load_stays_stable_works() {
    check("sudden_large_load");
}

/// Multirate stepping beside single-rate `implicit_factored` where its coupling holds (the
/// region's radius swept over 2.5-5 cm of the 9 x 5 cm block): a sudden load at ratio 8, and
/// skin 10^4 times stiffer than fat at ratio 2. At ratio 8 and 20 the stiff skin keeps the two
/// halves apart (`lamina study stability`, docs/accuracy-and-stability.md).
#[test]
fn multirate_follows_single_rate_where_its_coupling_holds_works() {
    let cases = stability_cases();
    let case = |name| cases.iter().find(|c| c.name == name).expect("case exists");
    let radii = [0.025, 0.03, 0.035, 0.04, 0.045, 0.05];
    // Measured (f32, 2 s): the sudden load within 1.1e-4 m of single-rate (its largest
    // displacement 1.4e-2 m), kinetic energy at most 2.1e-7 J; the stiff skin within 5.7e-4 m,
    // at most 5.9e-6 J. Where the coupling fails, 1e-3 to 0.3 J and up to 0.12 m.
    for row in coupling_sweep(case("sudden_large_load"), &radii, &[8], 2.0) {
        assert!(row.late_deviation_m < 0.02 * row.single_max_displacement_m, "{row:?}");
        assert!(row.late_kinetic_j < 1e-6, "{row:?}");
    }
    for row in coupling_sweep(case("stiffness_ratio_1e4"), &radii, &[2], 2.0) {
        assert!(row.late_deviation_m < 1e-3, "{row:?}");
        assert!(row.late_kinetic_j < 1e-4, "{row:?}");
        assert!(row.late_coupling_gap_m < 1e-4, "{row:?}");
    }
}

/// Where the coupling fails, the run says so: the 10^4 skin at ratio 8, whose deviation from
/// single-rate `implicit_factored` reaches centimetres from a 4 cm region up, reports a coupling
/// gap (the two halves' distance apart where both step, known to the run without a
/// single-rate run beside it) above 1 mm exactly there, and below it where the deviation stays
/// within 3 mm (measured: 5.2-27 mm against 0.09-0.21 mm).
#[test]
fn multirate_coupling_gap_flags_a_failing_coupling_works() {
    let cases = stability_cases();
    let case = cases.iter().find(|c| c.name == "stiffness_ratio_1e4").expect("case exists");
    let rows = coupling_sweep(case, &[0.025, 0.03, 0.035, 0.04, 0.045, 0.05], &[8], 2.0);
    assert!(rows.iter().any(|r| r.late_deviation_m > 0.01), "the sweep holds a failing coupling: {rows:?}");
    for row in &rows {
        if row.late_deviation_m > 0.01 {
            assert!(row.late_coupling_gap_m > 1e-3, "a failing coupling unflagged: {row:?}");
        } else if row.late_deviation_m < 3e-3 {
            assert!(row.late_coupling_gap_m < 1e-3, "a holding coupling flagged: {row:?}");
        }
    }
}
