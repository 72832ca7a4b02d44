//! Incision with multirate stepping: the region about the blade at the tick rate, the whole
//! limb on its own thread. Both halves see every cut (the bulk at the next exchange), the region
//! follows the blade's tip along the cut and is built again off the loop after cuts, factored
//! without the cut springs, and the wound opens as it does single-rate. With `late_build =
//! "wait"` two runs give the same bits.

use lamina_core::scene::Scene;
use lamina_core::study::{IncisionCase, IncisionResult, incision_study};

/// The incision scene (the living limb with a scalpel), single-rate or with `multirate` as its
/// `[solver.multirate]` table.
fn incision_scene(multirate: Option<&str>) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/scenes/incision.toml");
    let text = std::fs::read_to_string(&path).expect("the incision scene");
    let text = match multirate {
        Some(table) => text.replacen("\n[effects]\n", &format!("\n[solver.multirate]\n{table}\n\n[effects]\n"), 1),
        None => text,
    };
    Scene::from_toml_str(&text, Some(&path)).expect("scene")
}

/// The region of 50 mm radius (the 24x6 limb's nodes are 15 mm apart) about the tool's device
/// origin, the bulk every 4 ticks, regions built about the tip taken 5 exchanges after asking,
/// waited for if late (not chosen from a timed build: the same exchanges every run).
const MULTIRATE: &str = "radius = 0.05\nratio = 4\nlate_build = \"wait\"\nbuild_exchanges = 5";

/// The opening of the cut outer-skin spring nearest the cut's middle (z = 0.12 m), m.
fn mid_gap(r: &IncisionResult) -> f64 {
    r.gaps.iter().min_by(|a, b| (a.0 - 0.12).abs().total_cmp(&(b.0 - 0.12).abs())).expect("a cut skin spring").1
}

#[test]
fn a_multirate_cut_opens_the_wound_as_single_rate_does_and_repeats_bit_for_bit_works() {
    let case = IncisionCase::default();
    let single = incision_study(&incision_scene(None), &case).expect("single-rate study");
    let multi = incision_study(&incision_scene(Some(MULTIRATE)), &case).expect("multirate study");
    assert!(single.finite && multi.finite);
    let status = multi.multirate.expect("multirate on");
    for (name, r) in [("single-rate", &single), ("multirate", &multi)] {
        let (cut, mid, max, res) = (r.springs_cut, 1e3 * mid_gap(r), 1e3 * r.max_gap(), r.residuals);
        eprintln!("{name}: cut {cut:?}, mid gap {mid:.3} mm, max {max:.3} mm, residuals {res:?}");
    }
    eprintln!("{status:?}");
    // The same blade through the same tissue: one puncture, skin and fat cut, muscle not.
    assert_eq!(multi.punctures, 1);
    assert!(
        multi.springs_cut[0] > 0 && multi.springs_cut[1] > 0 && multi.springs_cut[2] == 0,
        "{:?}",
        multi.springs_cut
    );
    // Every cut logged, and the region's factor holds them all once the limb has settled.
    let cuts: u64 = multi.springs_cut.iter().sum();
    assert_eq!(status.cuts as u64, cuts);
    assert_eq!(status.cuts_in_factor, status.cuts, "{status:?}");
    // The region followed the tip: moved more than once, and ends within a quarter of its
    // radius (12.5 mm) of the cut's far end (z = 0.145 m), 25 mm from where it started (the
    // device origin, mid-limb).
    assert!(status.recentres >= 2, "{status:?}");
    assert!((status.centre[2] - 0.145).abs() < 0.0126, "region centre {:?}", status.centre);
    // The same cut: the springs cut per tissue within two of single-rate's (the blade meets
    // a node a few hundredths of a millimetre elsewhere and takes one spring more or less).
    for k in 0..2 {
        let (s, m) = (single.springs_cut[k], multi.springs_cut[k]);
        assert!(s.abs_diff(m) <= 2, "tissue {k}: {s} single-rate, {m} multirate");
    }
    // The wound opens by millimetres, below the free sheet's closed form, within 35 % of
    // single-rate's mid-cut. On this coarse grid one spring more or less moves the opening
    // by that much: single-rate alone opens 2.40 mm after 0.5 s of settling and 1.75 mm after
    // 1.5 s, the multirate 1.95 and 2.36 mm.
    let (s, m) = (mid_gap(&single), mid_gap(&multi));
    let hi = multi.closed_form_gap_m.1;
    assert!(s > 0.001 && m > 0.001 && s < hi && m < hi, "mid gaps {s} m, {m} m (closed form {hi} m)");
    assert!((m - s).abs() <= 0.35 * s, "mid-cut gap: {s} m single-rate, {m} m multirate");
    // Two runs give the same bits.
    let again = incision_study(&incision_scene(Some(MULTIRATE)), &case).expect("multirate study");
    let bits = |r: &IncisionResult| r.final_positions.iter().flat_map(|p| p.map(f64::to_bits)).collect::<Vec<u64>>();
    assert!(bits(&multi) == bits(&again), "two multirate runs differ");
}
