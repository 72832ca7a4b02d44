//! The living limb (config/scenes/limb-in-vivo.toml) pressed by its sphere against the in-vivo band of
//! `config/materials/indentation.toml` (2-9 N at 8 mm under a 12 mm sphere, derived by Hertz
//! contact from published lower-limb moduli; secant stiffness at 8 mm at least twice the one at
//! 2 mm), at three sites around the limb; and the press refused where Hertz contact no longer
//! holds.

use lamina_core::fit::{IndentationTargets, indentation_psi, press_candidate};
use lamina_core::scene::Scene;
use lamina_core::study::{IndentationError, indentation};

fn living_limb() -> Scene {
    Scene::load(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/scenes/limb-in-vivo.toml"))
        .expect("the living limb scene")
}

#[test]
fn living_limb_indentation_is_inside_the_in_vivo_band_works() {
    let scene = living_limb();
    let targets = IndentationTargets::shipped();
    let (radius, curves) = indentation(&scene, 3, 8).unwrap();
    assert_eq!(radius, targets.sphere_radius_m);
    assert_eq!(curves.len(), 3);
    for c in &curves {
        assert!(c.force_n.windows(2).all(|w| w[1] > w[0]), "{}: force rises with depth {:?}", c.site, c.force_n);
        let check = targets.band.check(&c.depth_m, &c.force_n).expect("reaches 8 mm");
        assert!(check.force_in_band, "{}: {:.3} N at 8 mm, band 2-9 N", c.site, check.force_n);
        assert!(check.stiffens, "{}: secant ratio {:.2}, at least 2", c.site, check.secant_ratio);
    }
}

#[test]
fn fat_and_muscle_compression_is_what_brings_the_limb_into_the_band_works() {
    // The same limb with fat and muscle as stiff in compression as in tension (the tensile fit
    // alone) is far below the band: the fitted compression, not the contact, carries the press.
    let scene = living_limb();
    let targets = IndentationTargets::shipped();
    let generated = scene.build_generated_model().unwrap();
    let tensile_only = press_candidate(&scene, &generated, 1.0, 1.0, 1, 8).unwrap().remove(0);
    let check = targets.band.check(&tensile_only.depth_m, &tensile_only.force_n).unwrap();
    assert!(check.force_n < 0.5 * targets.band.force_min_n, "{:.3} N", check.force_n);
    assert!(indentation_psi(&targets, &tensile_only) > 1.0);
}

#[test]
fn indentation_deeper_than_half_the_tissue_is_refused_fails() {
    // The default limb: 35 mm of soft tissue over the default limb's bone (37.7 mm to the nearest bone node): a 20
    // mm press is beyond Hertz contact.
    let scene = Scene::builtin_default();
    match indentation(&scene, 1, 20) {
        Err(IndentationError::TooDeep { depth_mm: 20, thickness_mm, .. }) => {
            assert!((35.0..40.0).contains(&thickness_mm), "{thickness_mm}")
        }
        other => panic!("{other:?}"),
    }
}
