//! The fitted default limb pressed by its sphere: the force grows with depth and, brought to
//! an effective modulus by Hertz contact, lies inside the published range of in-vivo
//! indentation moduli of lower-limb soft tissue (Zheng & Mak 1999: initial moduli 0.22-58.4
//! kPa).

use lamina_core::scene::Scene;
use lamina_core::study::{PUBLISHED_MODULI, effective_modulus, indentation};

#[test]
fn default_limb_indentation_is_inside_the_published_range_works() {
    let scene = Scene::builtin_default();
    let (radius, curves) = indentation(&scene, 1, 10).unwrap();
    let c = &curves[0];
    assert_eq!(c.force_n.len(), 10);
    assert!(c.force_n.iter().all(|f| f.is_finite() && *f > 0.0), "{:?}", c.force_n);
    assert!(c.force_n[9] > c.force_n[4] && c.force_n[4] > c.force_n[0], "{:?}", c.force_n);
    let lowest = PUBLISHED_MODULI.iter().map(|m| m.modulus_pa).fold(f64::INFINITY, f64::min);
    let highest = PUBLISHED_MODULI.iter().map(|m| m.modulus_pa).fold(0.0, f64::max);
    for (d, f) in c.depth_m.iter().zip(&c.force_n) {
        let e = effective_modulus(*f, radius, *d);
        assert!(e > lowest && e < highest, "{} mm: effective modulus {e} Pa", d * 1e3);
    }
}
